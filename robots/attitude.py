"""Attitude feedback from an IMU: body roll/pitch error → joint goal offsets on the stance legs.

Real servo humanoids balance with an IMU; an open-loop gait cannot correct the tilt that servo
compliance, latency and touchdown impacts build up. This module is the law, pure numpy, shared
by the simulator (`sim.attitude_loop`) and the player (`hardware.play.attitude`):

1. **Error.** e = (roll, pitch)_measured − (roll, pitch)_planned, both in the planner's z-y'-x''
   convention (`planner.nlp.rotations`: R = Rz(yaw)·Ry(pitch)·Rx(roll)), so a robot that has
   turned still reads its roll and pitch about its own heading. The plan's attitude comes from
   the gait file's ``base_pose`` (roll, pitch at each knot, linearly interpolated over the
   cycle), scaled by the entry blend weight α like the joints are (`robots.ramp`).
2. **Wanted body rotation.** ω = −G·e (rad; G is the dimensionless gain `AttitudeLaw.gain`):
   at G = 1 the offsets would, with stiff servos and the feet held, rotate the body exactly back
   onto its planned attitude; G < 1 corrects part of it each stream tick (a proportional law).
3. **Joint offsets from the kinematics** (`robots.attitude_maps`): the body rotation ω is
   applied about a pivot P with every stance foot held in place (flat feet: position and
   orientation; point feet: position). Each stance leg's joints follow by differential inverse
   kinematics,

       Δq_leg = −J_q,leg⁺ · J_b,leg · ξ,   ξ = (ω × (p_base − P), ω),

   with J_b, J_q the foot's Jacobian w.r.t. the floating base twist and the leg's joints at the
   robot's stance pose (computed once with MuJoCo). So the signs and the joints that act on
   each axis come from the model, not from joint names. The pivot is the base origin by default
   (`pivot_fraction` 1): the trunk turns about itself over the held feet, mostly through the
   hip servos — the *hip strategy* of human balance (Horak & Nashner 1986, J. Neurophysiol.
   55(6), 1369–1381), which acts through the trunk's inertia and still works when the stance
   foot has rolled onto a sole edge. `pivot_fraction` 0 pivots about the support centroid on
   the ground (the *ankle strategy*: on a flat-footed biped in single support the whole body
   turns about the sole through the ankle servos; on a point-footed quadruped the legs lengthen
   and shorten). Measured on the built-in biped's 0.222 m/s template (docs/results/
   attitude_feedback.md): the hip strategy passes at G 0.5 and 1, the ankle strategy falls at
   G 0.2 — the open-loop walk rocks ±16° in roll on its sole edges, where an ankle offset turns
   the foot instead of the body. Kajita et al. 2010 (IROS, "Biped walking stabilization based
   on linear inverted pendulum tracking") likewise feed the measured body inclination back as
   a rotation of the body target, on top of a ZMP walk.
4. **Support filter.** Only stance legs correct; a swing leg's offset is zero (it carries no
   load, and moving it would move where it lands). A leg's weight w ∈ [0, 1] rises with a
   half-cosine over `support_ramp_phase` of a cycle after touchdown and falls over the same
   before lift-off, so the offsets never step when a foot lands or lifts.
5. **Fade and clip.** The offsets are multiplied by the gait's entry blend weight (0 while the
   robot ramps to and stands at the stand, 1 once the gait runs fully; the exit blend fades them
   out again) and each one is clipped to ±`max_offset_rad` (default 0.15 rad ≈ 8.6°): the
   built-in biped's 0.222 m/s walk asks at most 0.12 rad at G 0.5 (never clipped) and 0.17 rad
   at G 1 (clipped on 0.6 % of its ticks), so the bound only bites in a fall, where chasing the
   tilt would throw the legs to their limits.

A gait validated with G > 0 records ``attitude_gain`` in its validation conditions; the player
then refuses to play it open loop unless forced (`hardware.play.preflight`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from robots.errors import RobotsError
from robots.gait import Gait
from robots.schedule import ContactSchedule

if TYPE_CHECKING:
    from robots.robot import Robot

#: the largest gain accepted: G = 1 corrects the whole error kinematically; above 2 the law
#: overcorrects by more than the error itself every tick and rings
MAX_ATTITUDE_GAIN = 2.0
DEFAULT_MAX_OFFSET_RAD = 0.15
MAX_OFFSET_BOUND_RAD = 0.5
DEFAULT_SUPPORT_RAMP_PHASE = 0.05
#: the validation conditions' key that says a verdict was reached closed loop
ATTITUDE_GAIN_KEY = "attitude_gain"
#: the default gain of a robot with fewer than 3 legs that declares an IMU (`default_attitude_gain`)
TWO_LEG_IMU_GAIN = 0.5
MIN_STATIC_LEGS = 3  # fewer legs have no static support polygon


class AttitudeError(RobotsError, ValueError):
    """A bad attitude-feedback setting (gain, clip, ramp) or map."""


def check_gain(option: str, gain: object) -> float:
    """`gain` as a float if it is a finite number in [0, MAX_ATTITUDE_GAIN]; else AttitudeError
    naming `option`."""
    if isinstance(gain, bool) or not isinstance(gain, (int, float)):
        raise AttitudeError(f"{option} must be a number from 0 to {MAX_ATTITUDE_GAIN:g}, "
                            f"got {gain!r:.40}")
    g = float(gain)
    if not (math.isfinite(g) and 0.0 <= g <= MAX_ATTITUDE_GAIN):
        raise AttitudeError(f"{option} must be from 0 to {MAX_ATTITUDE_GAIN:g} (1 corrects the "
                            f"whole tilt error each tick), got {gain!r:.40}")
    return g


@dataclass(frozen=True)
class AttitudeLaw:
    """The law's settings (module docstring): gain G, per-joint clip, support ramp width."""

    gain: float
    max_offset_rad: float = DEFAULT_MAX_OFFSET_RAD
    support_ramp_phase: float = DEFAULT_SUPPORT_RAMP_PHASE
    pivot_fraction: float = 1.0  # 1: rotate about the base (hip strategy); 0: the support

    def __post_init__(self) -> None:
        check_gain("attitude gain", self.gain)
        if not (math.isfinite(self.pivot_fraction) and 0.0 <= self.pivot_fraction <= 1.0):
            raise AttitudeError("attitude pivot_fraction must be in [0, 1], got "
                                f"{self.pivot_fraction!r}")
        if not (math.isfinite(self.max_offset_rad)
                and 0.0 < self.max_offset_rad <= MAX_OFFSET_BOUND_RAD):
            raise AttitudeError(f"attitude max_offset_rad must be in (0, {MAX_OFFSET_BOUND_RAD}]"
                                f", got {self.max_offset_rad!r}")
        if not (math.isfinite(self.support_ramp_phase) and 0.0 <= self.support_ramp_phase < 0.5):
            raise AttitudeError("attitude support_ramp_phase must be in [0, 0.5) of a cycle, "
                                f"got {self.support_ramp_phase!r}")


@dataclass(frozen=True, eq=False)
class LegMap:
    """One leg's share of the map: Δq_leg = K · ξ (ξ = base twist (v, ω), world frame at the
    stance pose) and where its foot touches the ground, relative to the base origin."""

    joint_index: tuple[int, ...]  # columns of the leg's joints in Robot.joints order
    twist_to_joints: np.ndarray  # (n_leg, 6) K = −J_q⁺ J_b
    foot_from_base_m: np.ndarray  # (3,) contact point − base origin, at the stance pose


@dataclass(frozen=True, eq=False)
class AttitudeMap:
    """The kinematic map of a robot (`robots.attitude_maps.attitude_map`), one `LegMap` per leg
    in `Robot.legs` order."""

    n_joints: int
    legs: tuple[LegMap, ...]

    @property
    def n_legs(self) -> int:
        return len(self.legs)

    def joint_offsets(self, rotation_rad: np.ndarray, support: np.ndarray,
                      pivot_fraction: float = 0.0) -> np.ndarray:
        """(J,) joint offsets that rotate the body by `rotation_rad` = (about x, about y) about
        the support centroid with the stance feet held (module docstring, step 3), each leg's
        scaled by its support weight `support` (F,); `pivot_fraction` moves the pivot from the
        support centroid (0) to the base origin (1). Zero if no foot bears weight."""
        w = np.asarray(support, dtype=float)
        out = np.zeros(self.n_joints)
        total = float(np.sum(w))
        if total <= 1e-9:
            return out
        pivot = sum(wf * leg.foot_from_base_m for wf, leg in zip(w, self.legs, strict=True))
        omega = np.array([rotation_rad[0], rotation_rad[1], 0.0])
        # base origin relative to the pivot: −pivot/total (the pivot is base-relative)
        twist = np.concatenate([np.cross(omega, -(1.0 - pivot_fraction) * pivot / total), omega])
        for wf, leg in zip(w, self.legs, strict=True):
            if wf > 0.0:
                out[list(leg.joint_index)] += wf * (leg.twist_to_joints @ twist)
        return out


def default_attitude_gain(robot: Robot, gait: Gait | None = None) -> tuple[float, str]:
    """(gain, why) of a robot's closed-loop runs of `gait` when no gain is asked for:
    robot.toml's ``[imu].attitude_gain`` if it gives one; else `TWO_LEG_IMU_GAIN` for a walk
    (a foot down all cycle) of a robot with an ``[imu]`` and fewer than `MIN_STATIC_LEGS` legs
    (no static support polygon; the built-in biped's and humanoid20's Fr 0.02 template walks,
    docs/results/attitude_feedback.md); else 0: open loop for quadrupeds and hexapods (they keep
    their open-loop verdicts; session 28 measured feedback hurting knee8 and spotmicro) and for
    runs (a flight phase: the built-in biped's flying run at 0.5 m/s turns −5.7° at G 0.5
    against −2.1° open loop and fails its heading check)."""
    if robot.imu is None:
        return 0.0, "no [imu] in robot.toml"
    if robot.imu.attitude_gain is not None:
        return robot.imu.attitude_gain, "robot.toml [imu].attitude_gain"
    if len(robot.legs) >= MIN_STATIC_LEGS:
        return 0.0, f"{len(robot.legs)} legs stand statically"
    if gait is not None and _has_flight(gait):
        return 0.0, "a run (flight phase) stays open loop"
    return TWO_LEG_IMU_GAIN, (f"robot.toml declares an [imu], the robot has {len(robot.legs)} "
                              f"legs (< {MIN_STATIC_LEGS})")


def gait_attitude_gain(robot: Robot, gait: Gait | None = None,
                       gain: float | None = None) -> tuple[float, str]:
    """(gain, why) of a run of `gait` on `robot`: `gain` if one was asked for (an explicit
    ``--attitude-gain``; 0 is open loop), else the robot's default for that gait
    (`default_attitude_gain`). The one rule every MuJoCo judgement applies — `plan --simulate`
    and `--knife-edge`, `simulate`, the search's acceptance (coarse samples and final
    candidates, `sim.acceptance`), `sweep` and the gait library's validation — so that a
    gait is judged by the controller it will be played with."""
    if gain is not None:
        return check_gain("attitude gain", gain), "asked for"
    return default_attitude_gain(robot, gait)


def validated_attitude_gain(validation: Mapping[str, Any] | None) -> float:
    """The IMU feedback gain a gait's sim verdict (its ``validation`` block) was reached with
    (0: open loop, or no verdict): what the player's pre-flight checks."""
    cond = (validation or {}).get("conditions")
    gain = cond.get(ATTITUDE_GAIN_KEY, 0.0) if isinstance(cond, Mapping) else 0.0
    ok = isinstance(gain, (int, float)) and not isinstance(gain, bool) and math.isfinite(gain)
    return float(gain) if ok else 0.0


def _has_flight(gait: Gait) -> bool:
    from robots.ramp import has_flight  # robots.ramp imports robots.gait, as this module does

    return has_flight(gait)


def roll_pitch(quat_wxyz: np.ndarray) -> np.ndarray:
    """(…, 2) roll and pitch [rad] of unit quaternions (w, x, y, z) in the z-y'-x'' convention
    (R = Rz·Ry·Rx: roll = atan2(R₃₂, R₃₃), pitch = −asin(R₃₁))."""
    q = np.asarray(quat_wxyz, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    return np.stack([roll, pitch], axis=-1)


def planned_roll_pitch(gait: Gait, gait_time_s: float) -> np.ndarray:
    """(2,) the plan's body roll and pitch at gait time `gait_time_s` (linear between knots;
    zero if the gait file has no ``base_pose``)."""
    if gait.base_pose is None:
        return np.zeros(2)
    rp = np.asarray(gait.base_pose, dtype=float)[:, 3:5]
    n = len(rp)
    u = (gait_time_s / gait.period_s) % 1.0 * n
    k = math.floor(u) % n
    f = u - math.floor(u)
    return np.asarray((1.0 - f) * rp[k] + f * rp[(k + 1) % n])


def support_weights(schedule: ContactSchedule, phase: float, ramp_phase: float) -> np.ndarray:
    """(F,) each foot's support weight at gait phase `phase` (cycles): 1 in stance, 0 in
    swing, half-cosine ramps `ramp_phase` wide inside the stance at touchdown and lift-off."""
    out = np.zeros(schedule.n_feet)
    for f in range(schedule.n_feet):
        duty = schedule.duty_factor[f]
        s = (phase - schedule.touchdown_phase[f]) % 1.0
        if duty >= 1.0:
            out[f] = 1.0
            continue
        if s >= duty:
            continue
        width = min(ramp_phase, duty / 2.0)
        edge = min(s, duty - s)
        out[f] = 1.0 if width <= 0.0 or edge >= width else 0.5 - 0.5 * math.cos(
            math.pi * edge / width)
    return out


def attitude_offsets(
    law: AttitudeLaw,
    amap: AttitudeMap,
    error_rp_rad: np.ndarray,
    support: np.ndarray,
    blend: float,
) -> np.ndarray:
    """(J,) the clipped joint goal offsets for a measured-minus-planned roll/pitch error
    `error_rp_rad` (2,), support weights `support` (F,) and blend weight `blend` ∈ [0, 1]."""
    if law.gain == 0.0 or blend <= 0.0:
        return np.zeros(amap.n_joints)
    e = np.asarray(error_rp_rad, dtype=float)
    if not np.all(np.isfinite(e)):
        return np.zeros(amap.n_joints)
    raw = amap.joint_offsets(-law.gain * min(blend, 1.0) * e, support, law.pivot_fraction)
    return np.asarray(np.clip(raw, -law.max_offset_rad, law.max_offset_rad))


def gait_offsets(
    law: AttitudeLaw,
    amap: AttitudeMap,
    gait: Gait,
    measured_rp_rad: np.ndarray,
    blend: float,
    gait_time_s: float,
) -> np.ndarray:
    """(J,) `attitude_offsets` at the gait's clock `gait_time_s`: the error against the plan's
    roll/pitch there (scaled by the blend weight), the stance legs' support weights there. The
    one step the simulator's loop and the player's corrector share."""
    planned = blend * planned_roll_pitch(gait, gait_time_s)
    support = support_weights(gait.schedule, gait_time_s / gait.period_s, law.support_ramp_phase)
    return attitude_offsets(law, amap, np.asarray(measured_rp_rad) - planned, support, blend)


def blended_offsets(
    law: AttitudeLaw,
    amap: AttitudeMap,
    gaits: Sequence[Gait],
    weights: Sequence[float] | np.ndarray,
    measured_rp_rad: np.ndarray,
    blend: float,
    phase: float,
) -> np.ndarray:
    """(J,) `gait_offsets` for a blend of gaits played at one phase (`robots.blend`: the
    library's entries share a schedule and are blended at equal phase φ, q = Σ wₑ Sₑ(φ)). The
    reference is blended the way the joints are, with the same weights wₑ (Σ wₑ = 1):

        (roll, pitch)_ref = α · Σ wₑ (roll, pitch)_planned,e(φ·Tₑ),
        support_f = Σ wₑ support_f,e(φ),

    so a blend sitting on one entry gives exactly that entry's `gait_offsets` at gait time
    φ·Tₑ, and a command moving between entries (a gait switch mid-blend) moves the reference and
    the support weights continuously with the weights; both stay in [0, 1] and the clip of
    `attitude_offsets` still bounds every offset. `phase` in cycles; `blend` is the entry/exit
    blend weight α as in `gait_offsets`."""
    w = np.asarray(weights, dtype=float).reshape(-1)
    if len(gaits) != w.size or w.size == 0:
        raise AttitudeError(f"blended_offsets: {len(gaits)} gait(s) for {w.size} weight(s)")
    if not (np.all(np.isfinite(w)) and np.all(w >= -1e-12) and abs(float(np.sum(w)) - 1.0)
            <= 1e-6):
        raise AttitudeError(f"blended_offsets: weights must be ≥ 0 and sum to 1, got {w}")
    planned = np.zeros(2)
    support = np.zeros(amap.n_legs)
    for g, wg in zip(gaits, w, strict=True):
        if wg <= 0.0:
            continue
        planned += wg * planned_roll_pitch(g, phase * g.period_s)
        support += wg * support_weights(g.schedule, phase, law.support_ramp_phase)
    return attitude_offsets(law, amap, np.asarray(measured_rp_rad) - blend * planned, support,
                            blend)


__all__ = [
    "ATTITUDE_GAIN_KEY",
    "DEFAULT_MAX_OFFSET_RAD",
    "MAX_ATTITUDE_GAIN",
    "AttitudeError",
    "AttitudeLaw",
    "AttitudeMap",
    "LegMap",
    "attitude_offsets",
    "blended_offsets",
    "check_gain",
    "default_attitude_gain",
    "gait_attitude_gain",
    "gait_offsets",
    "planned_roll_pitch",
    "roll_pitch",
    "support_weights",
    "validated_attitude_gain",
]

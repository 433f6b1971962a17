"""`validate(gait, robot)`: run the gait in MuJoCo with servo actuators and judge it.

The run starts at rest in the nominal stance on flat ground, holds, ramps in the way the player
does (`robots.ramp`), then plays `cycles` gait cycles streamed at `rate_hz` with `latency_s`.
Like the player it can hold the gait's stand (its mean pose) for `stand_s` after the ramp-in and,
with `end_at_stand`, end the way a completed run ends on the servos: the gait blended out to
the stand and the stand held `stand_s` (the steady-cycle metrics stop at the last cycle; heading,
path and falls cover the ending too).
Metrics (see `sim.metrics`): heading and path over the whole run in the world frame from the rest
pose, the rest over the steady cycles; the verdict applies `PassCriteria`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace

import mujoco
import numpy as np

from robots.attitude import ATTITUDE_GAIN_KEY
from robots.gait import Gait
from robots.robot import Robot
from robots.servo_params import ServoSetting
from sim.attitude_loop import AttitudeSettings
from sim.errors import SimConfigError
from sim.metrics import FallThresholds, JointMetrics, Metrics, compute, detect_fall, tilt_of
from sim.model import SimConditions, SimModel, build_sim_model
from sim.rollout import Progress, RunSettings, Trajectory, run
from sim.servo import DEFAULT_RATE_HZ

VALIDATION_SCHEMA = "gaitsmith.validation/1"


@dataclass(frozen=True)
class PassCriteria:
    """Thresholds of the verdict. A gait passes when every check holds."""

    speed_rel_tol: float = 0.10  # |achieved − commanded| ≤ 10 % of commanded speed
    speed_abs_tol_m_s: float = 0.01  # … or this, whichever is larger (standing gaits)
    max_peak_torque_fraction: float = 0.80  # peak |τ| ≤ 80 % of stall on every joint
    # Heading and path over the whole run, from the rest pose (ramp-in included). 5° of heading
    # error puts an open-loop walk 0.09 m off its line per metre (tan 5°), the same order as a
    # foot's width on these robots; a 15° turn during the ramp-in (0.27 m/m) fails both checks.
    max_heading_error_rad: float = math.radians(5.0)  # |yaw change − commanded turn|, cycle mean
    max_lateral_drift_per_m: float = 0.15  # metres off the commanded path per metre along it
    max_yaw_drift_rad_per_m: float = 0.35  # steady turning: ≈ 20° of unwanted turn per metre
    # Turning and side-stepping commands (`gaitsmith plan --yaw-rate/--vy`): the achieved rate,
    # from the gait's start to the end of the run, within 15 % of the commanded one, or within
    # the floor for tiny commands (0.02 rad/s: the 5° heading limit over a 4-5 s run; 0.01 m/s
    # as the speed check). With a commanded yaw rate this replaces the heading and yaw-drift
    # checks, whose absolute limits (5° over the whole run, 0.35 rad/m) are tighter than 15 % of
    # any turn longer than a few seconds; the lateral-drift check (the commanded arc) stays. vy
    # is judged for straight commands only: on an arc the start-frame mean velocity is a chord,
    # not the body-frame vy (the arc check covers it there).
    yaw_rate_rel_tol: float = 0.15
    yaw_rate_abs_tol_rad_s: float = 0.02
    vy_rel_tol: float = 0.15
    vy_abs_tol_m_s: float = 0.01
    max_tilt_rad: float = math.radians(20.0)  # body tilt in the steady cycles
    # mean contact-point travel per stance, in leg lengths L (`Robot.leg_length_m`), or fixed
    # metres when `max_mean_slip_m` is set. A fixed 20 mm was 11 % of quad12's leg but 29 % of
    # star5's (7 cm) and 10 % of humanoid20's (24 cm): at equal Froude number strides scale with
    # L, so a slip that matters does too.
    max_mean_slip_leg_lengths: float = 0.10
    max_mean_slip_m: float | None = None
    # At zero command (a stand, or stepping in place) there is no speed to compare with: the
    # speed check becomes a drift check instead — the base's planar speed over the steady
    # cycles ≤ this many leg lengths per second (0.05 L/s: 9 mm/s for an 18 cm leg, half a leg
    # length in 10 s), and the whole run (ramp-in included) ends within `max_run_drift_leg_lengths`
    # of where it started. Heading, fall, tilt, slip and torque are judged as for a walk.
    max_drift_leg_lengths_per_s: float = 0.05
    max_run_drift_leg_lengths: float = 0.5
    falls: FallThresholds = field(default_factory=FallThresholds)
    warmup_cycles: int = 2  # cycles after the ramp not judged (start-up transient)


@dataclass(frozen=True)
class ValidationResult:
    passed: bool
    reasons: tuple[str, ...]  # why it failed (empty when it passed)
    checks: tuple[tuple[str, bool, str], ...]  # (name, ok, detail) for every criterion
    metrics: Metrics
    joints: tuple[JointMetrics, ...]
    conditions: dict[str, float | int | None]
    criteria: PassCriteria
    trajectory: Trajectory | None = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe summary (no trajectory), as stored in the gait file's `validation` block."""
        crit = asdict(self.criteria)
        return {
            "schema": VALIDATION_SCHEMA,
            "passed": self.passed,
            "reasons": list(self.reasons),
            "checks": [{"name": n, "ok": ok, "detail": d} for n, ok, d in self.checks],
            "conditions": dict(self.conditions),
            "criteria": crit,
            "metrics": self.metrics.to_dict(),
            "joints": [asdict(j) for j in self.joints],
            "simulator": {"engine": "mujoco", "version": mujoco.__version__},
        }


def slip_limit_m(c: PassCriteria, leg_length_m: float) -> float:
    """The foot-slip limit for legs of `leg_length_m` (see `PassCriteria`)."""
    if c.max_mean_slip_m is not None:
        return c.max_mean_slip_m
    return c.max_mean_slip_leg_lengths * leg_length_m


def standing_command(m: Metrics) -> bool:
    """Zero commanded velocity (vx, vy and yaw rate): a stand or stepping in place."""
    return m.commanded_speed_m_s == 0.0 and m.commanded_yaw_rate_rad_s == 0.0


def _drift_check(m: Metrics, c: PassCriteria, leg_length_m: float) -> tuple[str, bool, str]:
    """The zero-command replacement of the speed check (see `PassCriteria`)."""
    speed_limit = c.max_drift_leg_lengths_per_s * leg_length_m
    run_limit = c.max_run_drift_leg_lengths * leg_length_m
    run_drift = abs(m.lateral_drift_m)  # at v = 0: the planar displacement over the run
    ok = m.achieved_speed_m_s <= speed_limit and run_drift <= run_limit
    return (
        "drift",
        ok,
        f"drifted {m.achieved_speed_m_s * 1000:.1f} mm/s in the steady part (limit "
        f"{speed_limit * 1000:.1f} mm/s = {c.max_drift_leg_lengths_per_s:g} L/s) and "
        f"{run_drift * 1000:.0f} mm over the whole {m.duration_s:.1f} s run (limit "
        f"{run_limit * 1000:.0f} mm = {c.max_run_drift_leg_lengths:g} L)",
    )


def _speed_check(m: Metrics, c: PassCriteria) -> tuple[str, bool, str]:
    """|achieved − commanded| within `speed_rel_tol` of the command or `speed_abs_tol_m_s`,
    whichever is larger. Where the absolute floor is the larger (slow commands: below 0.1 m/s
    with the defaults) the detail says so and gives the band as a share of the command, so a
    pass that reaches 84 % of a 0.05 m/s command is seen as one that only the floor let pass."""
    cmd = m.commanded_speed_m_s
    rel_tol = c.speed_rel_tol * cmd
    tol = max(rel_tol, c.speed_abs_tol_m_s)
    share = f" = {m.achieved_speed_m_s / cmd:.0%} of it" if cmd > 0.0 else ""
    band = f"±{tol:.3f}"
    if c.speed_abs_tol_m_s > rel_tol and cmd > 0.0:
        band += (f": the {c.speed_abs_tol_m_s:.3f} m/s floor, ±{tol / cmd:.0%} of the command "
                 f"instead of ±{c.speed_rel_tol:.0%}")
    return (
        "speed",
        abs(m.achieved_speed_m_s - cmd) <= tol,
        f"achieved {m.achieved_speed_m_s:.3f} m/s vs commanded {cmd:.3f} m/s{share} "
        f"(tolerance {band})",
    )


def judge(
    m: Metrics, c: PassCriteria, leg_length_m: float
) -> tuple[tuple[str, bool, str], ...]:
    checks: list[tuple[str, bool, str]] = []
    slip_limit = slip_limit_m(c, leg_length_m)
    if standing_command(m):
        checks.append(_drift_check(m, c, leg_length_m))
    else:
        checks.append(_speed_check(m, c))
    checks.append(
        (
            "no fall",
            not m.fell,
            "stayed up" if not m.fell else f"fell at t = {m.fall_time_s:.2f} s: {m.fall_reason}",
        )
    )
    checks.append(
        (
            "peak torque",
            m.peak_torque_fraction <= c.max_peak_torque_fraction,
            f"peak |τ| = {m.peak_torque_fraction:.0%} of stall "
            f"(limit {c.max_peak_torque_fraction:.0%})",
        )
    )
    turning = m.commanded_yaw_rate_rad_s != 0.0
    if turning:
        w_cmd, w_got = m.commanded_yaw_rate_rad_s, m.achieved_yaw_rate_rad_s
        w_tol = max(c.yaw_rate_rel_tol * abs(w_cmd), c.yaw_rate_abs_tol_rad_s)
        checks.append(
            (
                "yaw rate",
                abs(w_got - w_cmd) <= w_tol,
                f"achieved {w_got:+.3f} rad/s vs commanded {w_cmd:+.3f} rad/s "
                f"(tolerance ±{w_tol:.3f})",
            )
        )
    elif m.commanded_vy_m_s != 0.0:
        vy_cmd, vy_got = m.commanded_vy_m_s, m.achieved_vy_m_s
        vy_tol = max(c.vy_rel_tol * abs(vy_cmd), c.vy_abs_tol_m_s)
        checks.append(
            (
                "lateral speed",
                abs(vy_got - vy_cmd) <= vy_tol,
                f"achieved vy {vy_got:+.3f} m/s vs commanded {vy_cmd:+.3f} m/s "
                f"(tolerance ±{vy_tol:.3f})",
            )
        )
    checks.append(
        (
            "heading",
            turning or abs(m.heading_error_rad) <= c.max_heading_error_rad,
            f"n/a (turning: see yaw rate; {math.degrees(m.heading_error_rad):+.1f}° off the "
            "commanded turn over the run)"
            if turning
            else f"turned {math.degrees(m.heading_error_rad):+.1f}° off the commanded heading over "
            f"the run (mean over its last cycle), {math.degrees(m.ramp_yaw_rad):+.1f}° of it on "
            f"the gait's first cycle (limit ±{math.degrees(c.max_heading_error_rad):.0f}°)",
        )
    )
    lat = m.lateral_drift_per_m
    checks.append(
        (
            "lateral drift",
            lat is None or lat <= c.max_lateral_drift_per_m,
            "n/a (no distance)"
            if lat is None
            else f"{lat:.3f} m/m ({m.lateral_drift_m:+.3f} m off the commanded path after "
            f"{m.run_distance_m:.2f} m; limit {c.max_lateral_drift_per_m:.2f})",
        )
    )
    yaw = m.yaw_drift_rad_per_m
    checks.append(
        (
            "yaw drift",
            turning or yaw is None or yaw <= c.max_yaw_drift_rad_per_m,
            "n/a (turning: see yaw rate)"
            if turning
            else "n/a (no distance)"
            if yaw is None
            else f"{math.degrees(yaw):.1f}°/m "
            f"(limit {math.degrees(c.max_yaw_drift_rad_per_m):.0f}°/m)",
        )
    )
    checks.append(
        (
            "tilt",
            m.tilt_max_rad <= c.max_tilt_rad,
            f"max {math.degrees(m.tilt_max_rad):.1f}° (limit {math.degrees(c.max_tilt_rad):.0f}°)",
        )
    )
    checks.append(
        (
            "foot slip",
            m.slip_mean_m <= slip_limit,
            f"mean {m.slip_mean_m * 1000:.1f} mm per stance over {m.stances} stances "
            f"(limit {slip_limit * 1000:.1f} mm)",
        )
    )
    return tuple(checks)


def _over(value: float, limit: float) -> float:
    """How far `value` is past `limit`, relative to it: value / limit − 1 (≤ 0 within it)."""
    return value / limit - 1.0 if limit > 0.0 else (math.inf if value > limit else -math.inf)


def criterion_excess(m: Metrics, c: PassCriteria, leg_length_m: float
                     ) -> tuple[tuple[str, float], ...]:
    """Every criterion `judge` applies (the same names, in its order) with how far its metric is
    past its limit, relative to the limit: (metric − limit) / limit, ≤ 0 where the check holds
    (speed: |achieved − commanded| against the tolerance; drift: the larger of its two ratios;
    heading, path and yaw drift: their absolute values). A fall is +inf (no margin: the run
    stopped), a check that does not apply (turning, no distance) −inf. So a failed check's
    excess says whether it failed by a hair (+0.002: 0.2 % past the limit) or clearly."""
    out: list[tuple[str, float]] = []
    if standing_command(m):
        run_drift = abs(m.lateral_drift_m)
        out.append(("drift", max(
            _over(m.achieved_speed_m_s, c.max_drift_leg_lengths_per_s * leg_length_m),
            _over(run_drift, c.max_run_drift_leg_lengths * leg_length_m))))
    else:
        cmd = m.commanded_speed_m_s
        tol = max(c.speed_rel_tol * cmd, c.speed_abs_tol_m_s)
        out.append(("speed", _over(abs(m.achieved_speed_m_s - cmd), tol)))
    out.append(("no fall", math.inf if m.fell else -math.inf))
    out.append(("peak torque", _over(m.peak_torque_fraction, c.max_peak_torque_fraction)))
    turning = m.commanded_yaw_rate_rad_s != 0.0
    if turning:
        w_cmd = m.commanded_yaw_rate_rad_s
        w_tol = max(c.yaw_rate_rel_tol * abs(w_cmd), c.yaw_rate_abs_tol_rad_s)
        out.append(("yaw rate", _over(abs(m.achieved_yaw_rate_rad_s - w_cmd), w_tol)))
    elif m.commanded_vy_m_s != 0.0:
        vy_cmd = m.commanded_vy_m_s
        vy_tol = max(c.vy_rel_tol * abs(vy_cmd), c.vy_abs_tol_m_s)
        out.append(("lateral speed", _over(abs(m.achieved_vy_m_s - vy_cmd), vy_tol)))
    out.append(("heading", -math.inf if turning
                else _over(abs(m.heading_error_rad), c.max_heading_error_rad)))
    lat = m.lateral_drift_per_m
    out.append(("lateral drift", -math.inf if lat is None
                else _over(lat, c.max_lateral_drift_per_m)))
    yaw = m.yaw_drift_rad_per_m
    out.append(("yaw drift", -math.inf if turning or yaw is None
                else _over(yaw, c.max_yaw_drift_rad_per_m)))
    out.append(("tilt", _over(m.tilt_max_rad, c.max_tilt_rad)))
    out.append(("foot slip", _over(m.slip_mean_m, slip_limit_m(c, leg_length_m))))
    return tuple(out)


def simulate(
    gait: Gait,
    robot: Robot,
    cycles: int = 20,
    *,
    rate_hz: float = DEFAULT_RATE_HZ,
    latency_s: float = 0.0,
    friction: float | None = None,
    payload_kg: float = 0.0,
    strength: float = 1.0,
    progress: Progress | None = None,
    criteria: PassCriteria = PassCriteria(),
    stop_on_fall: bool = True,
    stand_s: float = 0.0,
    end_at_stand: bool = False,
    servo_settings: Sequence[ServoSetting] | None = None,
    attitude: AttitudeSettings | None = None,
) -> tuple[SimModel, Trajectory]:
    """Build the model and run the gait (no verdict); see `validate`. `servo_settings`: the
    identified servos (`robots.servo_params`, one per joint; None: catalogue servos);
    `attitude`: closed-loop IMU feedback (`sim.attitude_loop`; None: open loop)."""
    gait.check_robot(robot)
    settings = RunSettings(cycles=cycles, rate_hz=rate_hz, latency_s=latency_s,
                           stand_s=stand_s, end_at_stand=end_at_stand, attitude=attitude)
    sim = build_sim_model(
        robot,
        SimConditions(friction=friction, payload_kg=payload_kg, strength=strength),
        servo_settings=servo_settings,
    )
    stop = _fall_stop(criteria.falls) if stop_on_fall else None
    return sim, run(gait, sim, settings, progress=progress, stop=stop)


def _fall_stop(falls: FallThresholds) -> Callable[[np.ndarray, SimModel], bool]:
    """Stop one chunk (≈ a cycle) after a fall is first seen: enough to show it, no more."""
    seen = [False]

    def stop(sd: np.ndarray, sim: SimModel) -> bool:
        if seen[0]:
            return True
        feet = sum(sim.sensor(sd, f"gs_foot_contact_{f}")[:, 0] for f in sim.robot.foot_names)
        body = sim.sensor(sd, "gs_robot_contacts")[:, 0] > feet + 0.5
        low = (
            sim.sensor(sd, "gs_base_pos")[:, 2]
            < falls.min_height_fraction * sim.robot.stance_base_height_m
        )
        tipped = tilt_of(sim.sensor(sd, "gs_base_quat")) > falls.max_tilt_rad
        seen[0] = bool(np.any(body | low | tipped))
        return False

    return stop


def validate(
    gait: Gait,
    robot: Robot,
    cycles: int = 20,
    *,
    rate_hz: float = DEFAULT_RATE_HZ,
    latency_s: float = 0.0,
    friction: float | None = None,
    payload_kg: float = 0.0,
    strength: float = 1.0,
    progress: Progress | None = None,
    criteria: PassCriteria = PassCriteria(),
    keep_trajectory: bool = True,
    stand_s: float = 0.0,
    end_at_stand: bool = False,
    servo_settings: Sequence[ServoSetting] | None = None,
    attitude: AttitudeSettings | None = None,
) -> ValidationResult:
    """Simulate `cycles` cycles of `gait` on `robot` and return metrics + verdict (`stand_s`,
    `end_at_stand`: start and end at the gait's stand, see the module docstring)."""
    if cycles <= criteria.warmup_cycles:
        raise SimConfigError(
            f"cycles must exceed the {criteria.warmup_cycles} warm-up cycles, got {cycles}"
        )
    sim, traj = simulate(
        gait,
        robot,
        cycles,
        rate_hz=rate_hz,
        latency_s=latency_s,
        friction=friction,
        payload_kg=payload_kg,
        strength=strength,
        progress=progress,
        criteria=criteria,
        stand_s=stand_s,
        end_at_stand=end_at_stand,
        servo_settings=servo_settings,
        attitude=attitude,
    )
    result = evaluate(
        traj,
        gait,
        sim,
        criteria,
        rate_hz=rate_hz,
        latency_s=latency_s,
        keep_trajectory=keep_trajectory,
    )
    if stand_s or end_at_stand:
        extra: dict[str, float | int | None] = {"stand_s": stand_s,
                                                 "end_at_stand": int(end_at_stand)}
        result = replace(result, conditions={**result.conditions, **extra})
    return result


def evaluate(
    traj: Trajectory,
    gait: Gait,
    sim: SimModel,
    criteria: PassCriteria = PassCriteria(),
    *,
    rate_hz: float = DEFAULT_RATE_HZ,
    latency_s: float = 0.0,
    keep_trajectory: bool = True,
) -> ValidationResult:
    metrics, joints = compute(
        traj, gait, sim, warmup_cycles=criteria.warmup_cycles, falls=criteria.falls
    )
    checks = judge(metrics, criteria, sim.robot.leg_length_m)
    reasons = tuple(f"{name}: {detail}" for name, ok, detail in checks if not ok)
    cond = sim.conditions
    conditions: dict[str, float | int | None] = {
        "cycles": traj.cycles_run,
        "rate_hz": rate_hz,
        "latency_s": latency_s,
        "friction": cond.friction,
        "payload_kg": cond.payload_kg,
        "strength": cond.strength,
        "timestep_s": float(sim.model.opt.timestep),
    }
    if traj.attitude_gain > 0.0:  # a closed-loop verdict says so (the player checks it)
        conditions[ATTITUDE_GAIN_KEY] = traj.attitude_gain
    return ValidationResult(
        passed=not reasons,
        reasons=reasons,
        checks=checks,
        metrics=metrics,
        joints=joints,
        conditions=conditions,
        criteria=criteria,
        trajectory=traj if keep_trajectory else None,
    )


def validate_and_annotate(gait: Gait, robot: Robot, cycles: int = 20, **kwargs: object) -> Gait:
    """`gait` with its `validation` block filled in (for `gaitsmith plan --simulate`)."""
    result = validate(gait, robot, cycles, keep_trajectory=False, **kwargs)  # type: ignore[arg-type]
    return gait.with_validation(result.to_dict())


__all__ = [
    "PassCriteria",
    "ValidationResult",
    "criterion_excess",
    "detect_fall",
    "evaluate",
    "judge",
    "simulate",
    "slip_limit_m",
    "standing_command",
    "validate",
    "validate_and_annotate",
]

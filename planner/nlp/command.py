"""Velocity commands (vx, vy, yaw rate) in the spacetime NLP: the command frame.

A commanded gait is periodic up to a planar rigid motion: a body moving at the constant
body-frame velocity (vx, vy) with yaw rate W is, after a time t, displaced by

    d(t) = [ sin(Wt)/W      −(1−cos(Wt))/W ] · (vx, vy)        (W → 0: d(t) = t·(vx, vy))
           [ (1−cos(Wt))/W    sin(Wt)/W    ]

in its starting frame, and turned by W·t. The planner generalises the treadmill frame of
W&P §3 to the *command frame*: a frame that moves with exactly that motion. Every decision
variable is the pose relative to the command frame at its own knot's time, so all of them are
N-periodic (the robot's yaw stays small, its bounds and cost keep their meaning); the world pose
at knot k is Δ(t_k)∘b_k, so over one period the base turns by W·T and moves by d(T) — the
wrap-around "last knot's pose = the first's composed with the planar motion" holds at every
knot interval, the wrap N−1 → 0 included, because the command frame's motion is the same over
every interval.

Finite differences and the stance no-slip rows compare neighbouring knots in *one* frame: knot
k±1 expressed in the command frame of knot k is Δ(±h)∘b_{k±1} with h = T/N, Δ(h) the planar
motion (d(h), W·h). Only base x, y (and the feet's x, y) change — yaw composes additively
(R = Rz(yaw)·Ry·Rx, so Rz(W·h)·R adds W·h to the yaw) and the lifted yaw rate is the relative
one; the dynamics add the command back: world velocity = lifted rate + (vx, vy, 0), world yaw
rate = lifted yaw rate + W. With vy = W = 0, Δ(h) is the translation (vx·h, 0) and every row is
today's treadmill row.

The planar motion over h enters the NLP as parameters (`motion_parameters`), so one build serves
every command.

**Stepping in place** (the zero command with a stepping schedule; issue #14 item 5) plans with
`in_place_options`. Measured in MuJoCo (`--knots 16`, 2026-12-02,
docs/results/stand_in_place.md), the walking defaults let the robots wander off their spot:

- nothing anchors the footprint when the body does not travel: the optimiser moved the two
  diagonals of quad12's trot apart (FR 112 mm behind its stance position, FL 46 mm ahead),
  spotmicro's trot likewise (104 mm), quad12's and spotmicro's walks put the hind feet 77-79 mm
  back, bittle8's trot spread its feet 28-37 mm; the gaits' mean poses differed from the stance
  by up to 39°, so the entry ramp (`robots.ramp`, to that mean pose) moved the standing robot,
  and the trots drifted 20-24 mm/s (or turned 58°). `IN_PLACE_FOOTPRINT_LEG_LENGTHS`: the
  cycle mean of every foot stays within ±0.01 L of its stance position (the
  `PlannerOptions.mean_footprint_leg_lengths` constraint), so the entry moves no foot;
- on each support diagonal quad12's anchored trot tipped 4.5° towards the free front foot in
  MuJoCo (planned 0.5°), which landed early, and it drifted 12-23 mm/s. The walking clearance
  0.14 L (25 mm) over a 0.19 s swing lifts the foot at up to h·π²/t² ≈ 7 m/s² (the clearance
  profile h·sin(π·s)), and the leg's reaction on a body balanced on two feet is what the
  open-loop servos do not reproduce. In place the foot travels no stride, so it needs to clear
  the floor, not scuff across a step: `IN_PLACE_SWING_CLEARANCE_LEG_LENGTHS` = 0.07 L (half;
  an explicit `swing_clearance_m` is kept): quad12 trot 1.4 mm/s, bittle8 trot 2.5 mm/s;
- a gait that does not balance on a support line (`centre_under_com`: walk, wave, ripple,
  tripod — the caller's judgement, e.g. not `gaitsmith.gait_choice.tips_on_a_line`) stands on
  its support polygons, so the footprint's stance position is the nominal one *shifted under
  the centre of mass* (`stance_com_offset_m`, `PlannerOptions.mean_footprint_offset_m`):
  quad12's CoM is 17 mm behind its feet's centroid, and at the nominal footprint its walk in
  place tipped towards each swinging hind foot (the CoM near that triangle's edge) and drifted
  20 mm/s backwards; centred, 0.8 mm/s. The entry ramp then shifts the body over the planted
  feet by that offset. The trots are not centred: measured, centring made them drift more
  (quad12 3.4 vs 1.4 mm/s and 64 vs 22 mm over the run, bittle8 3.9 vs 2.5 mm/s).

The base height is left free (above `min_base_height_fraction`): a band of ±0.05 L around the
stance's (tried, 2026-12-02) made bittle8's trot drift 7.7 instead of 2.5 mm/s (it crouches
16 mm when free) and quad12's walk 5.9 instead of 0.8 mm/s (it rises 37 mm when free).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from robots.robot import Robot

#: the planner's own bounds on a command (the CLI's are tighter and scale with the robot,
#: `gaitsmith.options.check_yaw_rate`): speeds as `GaitPlanner`'s forward speed, and at most a
#: quarter turn per period — beyond that the stance feet would have to twist through more than
#: any leg's reach within one stance, and a knot interval's rotation W·T/N stops being small
MAX_SPEED_M_S = 10.0
MAX_TURN_PER_PERIOD_RAD = math.pi / 2

#: entries of the command block at the end of the parameter vector (after vx and T)
N_MOTION_PARAMETERS = 8  # vy, W, cos(Wh), sin(Wh), d(+h) x, y, d(−h) x, y
_SMALL_ANGLE = 1e-6

#: stepping in place (module docstring): each foot's cycle-mean x, y within this · L of its
#: stance position, and the swing clearance this · L (half `SWING_CLEARANCE_LEG_LENGTHS`)
IN_PLACE_FOOTPRINT_LEG_LENGTHS = 0.01
IN_PLACE_SWING_CLEARANCE_LEG_LENGTHS = 0.07


@dataclass(frozen=True)
class VelocityCommand:
    """A commanded body-frame velocity: forward vx [m/s], left vy [m/s], yaw rate [rad/s]."""

    vx_m_s: float = 0.0
    vy_m_s: float = 0.0
    yaw_rate_rad_s: float = 0.0

    @property
    def moving(self) -> bool:
        return any(v != 0.0 for v in (self.vx_m_s, self.vy_m_s, self.yaw_rate_rad_s))


def stance_com_offset_m(robot: Robot) -> tuple[float, float]:
    """Ground projection of the centre of mass minus the centroid of the feet (x, y) in the base
    frame, at the nominal stance (base level at the origin)."""
    import mujoco

    from planner.stance import stance_kinematics
    from planner.templates import stance_foot_positions_m

    stance = stance_kinematics(robot)
    model, data = stance.model, stance.data
    mujoco.mj_comPos(model, data)
    root = int(np.argmax(model.body_subtreemass[1:])) + 1  # the floating base: the heaviest tree
    offset = data.subtree_com[root][:2] - stance_foot_positions_m(robot)[:, :2].mean(axis=0)
    return float(offset[0]), float(offset[1])


def in_place_options(options: PlannerOptions, robot: Robot, *,
                     centre_under_com: bool) -> PlannerOptions:
    """`options` for stepping in place (zero command, feet stepping; module docstring): each
    foot's cycle mean within ±0.01 L of its stance position (shifted under the centre of mass
    with `centre_under_com`, for gaits that stand on support polygons) and half the walking
    swing clearance. An explicit `swing_clearance_m`, or a tighter footprint, is kept."""
    leg_m = robot.leg_length_m
    footprint = options.mean_footprint_leg_lengths
    if footprint is None or footprint > IN_PLACE_FOOTPRINT_LEG_LENGTHS:
        footprint = IN_PLACE_FOOTPRINT_LEG_LENGTHS
    clearance = options.swing_clearance_m
    if clearance is None:
        clearance = IN_PLACE_SWING_CLEARANCE_LEG_LENGTHS * leg_m
    offset = stance_com_offset_m(robot) if centre_under_com else options.mean_footprint_offset_m
    return replace(options, mean_footprint_leg_lengths=footprint, mean_footprint_offset_m=offset,
                   swing_clearance_m=clearance)


def check_command(vy_m_s: float, yaw_rate_rad_s: float, period_s: float, n_knots: int) -> None:
    """Raise PlannerConfigError unless the lateral speed and yaw rate are plannable."""
    if not (math.isfinite(vy_m_s) and abs(vy_m_s) <= MAX_SPEED_M_S):
        raise PlannerConfigError(
            f"lateral speed vy must be in [-{MAX_SPEED_M_S:g}, {MAX_SPEED_M_S:g}] m/s, "
            f"got {vy_m_s!r}"
        )
    if not (math.isfinite(yaw_rate_rad_s)
            and abs(yaw_rate_rad_s) * period_s <= MAX_TURN_PER_PERIOD_RAD):
        raise PlannerConfigError(
            f"yaw rate {yaw_rate_rad_s!r} rad/s turns more than a quarter turn per period "
            f"({period_s:g} s); use a smaller yaw rate or a shorter period"
        )


def planar_displacement(command: VelocityCommand, dt_s: float) -> tuple[float, float, float]:
    """(dx, dy, dyaw) after `dt_s` (may be negative) in the starting frame: d(t) and W·t."""
    w, vx, vy = command.yaw_rate_rad_s, command.vx_m_s, command.vy_m_s
    theta = w * dt_s
    if abs(theta) < _SMALL_ANGLE:  # series of sin(θ)/θ and (1 − cos θ)/θ
        s = dt_s * (1.0 - theta * theta / 6.0)
        c = dt_s * (theta / 2.0 - theta**3 / 24.0)
    else:
        s, c = math.sin(theta) / w, (1.0 - math.cos(theta)) / w
    return s * vx - c * vy, c * vx + s * vy, theta


def compose(motion: tuple[float, float, float], pose: np.ndarray) -> np.ndarray:
    """Planar motion (dx, dy, dyaw) ∘ pose (x, y, z, roll, pitch, yaw …): rotate x, y by dyaw,
    add (dx, dy), add dyaw to the yaw (poses are R = Rz(yaw)·Ry(pitch)·Rx(roll))."""
    dx, dy, dyaw = motion
    out = np.array(pose, dtype=float)
    c, s = math.cos(dyaw), math.sin(dyaw)
    out[..., 0] = dx + c * pose[..., 0] - s * pose[..., 1]
    out[..., 1] = dy + s * pose[..., 0] + c * pose[..., 1]
    out[..., 5] = pose[..., 5] + dyaw
    return out


def motion_parameters(command: VelocityCommand, period_s: float, n_knots: int) -> np.ndarray:
    """The NLP's command block: vy, W, cos(W·h), sin(W·h), d(+h), d(−h) with h = T/N."""
    h = period_s / n_knots
    fwd = planar_displacement(command, h)
    back = planar_displacement(command, -h)
    theta = command.yaw_rate_rad_s * h
    return np.array(
        [command.vy_m_s, command.yaw_rate_rad_s, math.cos(theta), math.sin(theta),
         fwd[0], fwd[1], back[0], back[1]]
    )


def world_base_poses(
    base_pose: np.ndarray, command: VelocityCommand, period_s: float, cycles: int = 1
) -> np.ndarray:
    """(cycles·N + 1) × 6 world base poses from the N command-frame poses of one cycle, the
    command frame starting at the world origin: knot k is Δ(k·h)∘b_(k mod N); the last row is
    the first knot of the next cycle."""
    n = len(base_pose)
    h = period_s / n
    rows = [compose(planar_displacement(command, k * h), base_pose[k % n])
            for k in range(cycles * n + 1)]
    return np.array(rows)


@dataclass(frozen=True)
class MotionSymbols:
    """The command block of the parameter vector (CasADi scalars)."""

    vx_m_s: Any
    vy_m_s: Any
    yaw_rate_rad_s: Any
    cos_wh: Any
    sin_wh: Any
    forward_xy: tuple[Any, Any]  # d(+h)
    backward_xy: tuple[Any, Any]  # d(−h)

    @classmethod
    def from_parameters(cls, vx: Any, block: Any) -> MotionSymbols:
        return cls(vx, block[0], block[1], block[2], block[3], (block[4], block[5]),
                   (block[6], block[7]))

    def next_in_frame(self, x: Any, y: Any) -> tuple[Any, Any]:
        """x, y of knot k+1 in the command frame of knot k: Δ(+h)∘(x, y)."""
        c, s = self.cos_wh, self.sin_wh
        return self.forward_xy[0] + c * x - s * y, self.forward_xy[1] + s * x + c * y

    def previous_in_frame(self, x: Any, y: Any) -> tuple[Any, Any]:
        """x, y of knot k−1 in the command frame of knot k: Δ(−h)∘(x, y)."""
        c, s = self.cos_wh, self.sin_wh
        return self.backward_xy[0] + c * x + s * y, self.backward_xy[1] - s * x + c * y

    def rotate_next(self, x: Any, y: Any) -> tuple[Any, Any]:
        """A direction (x, y) of knot k+1 in the command frame of knot k (rotation by W·h)."""
        c, s = self.cos_wh, self.sin_wh
        return c * x - s * y, s * x + c * y

    def linear_velocity(self) -> Any:
        """(vx, vy, 0): the command frame's velocity at its own origin."""
        return ca.vertcat(self.vx_m_s, self.vy_m_s, 0)


__all__ = [
    "IN_PLACE_FOOTPRINT_LEG_LENGTHS",
    "IN_PLACE_SWING_CLEARANCE_LEG_LENGTHS",
    "N_MOTION_PARAMETERS",
    "MotionSymbols",
    "VelocityCommand",
    "check_command",
    "compose",
    "in_place_options",
    "motion_parameters",
    "planar_displacement",
    "stance_com_offset_m",
    "world_base_poses",
]

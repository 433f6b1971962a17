"""Planner options and objective weights: frozen values with units in their names.

Defaults follow Wampler & Popović 2009 (W&P) §3 where it gives numbers (µ = 0.5) and add the servo
physics that make a gait deployable (torque–speed envelope with a margin, speed limit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from planner.errors import PlannerConfigError


@dataclass(frozen=True)
class CostWeights:
    """Weights of the objective terms (W&P eqs 13-16 with servo-normalised effort).

    Every term is averaged over the N knots, so the weights do not depend on N or the period.

    - `effort`: Σ_j (τ_j / τ_stall,j)² — W&P eq 13 (muscle torque²), normalised per servo so
      it measures heating (I²R ∝ τ²) on mixed servos instead of dividing by body mass.
    - `joint_speed_s2`: Σ_j q̇_j² [rad²/s²] — eq 14, suppresses wiggling (units s²/rad²).
    - `bounce_s2_m2`: ẏ² + ż² of the base [m²/s²] — eq 15, head/body motion perpendicular to the
      gait velocity.
    - `orientation_rad2`: roll² + pitch² + yaw² — eq 16, ‖R − I‖² to first order (÷2).
    - `angular_velocity_s2`: |ω_base|² [rad²/s²] — body stability; our addition.
    - `joint_accel_s4`: Σ_j q̈_j² [rad²/s⁴] — smooth targets a position servo can track; ours.

    Default ratios follow W&P's C1:C2:C3:C4 = 25:0.1:25:100 scaled to servo units so the terms have
    the same general magnitude on a 2 kg robot.
    """

    effort: float = 1.0
    joint_speed_s2: float = 1e-3
    bounce_s2_m2: float = 10.0
    orientation_rad2: float = 10.0
    angular_velocity_s2: float = 0.1
    joint_accel_s4: float = 1e-5

    def __post_init__(self) -> None:
        for name, value in self.as_dict().items():
            if not (math.isfinite(value) and value >= 0):
                raise PlannerConfigError(
                    f"cost weight {name} must be a finite number ≥ 0, got {value!r}"
                )

    def as_dict(self) -> dict[str, float]:
        return {
            "effort": self.effort,
            "joint_speed_s2": self.joint_speed_s2,
            "bounce_s2_m2": self.bounce_s2_m2,
            "orientation_rad2": self.orientation_rad2,
            "angular_velocity_s2": self.angular_velocity_s2,
            "joint_accel_s4": self.joint_accel_s4,
        }


@dataclass(frozen=True)
class PlannerOptions:
    """Everything that shapes the NLP except the per-solve parameters (schedule, speed, period).

    - `mu`: friction coefficient of the cone (W&P eq 9 uses 0.5), imposed as the inscribed
      linear pyramid |f_x|, |f_y| ≤ µ/√2 · f_z — conservative, and linear (a cheaper Hessian).
    - `torque_margin`: |τ| ≤ margin · τ_stall · (1 − |q̇|/ω₀); 0.8 leaves the servo 20 % for
      tracking (sim requires peak torque ≤ 80 % of stall).
    - `speed_margin`: |q̇| ≤ margin · ω₀ (no-load speed).
    - `swing_clearance_m`: swing foot-sphere bottom ≥ h·sin(π·swing progress).
    - `body_clearance_m`: every body origin stays this high above the ground (W&P eq 1).
    - `max_tilt_rad`: bounds on base roll, pitch and yaw.
    - `min_base_height_fraction`: base height ≥ this × the robot's nominal stance height, so
      the optimiser cannot save torque by crouching the body onto the ground.
    - `joint_limit_margin_rad`: keep off the hard stops by this much.
    - `max_force_body_weights`: normal force bound in stance, in units of m·g.
    - `servo_goals`: write servo *goal* positions to the gait file instead of the planned angles:
      goal = q + (τ + d·q̇)/kp inverts the servo's proportional position loop (`planner.servo_loop`)
      so the soft factory loop (STS3215: kp ≈ 10 N·m/rad) achieves the planned motion instead of
      sagging and lagging behind it. Goals are kept inside the joint limits (same margin) and
      below the player's step limit `speed_margin`·ω₀. False: the angles themselves (ideal servo).
    - `vertical_contact_transitions`: a foot keeps its ground-frame x, y from the last swing knot
      before touchdown to the first swing knot after lift-off, i.e. it sets down and lifts off
      vertically over one knot interval T/N. Without it the optimiser lands the hind feet still
      moving forward (≈ 0.3 m/s) and lifts the front feet while they already swing forward
      (≈ 0.36 m/s) — in one knot interval nothing in the NLP sees the foot in between, but MuJoCo
      does: impacts and scuffing that pitch the body nose-up and make the hind feet drag.
    - `tol`, `max_iter`, `print_level`: IPOPT; `print_level` 0 silences it, 5 shows iterations.
    """

    mu: float = 0.5
    torque_margin: float = 0.8
    speed_margin: float = 0.9
    swing_clearance_m: float = 0.025
    body_clearance_m: float = 0.03
    max_tilt_rad: float = 0.35
    min_base_height_fraction: float = 0.8
    joint_limit_margin_rad: float = 0.02
    max_force_body_weights: float = 3.0
    servo_goals: bool = True
    vertical_contact_transitions: bool = True
    weights: CostWeights = field(default_factory=CostWeights)
    tol: float = 1e-6
    max_iter: int = 150
    print_level: int = 0
    linear_solver: str = "mumps"

    def __post_init__(self) -> None:
        checks = {
            "mu": 0 < self.mu <= 5,
            "torque_margin": 0 < self.torque_margin <= 1,
            "speed_margin": 0 < self.speed_margin <= 1,
            "swing_clearance_m": 0 <= self.swing_clearance_m < 1,
            "body_clearance_m": 0 <= self.body_clearance_m < 1,
            "max_tilt_rad": 0 < self.max_tilt_rad < 1.5,
            "min_base_height_fraction": 0 <= self.min_base_height_fraction < 1.5,
            "joint_limit_margin_rad": 0 <= self.joint_limit_margin_rad < 0.5,
            "max_force_body_weights": self.max_force_body_weights > 0,
            "tol": 0 < self.tol < 1,
            "max_iter": self.max_iter > 0,
        }
        for name, ok in checks.items():
            if not ok:
                raise PlannerConfigError(
                    f"planner option {name}={getattr(self, name)!r} is out of range"
                )

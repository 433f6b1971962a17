"""Planner options and objective weights: frozen values with units in their names.

Defaults follow Wampler & Popović 2009 (W&P) §3 where it gives numbers (µ = 0.5) and add the servo
physics that make a gait deployable (torque–speed envelope with a margin, speed limit).

Scaling with the body (geometric and dynamic similarity; Alexander & Jayes 1983): a robot is
described by its leg length L (`Robot.leg_length_m`, hip height over the foot at stance) and
every default that is a length or a speed follows it, so a 7.5 cm hobby quadruped gets the same
plan *shape* as a 20 cm one instead of lifting its feet a third of its leg:

- swing clearance  h_swing = `SWING_CLEARANCE_LEG_LENGTHS` · L   (0.14 L: 25 mm at L = 0.18 m)
- body clearance   h_body  = `BODY_CLEARANCE_LEG_LENGTHS` · L    (0.17 L: 30 mm at L = 0.18 m)
- period           T = k · √(L/g) per template (`planner.templates`)
- speed            v = √(Fr · g · L) at Froude number Fr (`default_speed_m_s`,
  `DEFAULT_FROUDE` = 0.035 ≈ 0.25 m/s at L = 0.18 m; walking animals change gait near
  Fr ≈ 0.5, dynamically similar gaits share Fr)
- step length      s = v · T = k · √Fr · L, so it scales with L by the two laws above.

`PlannerOptions.swing_clearance_m` / `body_clearance_m` override the laws with fixed metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.contact_margin import (
    CAPTURE_SOLE_FRACTION,
    COP_SOLE_FRACTION,
    FLAT_MEAN_FOOTPRINT_LEG_LENGTHS,
)
from planner.nlp.force_rate import NORMAL_FORCE_RATE_WEIGHTS_PER_T0
from planner.nlp.sideways_locked import SIDEWAYS_SLIP_LEG_LENGTHS
from robots.servo_params import ServoSetting

#: Scaling laws with the leg length L (see the module docstring).
SWING_CLEARANCE_LEG_LENGTHS = 0.14
BODY_CLEARANCE_LEG_LENGTHS = 0.17
DEFAULT_FROUDE = 0.035
#: `PlannerOptions.unmirrored_mean_footprint_leg_lengths` (docstring of `PlannerOptions`)
UNMIRRORED_MEAN_FOOTPRINT_LEG_LENGTHS: float | None = 0.05
GRAVITY_M_S2 = 9.81
#: values of `PlannerOptions.derivatives`
DERIVATIVE_PATHS = ("knot", "expanded", "compiled")
#: values of `PlannerOptions.ipopt_tuning` (`planner.nlp.spacetime.ipopt_options`)
IPOPT_TUNINGS = ("tuned", "session21")
#: IPOPT options `PlannerOptions.ipopt_extra` may not set: the planner's own plumbing (how it
#: passes starts and scales), which an override would silently break
IPOPT_EXTRA_RESERVED = ("warm_start_init_point", "linear_solver", "print_level", "max_iter", "sb")
#: `PlannerOptions.ipopt_extra`: a name "warm:NAME" sets IPOPT's NAME in warm solves only
WARM_ONLY_PREFIX = "warm:"
#: values of `PlannerOptions.nlp_jacobian`
NLP_JACOBIANS = ("ad", "assembled")
#: values of `PlannerOptions.nlp_hessian`
NLP_HESSIANS = ("ad", "assembled")
#: `PlannerOptions.nlp_hessian`'s default (`gaitsmith plan --nlp-hessian` says it)
DEFAULT_NLP_HESSIAN = "assembled"
#: the inequality rows `PlannerOptions.compact_rows` can give IPOPT in a smaller form
COMPACT_ROWS = ("joint speed", "goal slope", "torque envelope", "swing force")
#: `PlannerOptions.compact_rows`' default: the one form that keeps IPOPT's barrier problem
#: (docs/results/planner_speed_rows.md, session 31)
DEFAULT_COMPACT_ROWS = ("torque envelope",)
#: values of `PlannerOptions.cold_start` (`planner.nlp.cold_start`)
COLD_STARTS = ("stance", "balanced", "stride")
#: values of `PlannerOptions.swing_wrench` (`planner.nlp.swing_wrench`)
SWING_WRENCHES = ("rows", "bounds")
#: `PlannerOptions.swing_wrench`'s default: "bounds" since session 42 (was "rows"), with
#: `DEFAULT_SEPARATION_UNIT_LEG_LENGTHS`. Template path (half-cycle, cold, N = 30): over every
#: template + 20 random schedules of quad12 and hex18, 35 judged: 6 cheaper, 25 within 1e-4, 4
#: costlier — quad12 wave +3.4 %, hex18 random2 +2.1 %, random7 +8.0e-4, quad12 random3
#: +1.0e-4, each another local optimum of the same NLP — geometric mean 0.995, 0.68-0.70x the
#: iterations (session 41, 41d); the 14 zoo template commands the same MuJoCo verdict on 14
#: of 14 (41e); quad12 trot cold 16 iterations, 0.45-0.52 s CPU against 19 and 0.52-0.62 s,
#: hex18 tripod 25 against 40, 0.65-0.68x the CPU (41f; session 42: 0.52 against 0.61 s, 1.6
#: against 2.4 s). On the bipeds only with the separation
#: unit (session 42): the built-in biped's walk at 0.1-0.3 m/s and its run, each over nine
#: draws of the start, at most 18-26 iterations by command (rows 26-65, "bounds" in
#: metres 35-118).
#: The 32 searches (session 42): the same written gait within 1e-4 in 31, one biped walk
#: 0.52 % cheaper, 32 of 32 passing, 0.967x the CPU; the library and retarget on a small
#: grid: the same verdicts, objectives within 2e-5 (docs/results/planner_speed_coldstart.md).
DEFAULT_SWING_WRENCH = "bounds"
#: values of `PlannerOptions.servo_goal_form`: "direct" (the servo-goal rows read q, τ, q̇) or
#: "lifted" (the goal g = q + τ/k_p + (d/k_p)·q̇ a variable of its own, tied by an equality row;
#: the goal rows read g). The same feasible set; MUMPS' factor flops 0.71-0.82x on quad12 and
#: hex18 (docs/results/planner_speed_rows.md, session 43)
SERVO_GOAL_FORMS = ("direct", "lifted")
#: `PlannerOptions.servo_goal_form`'s default since session 43: "lifted". The per-schedule bar
#: met (templates + 20 random schedules: quad12 12/12 and hex18 23/23 at the same optimum, worst
#: 4.8e-6, the capped ones capped alike; seven zoo robots the same verdicts, costs within 8e-7);
#: cold solves 0.83-0.92x the CPU on quad12 trot and hex18 tripod (compiled), warm chains
#: 0.79-0.93x; hex18's README search neutral (0.95-1.14x). "direct" is the NLP before.
DEFAULT_SERVO_GOAL_FORM = "lifted"
#: values of `PlannerOptions.warm_retime` (`planner.nlp.warm_start`)
WARM_RETIMES = ("none", "whole", "per foot")
#: values of `PlannerOptions.warm_swing_wrench`: "same" (the solve's own, `swing_wrench`)
WARM_SWING_WRENCHES = ("same", *SWING_WRENCHES)
#: values of `PlannerOptions.cold_mu_centrality`: IPOPT's ``quality_function_centrality``
COLD_MU_CENTRALITIES = ("none", "reciprocal")
#: `PlannerOptions.cold_mu_centrality`'s default (the search's coarse solves use
#: `planner.search.defaults.SEARCH_COLD_MU_CENTRALITY` whatever the options say)
DEFAULT_COLD_MU_CENTRALITY = "none"
#: values of `PlannerOptions.stance_clearance` (`planner.nlp.stance_clearance`)
STANCE_CLEARANCES = ("rows", "free")
#: `PlannerOptions.stance_clearance`'s default (the search's coarse solves use
#: `planner.search.defaults.SEARCH_STANCE_CLEARANCE` whatever the options say)
DEFAULT_STANCE_CLEARANCE = "rows"
#: values of `PlannerOptions.inactive_rows` (`planner.nlp.inactive_rows`)
INACTIVE_ROWS = ("rows", "free", "free stance", "regularised")
#: `PlannerOptions.inactive_rows`' default ("rows"; the search's coarse solves use
#: `planner.search.defaults.SEARCH_INACTIVE_ROWS` whatever the options say). "free stance" at
#: N = 30 kept every optimum on quad12 and hex18 (as "free", session 33), the biped, humanoid20,
#: star5, spotmicro, knee8 and phantomx18, but ended bittle8's template walk 2.7 % costlier
#: (docs/results/planner_speed_ipopt.md, session 34)
DEFAULT_INACTIVE_ROWS = "rows"
#: the groups whose switched-off rows each "free…" value of `PlannerOptions.inactive_rows`
#: unbounds (None: every group that has an activity factor)
FREED_GROUPS: dict[str, tuple[str, ...] | None] = {
    "free": None,
    "free stance": ("stance height", "stance no-slip"),
}
#: `PlannerOptions.cold_start`'s default
DEFAULT_COLD_START = "stance"
#: `PlannerOptions.half_cycle_solve`'s default: on for every single gait planned from a template
#: or a given schedule (`gaitsmith plan --gait`, the library, retarget, the design search's
#: bodies); a solve it does not fit (a turn, an asymmetric schedule or start, a body with no
#: mirror map) is the full NLP's. One solve 0.47–0.63× the CPU, the same MuJoCo verdict on 14 of
#: 14 zoo templates (docs/results/planner_speed_search.md, 36-lead f;
#: planner_speed_template_half.md, session 38). The gait search overrides it: its coarse solves
#: use `planner.search.defaults.SEARCH_HALF_CYCLE`, its final re-solves
#: `planner.search.defaults.FINAL_HALF_CYCLE`, whatever the options say
#: (`gaitsmith plan --half-cycle/--full-cycle` given explicitly sets both)
DEFAULT_HALF_CYCLE_SOLVE = True
#: `PlannerOptions.warm_half_cycle`'s default: a warm solve on a symmetric schedule from a start
#: on the mirror subspace takes the half-cycle NLP too (with the warm IPOPT options). Over 40
#: warm solves of symmetric perturbed chains (quad12 trot, hex18 tripod, N = 30, five chains)
#: the same verdict as the full warm solve on 40, its cost within 1e-4 on 39 (one +1.5e-4, both
#: below the cold solve's) at 0.50–0.52× its CPU per chain (docs/results/planner_speed_ipopt.md,
#: session 41)
DEFAULT_WARM_HALF_CYCLE = True
#: `PlannerOptions.separation_unit_leg_lengths`' default: the foot-separation rows
#: (`planner.nlp.foot_separation`; the bipeds' only) counted in 0.4 leg lengths (0.1 m on the
#: built-in biped) instead of metres (None, before session 42). In metres a row the cold start sits
#: on weighs little against the dynamics rows in IPOPT's filter; with the swing wrench by bounds
#: the half-cycle NLP's first long steps carried the biped's swing foot 31-77 mm across the
#: other and took ~70 iterations to undo (session 41). Over nine draws of the start, "bounds"
#: with this unit against "bounds" in metres and "rows" in metres: the biped's walk at 0.1 m/s
#: 15-18 / 23-118 / 19-26 iterations, 0.15 m/s 14-24 / 19-92 / 21-29, 0.2 m/s 14-20 / 22-36
#: / 23-46, 0.25 m/s 18-22 / 19-51 / 26-37, 0.3 m/s 22-24 / 20-35 / 28-41, its run 21-26 /
#: 20-72 / 36-65 (unit 0.1 m; 0.4 L measured at 0.1 and 0.15 m/s); costs within 5e-5 of rows'.
#: 0.2 L: 12-38 at 0.1 m/s (12-29 elsewhere); 1 L: 14-30 at 0.1 m/s. humanoid20
#: (`PlannerOptions()`, walk): 18-33 at 0.15 m/s and 25-55 at 0.1 m/s against "bounds" in
#: metres 16-20 / 21-33 and rows 31-36 / 31-38; its CLI walks 17 / 41 against rows' 37 / 38,
#: the same verdicts (docs/results/planner_speed_coldstart.md, session 42).
DEFAULT_SEPARATION_UNIT_LEG_LENGTHS: float | None = 0.4
#: upper bound of `PlannerOptions.knot_threads`
MAX_KNOT_THREADS = 64


def speed_for_froude(froude: float, leg_length_m: float) -> float:
    """v = √(Fr·g·L): the speed of Froude number `froude` for legs of `leg_length_m`."""
    if not (math.isfinite(froude) and froude >= 0 and leg_length_m > 0):
        raise PlannerConfigError(f"Froude number must be ≥ 0, got {froude!r}")
    return math.sqrt(froude * GRAVITY_M_S2 * leg_length_m)


def default_speed_m_s(leg_length_m: float) -> float:
    """The default planning speed: `DEFAULT_FROUDE` for this leg length (0.25 m/s at 18 cm)."""
    return speed_for_froude(DEFAULT_FROUDE, leg_length_m)


def default_speeds_m_s(leg_length_m: float, froudes: tuple[float, ...] = (0.002, 0.01, 0.03,
                                                                           0.06)) -> list[float]:
    """Speeds of a gait-from-speed sweep at fixed Froude numbers (≈ 0.05-0.3 m/s at 18 cm)."""
    return [round(speed_for_froude(fr, leg_length_m), 4) for fr in froudes]


#: IPOPT's iteration cap (`iteration_cap`): `BASE_ITERATION_CAP` at `REFERENCE_VARIABLES` (quad12
#: at 30 knots, whose templates converge in 21-45 iterations), growing with the square root of
#: the number of variables, at most `MAX_ITERATION_CAP`
BASE_ITERATION_CAP = 150
REFERENCE_VARIABLES = 2700
MAX_ITERATION_CAP = 1000


def iteration_cap(n_variables: int) -> int:
    """The default IPOPT iteration cap for an NLP of `n_variables` decision variables.

    Interior-point iteration counts grow slowly with the size of a discretised problem (the
    mesh-independence of Newton-type methods; Wächter & Biegler 2006 report counts nearly flat
    in the mesh size), so the cap grows with √n rather than n: 150 for quad12 at 30 knots
    (2700 variables), 150 for anything smaller, 212 at twice that size, 300 at four times
    (humanoid20 at 60 knots). A point met at the cap is still a gait if it meets every
    constraint (`planner.nlp.diagnostics.ACCEPT_IF_FEASIBLE`); measured iteration counts per
    robot and template are in docs/results/iteration_cap.md.
    """
    if n_variables < 1:
        raise PlannerConfigError(f"an NLP needs variables, got {n_variables}")
    grown = BASE_ITERATION_CAP * math.sqrt(n_variables / REFERENCE_VARIABLES)
    return int(min(MAX_ITERATION_CAP, max(BASE_ITERATION_CAP, round(grown))))


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
    - `posture_rad2`: Σ_j (q_j − q_stance,j)² [rad²] — distance from the robot's stance pose
      (robot.toml `stance_deg`), the regularising "rest pose" term of W&P-style objectives; it
      keeps joints the gait does not need (and "hold" joints outside the legs) near their
      stance instead of wherever the optimiser leaves them. 0.01: a 0.3 rad mean deviation over
      12 joints costs ≈ 0.01, a few per cent of a walk's objective.
    - `yaw_moment_mgl2`: Σ_feet τ_z² of the flat feet's contact moments about the vertical, in
      units of (m·g·L)² — the yaw moment the soles must hold by friction (`planner.nlp.costs`).
      0 by default (the objective is unchanged); point feet have no moment and add nothing.

    Default ratios follow W&P's C1:C2:C3:C4 = 25:0.1:25:100 scaled to servo units so the terms have
    the same general magnitude on a 2 kg robot.
    """

    effort: float = 1.0
    joint_speed_s2: float = 1e-3
    bounce_s2_m2: float = 10.0
    orientation_rad2: float = 10.0
    angular_velocity_s2: float = 0.1
    joint_accel_s4: float = 1e-5
    posture_rad2: float = 0.01
    yaw_moment_mgl2: float = 0.0

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
            "posture_rad2": self.posture_rad2,
            "yaw_moment_mgl2": self.yaw_moment_mgl2,
        }


@dataclass(frozen=True)
class PlannerOptions:
    """Everything that shapes the NLP except the per-solve parameters (schedule, speed, period).

    - `mu`: friction coefficient of the cone (W&P eq 9 uses 0.5), imposed as the inscribed
      linear pyramid |f_x|, |f_y| ≤ µ/√2 · f_z — conservative, and linear (a cheaper Hessian).
    - `torque_margin`: |τ| ≤ margin · τ_stall · (1 − |q̇|/ω₀); 0.8 leaves the servo 20 % for
      tracking and equals the MuJoCo verdict's peak-torque limit (80 % of stall), so it keeps
      no headroom below the verdict on purpose: on the zoo's template plans (Fr 0.02–0.03) no
      knot is on the envelope, MuJoCo's peaks exceed the plan by 9–35 points of stall away from
      it (humanoid20: stance sag), and 0.78 / 0.75 lowered no peak but lost the built-in biped's
      walk (docs/results/zoo_gaits.md, "Session 27"). Heavy rotors: `rotor_reserve`.
    - `speed_margin`: |q̇| ≤ margin · ω₀ (no-load speed).
    - `swing_clearance_m`: swing foot-sphere bottom ≥ h·sin(π·swing progress); None (default):
      h = `SWING_CLEARANCE_LEG_LENGTHS`·L (`swing_clearance_for`).
    - `body_clearance_m`: every body origin stays this high above the ground (W&P eq 1); None
      (default): `BODY_CLEARANCE_LEG_LENGTHS`·L (`body_clearance_for`).
    - `max_tilt_rad`: bounds on base roll, pitch and yaw.
    - `min_base_height_fraction`: base height ≥ this × the robot's nominal stance height, so
      the optimiser cannot save torque by crouching the body onto the ground.
    - `joint_limit_margin_rad`, `joint_limit_margin_fraction`: keep every joint (planned
      angle and servo goal) off its limits by max(margin_rad, fraction × range), at most a
      quarter of the range — no plan parks a joint on its stop. The closest approach of each
      joint is written to the gait file (planner metadata ``joint_limit_clearance``).
    - `max_force_body_weights`: normal force bound in stance, in units of m·g.
    - `servo_goals`: write servo *goal* positions to the gait file instead of the planned angles:
      goal = q + (τ + d·q̇)/kp inverts the servo's proportional position loop
      (`planner.nlp.servo_loop`)
      so the soft factory loop (STS3215: kp ≈ 10 N·m/rad) achieves the planned motion instead of
      sagging and lagging behind it. Goals are kept inside the joint limits (same margin) and
      below the player's step limit `speed_margin`·ω₀. False: the angles themselves (ideal servo).
    - `vertical_contact_transitions`: a foot keeps its ground-frame x, y from the last swing knot
      before touchdown to the first swing knot after lift-off, i.e. it sets down and lifts off
      vertically over one knot interval T/N. Without it the optimiser lands the hind feet still
      moving forward (≈ 0.3 m/s) and lifts the front feet while they already swing forward
      (≈ 0.36 m/s) — in one knot interval nothing in the NLP sees the foot in between, but MuJoCo
      does: impacts and scuffing that pitch the body nose-up and make the hind feet drag.
    - `nondimensional`: the solver works on variables and constraint rows divided by their
      natural units (lengths by the leg length L, times by √(L/g), forces by m·g, torques by
      m·g·L; `planner.nlp.variables.variable_scale`). Results and reports stay in SI units and the
      optimum is the same (equal costs to 4 digits). Off by default because it did not reduce
      IPOPT iterations where measured (tests/planner/any_body_bench.py, N = 16, every template,
      cold): 0.23 kg quadruped 216 vs 212 iterations, 5-leg star 210 vs 191. What made the
      small robot hit the 150-iteration cap was the clearances fixed in metres (a 25 mm swing
      on a 76 mm leg) and the missing posture term: main 456 iterations with `pace` stopped at
      the cap, + posture and limit margins 280, + clearances ∝ L 212, all templates feasible.
      Forces are already in body weights and the servo rows in fractions of the servo's
      limits, and IPOPT's gradient-based row scaling covers the rest.
    - `static_margin_leg_lengths`: None (default) or d/L > 0: at every knot whose stance feet
      span a polygon, the ground projection of the centre of mass stays at least d = this × L
      inside it (`planner.search.support.polygon_edges`; the static stability margin of a
      crawl). Open-loop position servos cannot catch a body balanced dynamically outside its
      support (`planner.search.support`), so commanded walks ask for it
      (`gaitsmith.gait_choice.commanded_gait`). Knots on a line or in flight are not
      constrained.
    - `mean_footprint_leg_lengths`: None (default) or t/L > 0: the cycle mean of every foot's
      x, y in the base frame (forward kinematics of the joints alone) stays within ±t of its
      nominal stance position. Without it nothing but the weak posture term anchors the
      footprint to the body, and commanded side-steps and turns came out with their mean
      footprint sheared or turned by up to 30° about the body (feet 110 mm from nominal): the
      entry ramp (`robots.ramp`) goes to the gait's mean pose, so it twisted the standing robot
      by that much before the first step (`gaitsmith.gait_choice.commanded_gait`). The mean, not
      every knot (TOWR's range-of-motion box, Winkler et al. 2018), so strides of any length
      stay possible.
    - `mean_footprint_offset_m`: (dx, dy) added to every foot's nominal position in that
      constraint (base frame): stepping in place centres the footprint under the centre of mass
      (`planner.nlp.command.in_place_options`).
    - `cop_sole_fraction`: a flat foot's contact wrench stays in the cone of its sole shrunk
      about the centre to this share of its half extents — a centre-of-pressure and
      torsional-friction margin (`planner.nlp.contact_margin`; 1: the whole sole).
    - `capture_sole_fraction`: None or s: in single support on a flat foot the instantaneous
      capture point stays within s half widths of the stance sole's centre line (lateral;
      `planner.nlp.capture_margin`).
    - `flat_mean_footprint_leg_lengths`: None or t/L: a robot with flat feet gets the "mean
      footprint" rows at this t when `mean_footprint_leg_lengths` is None (some biped plans
      limp without them, docs/results/biped_walk_robustness.md).
    All three are off by default (`planner.nlp.contact_margin` says why).
    - `unmirrored_mean_footprint_leg_lengths`: None or t/L (default 0.05, the commanded gaits'
      `gaitsmith.gait_choice.MEAN_FOOTPRINT_LEG_LENGTHS`): a robot whose stance feet are not
      all in mirror pairs — a foot on the sagittal plane (an odd leg count) or no mirror
      image at all (`planner.nlp.constraints.footprint_unheld_by_symmetry`) — gets the "mean
      footprint" rows at this t when `mean_footprint_leg_lengths` is None. Its gaits cannot
      be half-cycle mirror symmetric, so nothing but the weak posture term holds the yaw of
      the mean footprint about the body, and the entry ramp to the gait's mean pose
      (`robots.ramp`) turns the standing robot by that yaw: star5's ripple at 0.117 m/s had
      its mean footprint turned −7.5° and MuJoCo measured +7.4° of body yaw during the 1 s
      ramp, before the first step (heading +8.3°, FAIL); with the rows, +0.19° and +1.1°
      (PASS; docs/results/zoo_gaits.md, "Session 26: star5's first-cycle turn"). Robots
      with only mirror pairs get no rows (their default plans' mean footprints turned 0.00°).
    - `normal_force_rate_weights_per_t0`: ρ > 0 or None: every foot's normal force changes by
      at most ρ body weights per leg time unit √(L/g) between neighbouring knots, swing knots
      included (`planner.nlp.force_rate`): the load builds over several knots after touchdown
      and fades before lift-off instead of jumping to ≈ 2 body weights in one knot, which
      position servos cannot produce (measured in MuJoCo, docs/results/zoo_gaits.md,
      "Session 24"); scaled by body weight and the leg's time unit, so one ρ asks the same of
      dynamically similar robots (5: one body weight in 0.2·√(L/g)). Default None: no rows
      (a different local optimum turned star5's entry, `planner.nlp.force_rate`).
    - `rotor_reserve`: ρ ≥ 0 or None: the torque envelope also holds for τ + ρ·I_a·q̈, the knot
      torque with the servo rotor's share (MJCF armature × joint acceleration) taken 1 + ρ
      times (`planner.nlp.constraints`, group "rotor reserve"): with a heavy rotor the plan's
      swing ends sit on the envelope with 0.65–0.85 of stall spent on the rotor, and MuJoCo's
      servo adds ≈ 0.04 on average and ≈ ±0.06 from cycle to cycle there
      (docs/results/heavy_rotor.md). 0.1–0.15 took spotmicro's walk with the identified STS3215
      rotor from 84 % to 78–79 % peak torque; plans already on their envelope become
      infeasible. Default None: no rows.
    - `line_capture_margin_leg_lengths`: m/L ≥ 0 or None: at every knot where exactly two feet
      stand (a support line), the capture point ξ = c + ċ/ω lies at least m on the side of
      the line where the next swing foot lands (`planner.nlp.line_capture`): the open-loop
      body then falls toward the landing foot rather than back over the foot that has just
      lifted. 0.16 took knee8's duty-0.6 walk (T 1.35 s, ρ 0.15) from 0.155 to 0.180 m/s of
      0.182 (docs/results/heavy_rotor.md §7). Default None: no rows.
    - `half_cycle_mirror`: the second half of the cycle is the first half mirrored under
      y → −y (`planner.nlp.mirror`): for straight gaits of left–right symmetric bodies on
      half-cycle symmetric schedules, so IPOPT cannot return a limping or turning asymmetric
      optimum. Off by default; `gaitsmith plan --mirror`.
    - `half_cycle_solve`: solve a straight gait on a half-cycle mirror-symmetric schedule of a
      left–right symmetric body on the first half of its knots, the second half its mirror
      image (`planner.nlp.half_cycle`): the same iterates as the full NLP where those stay
      symmetric (IPOPT's do from the symmetric cold start), on a KKT system half the size.
      Any other solve (a turn, an asymmetric schedule or start) is the full NLP's. On by
      default (`DEFAULT_HALF_CYCLE_SOLVE`); the gait search's final re-solves take
      `planner.search.defaults.FINAL_HALF_CYCLE` (on since session 40, a narrow MuJoCo failure
      re-solved full: `FINAL_RETRY_FULL`).
    - `sideways_slip_leg_lengths`: ε/L of the lateral no-slip band of feet whose legs cannot
      move them sideways relative to the body (hip-and-knee legs; `planner.nlp.sideways_locked`):
      their equality rows are degenerate and IPOPT stalled on them. 0: equality rows.
    - `tol`, `max_iter`, `print_level`: IPOPT; `print_level` 0 silences it, 5 shows iterations.
      `max_iter` None (default): the cap follows the problem size, `iteration_cap`.
    - `derivatives`: how IPOPT gets the NLP's Jacobian and Hessian (the optimum is the same):
      "knot" — from one knot's sparse Jacobian and Lagrangian Hessian, cached on disk
      (`planner.nlp.solver_cache`): builds in a fraction of the time; "expanded" — the whole NLP
      expanded to SX and differentiated (the path before issue #16); "compiled" — "knot" with
      J and H compiled to C once per robot (`planner.nlp.compiled_knot`: minutes the first time,
      then faster solves; "knot" uses a compiled entry it finds in the cache). See
      docs/results/planner_speed.md and planner_speed_compiled.md for the measured times.
    - `ipopt_tuning`: IPOPT's options (`planner.nlp.spacetime.ipopt_options`): "tuned"
      (default: a warm start and its bound multipliers are pushed 1e-3 inside the bounds,
      fewer iterations than a cold start, docs/results/planner_speed_ipopt.md; cold solves
      unchanged) or "session21" (1e-6, the options before that tuning, kept to measure
      against). Same optimum.
    - `knot_threads`: evaluate the knot function and its derivatives in that many threads
      (CasADi "thread" map in equal chunks, `planner.nlp.constraints.mapped_knots`); same
      values. 1 (default): two threads cost 5–15 % more CPU and lost where measured without
      heavy oversubscription (quad12 trot 1.16× per solve); a search's worker processes
      already use the cores (docs/results/planner_speed_threads.md).
    - `nlp_jacobian`: how IPOPT's constraint Jacobian is computed with `derivatives` "knot" or
      "compiled" ("expanded" always differentiates its SX): "assembled" (default) — the chain
      rule written out with one J per knot (`planner.nlp.assembled_jacobian`); "ad" — CasADi's
      AD of the NLP, which seeds the knots in batches of 64 forward directions (every knot's J
      twice when a knot's rows depend on more than 64 variables: hex18). Same Jacobian to
      rounding, the same iterates where measured; jac_g CPU per call quad12 15.0 → 11.0 ms,
      compiled 9.2 → 3.5 ms, hex18 48 → 18 ms (docs/results/planner_speed_lifted.md). With
      `knot_threads` > 1 the assembled Jacobian evaluates J serially.
    - `nlp_hessian`: how IPOPT's Lagrangian Hessian is computed with `derivatives` "knot" or
      "compiled": "assembled" (default) — the chain rule written out with one knot Hessian per
      knot, weighted by that knot's multipliers (`planner.nlp.assembled_hessian`); "ad" —
      CasADi's forward-over-adjoint AD of the NLP, which calls the knot's H·Δu for n seed
      directions. The same Hessian to rounding, not the same bits: the same optimum on 21 of
      21 quad12/hex18 schedules, the same knife-edge counts on the 9 must-show robots,
      planner build 0.71–0.84× the CPU, solves 0.97–0.98× (quad12, hex18) and 0.80×
      (humanoid20) (docs/results/planner_speed.md, sessions 29 and 30).
    - `compact_rows`: inequality rows handed to IPOPT in a smaller form with exactly the same
      feasible set (`COMPACT_ROWS`; each inequality row costs the KKT system a slack and a
      multiplier row): "joint speed" — |q̇| ≤ margin·ω₀ on the lifted rates as variable
      bounds; "goal slope" — the servo-goal speed's sample at a knot (u = 0, the lifted spline
      slope s_k) as a bound on s_k; "torque envelope" — the diamond's four faces per joint as
      two ranged rows −1 ≤ τ/τ_s ± q̇/ω₀ ≤ 1 (also the rotor reserve's); "swing force" —
      f_z ≤ C·f_max as a per-solve upper bound of f_z (0 in swing: IPOPT drops the variable).
      Reports still name every row by its group (`planner.nlp.diagnostics.BoundRows`).
      Default `DEFAULT_COMPACT_ROWS` ("torque envelope"): the ranged rows give IPOPT the same
      barrier problem in a KKT system 1440 rows smaller (quad12, N = 30): the same optimum on
      every feasible quad12 and hex18 schedule measured, 0.98× the CPU per iteration; the
      bounds change IPOPT's start and path, took other iteration counts and on quad12's wave
      another local optimum (+3.4 %). Measured in docs/results/planner_speed_rows.md
      (session 31); () is the NLP before.
    - `cold_start`: the start of a cold solve (`planner.nlp.cold_start`): "stance" (the
      nominal stance at every knot, lifted variables zero), "balanced" (the same poses with the
      wrench balancing the body and the torques its inverse dynamics) or "stride" (feet walking
      the treadmill by IK, rates, wrench and torques consistent with it).
      docs/results/planner_speed_init.md measures them.
    - `swing_wrench`: how a swing foot's wrench is held at 0 (`planner.nlp.swing_wrench`):
      "rows" (the schedule's rows and f_z ≥ 0 pin it from both sides) or "bounds" (fixed by
      its bounds per solve, the rows it pins freed; the default since session 42,
      `DEFAULT_SWING_WRENCH`). The same feasible set.
    - `inactive_rows`: the equality rows the schedule switches off (a swing foot's "stance
      height", "stance no-slip" over two swing knots, a flat foot's "sole level" and "sole yaw
      hold"; each reads 0 = 0 and makes the constraint Jacobian rank-deficient,
      `planner.nlp.inactive_rows`): "rows" keeps them as 0 = 0, "free" unbounds them per solve,
      "free stance" unbounds only the "stance height" and "stance no-slip" ones (all of them on
      point feet; a flat foot's sole rows stay rows), "regularised" keeps them and has IPOPT
      regularise the constraint block from the first iteration (``perturb_always_cd``) instead
      of after its degeneracy test. The same feasible set. The search's coarse solves use
      `planner.search.defaults.SEARCH_INACTIVE_ROWS` whatever this says.
    - `stance_clearance`: the "swing clearance" rows of the (foot, knot) pairs in contact, which
      repeat the "stance height" equality there (`planner.nlp.stance_clearance`): "rows" keeps
      them, "free" unbounds them per solve. The same feasible set. The search's coarse solves
      use `planner.search.defaults.SEARCH_STANCE_CLEARANCE` whatever this says.
    - `cold_mu_centrality`: IPOPT's ``quality_function_centrality`` for the solves that start
      with the cold options (`planner.nlp.spacetime.ipopt_options`: every solve but a warm one
      under the "tuned" tuning): "none" (IPOPT's default) or "reciprocal", a term that makes
      the adaptive μ oracle avoid μ far below the iterate's complementarity spread
      (docs/results/planner_speed_coldstart.md). The search's coarse solves use
      `planner.search.defaults.SEARCH_COLD_MU_CENTRALITY` whatever this says.
    - `warm_retime`: how a warm start that knows its schedule (`WarmStart.schedule`: the
      planner's last solution, a `PlanResult.warm_start`) is mapped onto another schedule
      before the solve (`planner.nlp.warm_start`): "none" (as it is), "whole" (every quantity
      at the same phase, rates by the period ratio: `planner.nlp.variables.retimed_start`),
      "per foot" (each leg's quantities by the phase since its foot's touchdown).
    - `warm_swing_wrench`: how a warm solve holds the swing feet's wrench at 0: "same" (as
      `swing_wrench` or `solve(swing_wrench=)` say) or one of `SWING_WRENCHES` (a solve that
      is given `swing_wrench` explicitly keeps it).
    - `warm_half_cycle`: a warm solve on a half-cycle symmetric schedule from a start on the
      mirror subspace may use the half-cycle NLP (`half_cycle_solve`) with the warm IPOPT
      options (a reduced IPOPT instance of its own, created at its first warm solve); off:
      warm solves take the full NLP when the warm options differ from the cold ones (before
      session 41). On by default (`DEFAULT_WARM_HALF_CYCLE`); `warm_retime` and
      `warm_swing_wrench` are off ("none", "same"): each moved some hex18 warm solves to
      another local optimum than the full warm solve's.
    Measured in docs/results/planner_speed_ipopt.md (session 41).
    - `ipopt_extra`: IPOPT options (name, value) set on top of `ipopt_tuning`'s, cold and warm
      solves alike (`planner.nlp.spacetime.ipopt_options`), or only warm ones when the name
      is "warm:NAME" (`WARM_ONLY_PREFIX`); () (default) adds none. For
      screening IPOPT's options on the planner as users run it (benchmarks/tail_screen.py,
      planner_speed_ipopt.md session 43); not `IPOPT_EXTRA_RESERVED`, and `tol` and
      `max_iter` have fields of their own.
    - `hessian_shift_acc`: add this × IPOPT's objective factor to the diagonal of the Lagrangian
      Hessian IPOPT is given on the lifted accelerations (`planner.nlp.hessian_shift`): the
      Newton model only, not the NLP (the same KKT points); 0 (default) adds nothing. Needs
      `nlp_hessian` "assembled" with "knot" derivatives (docs/results/planner_speed_rows.md,
      session 44).
    - `separation_unit_leg_lengths`: the length the foot-separation rows
      (`planner.nlp.foot_separation`, only bodies whose feet stand close: the bipeds) are
      counted in, in leg lengths; None: metres. The same feasible set; it weighs the rows' violation
      against the other rows' in IPOPT's filter and their multipliers' start
      (docs/results/planner_speed_coldstart.md, session 42).
    """

    mu: float = 0.5
    torque_margin: float = 0.8
    speed_margin: float = 0.9
    swing_clearance_m: float | None = None
    body_clearance_m: float | None = None
    max_tilt_rad: float = 0.35
    min_base_height_fraction: float = 0.8
    joint_limit_margin_rad: float = 0.02
    joint_limit_margin_fraction: float = 0.02
    max_force_body_weights: float = 3.0
    servo_goals: bool = True
    servo_settings: tuple[ServoSetting, ...] | None = None  # identified servos, per joint
    vertical_contact_transitions: bool = True
    weights: CostWeights = field(default_factory=CostWeights)
    nondimensional: bool = False
    static_margin_leg_lengths: float | None = None
    mean_footprint_leg_lengths: float | None = None
    mean_footprint_offset_m: tuple[float, float] = (0.0, 0.0)
    cop_sole_fraction: float = COP_SOLE_FRACTION
    capture_sole_fraction: float | None = CAPTURE_SOLE_FRACTION
    flat_mean_footprint_leg_lengths: float | None = FLAT_MEAN_FOOTPRINT_LEG_LENGTHS
    unmirrored_mean_footprint_leg_lengths: float | None = UNMIRRORED_MEAN_FOOTPRINT_LEG_LENGTHS
    normal_force_rate_weights_per_t0: float | None = NORMAL_FORCE_RATE_WEIGHTS_PER_T0
    rotor_reserve: float | None = None
    line_capture_margin_leg_lengths: float | None = None
    half_cycle_mirror: bool = False
    half_cycle_solve: bool = DEFAULT_HALF_CYCLE_SOLVE
    sideways_slip_leg_lengths: float = SIDEWAYS_SLIP_LEG_LENGTHS
    tol: float = 1e-6
    max_iter: int | None = None
    print_level: int = 0
    linear_solver: str = "mumps"
    derivatives: str = "knot"
    ipopt_tuning: str = "tuned"
    knot_threads: int = 1
    nlp_jacobian: str = "assembled"
    nlp_hessian: str = DEFAULT_NLP_HESSIAN
    compact_rows: tuple[str, ...] = DEFAULT_COMPACT_ROWS
    cold_start: str = DEFAULT_COLD_START
    swing_wrench: str = DEFAULT_SWING_WRENCH
    inactive_rows: str = DEFAULT_INACTIVE_ROWS
    stance_clearance: str = DEFAULT_STANCE_CLEARANCE
    cold_mu_centrality: str = DEFAULT_COLD_MU_CENTRALITY
    warm_retime: str = "none"
    warm_swing_wrench: str = "same"
    warm_half_cycle: bool = DEFAULT_WARM_HALF_CYCLE
    separation_unit_leg_lengths: float | None = DEFAULT_SEPARATION_UNIT_LEG_LENGTHS
    servo_goal_form: str = DEFAULT_SERVO_GOAL_FORM
    ipopt_extra: tuple[tuple[str, float | int | str], ...] = ()
    hessian_shift_acc: float = 0.0

    def __post_init__(self) -> None:
        checks = {
            "mu": 0 < self.mu <= 5,
            "torque_margin": 0 < self.torque_margin <= 1,
            "speed_margin": 0 < self.speed_margin <= 1,
            "swing_clearance_m": self.swing_clearance_m is None
            or 0 <= self.swing_clearance_m < 1,
            "body_clearance_m": self.body_clearance_m is None or 0 <= self.body_clearance_m < 1,
            "max_tilt_rad": 0 < self.max_tilt_rad < 1.5,
            "min_base_height_fraction": 0 <= self.min_base_height_fraction < 1.5,
            "joint_limit_margin_rad": 0 <= self.joint_limit_margin_rad < 0.5,
            "joint_limit_margin_fraction": 0 <= self.joint_limit_margin_fraction <= 0.25,
            "max_force_body_weights": self.max_force_body_weights > 0,
            "static_margin_leg_lengths": self.static_margin_leg_lengths is None
            or 0 < self.static_margin_leg_lengths < 1,
            "mean_footprint_leg_lengths": self.mean_footprint_leg_lengths is None
            or 0 < self.mean_footprint_leg_lengths < 2,
            "mean_footprint_offset_m": len(self.mean_footprint_offset_m) == 2
            and all(math.isfinite(v) and abs(v) < 1 for v in self.mean_footprint_offset_m),
            "cop_sole_fraction": 0 < self.cop_sole_fraction <= 1,
            "capture_sole_fraction": self.capture_sole_fraction is None
            or 0 < self.capture_sole_fraction <= 1,
            "flat_mean_footprint_leg_lengths": self.flat_mean_footprint_leg_lengths is None
            or 0 < self.flat_mean_footprint_leg_lengths < 2,
            "unmirrored_mean_footprint_leg_lengths":
            self.unmirrored_mean_footprint_leg_lengths is None
            or 0 < self.unmirrored_mean_footprint_leg_lengths < 2,
            "normal_force_rate_weights_per_t0": self.normal_force_rate_weights_per_t0 is None
            or (math.isfinite(self.normal_force_rate_weights_per_t0)
                and 0 < self.normal_force_rate_weights_per_t0 < 1e3),
            "rotor_reserve": self.rotor_reserve is None
            or (math.isfinite(self.rotor_reserve) and 0 <= self.rotor_reserve <= 2),
            "line_capture_margin_leg_lengths": self.line_capture_margin_leg_lengths is None
            or (math.isfinite(self.line_capture_margin_leg_lengths)
                and 0 <= self.line_capture_margin_leg_lengths < 1),
            "sideways_slip_leg_lengths": 0 <= self.sideways_slip_leg_lengths <= 0.01,
            "separation_unit_leg_lengths": self.separation_unit_leg_lengths is None
            or (math.isfinite(self.separation_unit_leg_lengths)
                and 1e-3 <= self.separation_unit_leg_lengths <= 10),
            "tol": 0 < self.tol < 1,
            "max_iter": self.max_iter is None or 0 < self.max_iter <= MAX_ITERATION_CAP,
            "derivatives": self.derivatives in DERIVATIVE_PATHS,
            "ipopt_tuning": self.ipopt_tuning in IPOPT_TUNINGS,
            "knot_threads": type(self.knot_threads) is int
            and 1 <= self.knot_threads <= MAX_KNOT_THREADS,
            "nlp_jacobian": self.nlp_jacobian in NLP_JACOBIANS,
            "nlp_hessian": self.nlp_hessian in NLP_HESSIANS,
            "ipopt_extra": _ipopt_extra_ok(self.ipopt_extra),
            "hessian_shift_acc": math.isfinite(self.hessian_shift_acc)
            and 0 <= self.hessian_shift_acc < 1,
            "compact_rows": isinstance(self.compact_rows, tuple)
            and all(r in COMPACT_ROWS for r in self.compact_rows)
            and len(set(self.compact_rows)) == len(self.compact_rows),
        }
        for name, choices in (("cold_start", COLD_STARTS), ("swing_wrench", SWING_WRENCHES),
                              ("inactive_rows", INACTIVE_ROWS),
                              ("cold_mu_centrality", COLD_MU_CENTRALITIES),
                              ("stance_clearance", STANCE_CLEARANCES),
                              ("warm_retime", WARM_RETIMES),
                              ("warm_swing_wrench", WARM_SWING_WRENCHES),
                              ("servo_goal_form", SERVO_GOAL_FORMS)):
            value = getattr(self, name)
            if value not in choices:
                raise PlannerConfigError(
                    f"planner option {name}={value!r}: use one of {', '.join(choices)}")
        for name, ok in checks.items():
            if not ok:
                hint = (f" (a tuple of distinct names from {', '.join(COMPACT_ROWS)})"
                        if name == "compact_rows" else
                        " (a tuple of distinct (IPOPT option, number or string) pairs, none of "
                        f"{', '.join(IPOPT_EXTRA_RESERVED)} or tol)"
                        if name == "ipopt_extra" else "")
                raise PlannerConfigError(
                    f"planner option {name}={getattr(self, name)!r} is out of range{hint}"
                )

    @property
    def lifted_goals(self) -> bool:
        """Is the servo goal a variable of its own (`servo_goal_form` "lifted" with
        `servo_goals` on)?"""
        return self.servo_goal_form == "lifted" and self.servo_goals

    def max_iter_for(self, n_variables: int) -> int:
        """IPOPT's iteration cap for an NLP of `n_variables`: the option, or `iteration_cap`."""
        return self.max_iter if self.max_iter is not None else iteration_cap(n_variables)

    def swing_clearance_for(self, leg_length_m: float) -> float:
        """Swing clearance [m] for legs of `leg_length_m` (the option, or the scaling law)."""
        if self.swing_clearance_m is not None:
            return self.swing_clearance_m
        return SWING_CLEARANCE_LEG_LENGTHS * leg_length_m

    def separation_unit_m(self, leg_length_m: float) -> float:
        """The length the foot-separation rows are counted in [m]: 1 (metres) or
        `separation_unit_leg_lengths` leg lengths."""
        if self.separation_unit_leg_lengths is None:
            return 1.0
        return self.separation_unit_leg_lengths * leg_length_m

    def body_clearance_for(self, leg_length_m: float) -> float:
        """Body clearance [m] for legs of `leg_length_m` (the option, or the scaling law)."""
        if self.body_clearance_m is not None:
            return self.body_clearance_m
        return BODY_CLEARANCE_LEG_LENGTHS * leg_length_m

    def joint_limit_margins_rad(self, lower_rad: np.ndarray, upper_rad: np.ndarray) -> np.ndarray:
        """Per joint: max(margin_rad, fraction × range), capped at a quarter of the range."""
        span = np.asarray(upper_rad, dtype=float) - np.asarray(lower_rad, dtype=float)
        margin = np.maximum(self.joint_limit_margin_rad, self.joint_limit_margin_fraction * span)
        return np.minimum(margin, 0.25 * span)


def _ipopt_extra_ok(extra: object) -> bool:
    """`PlannerOptions.ipopt_extra` is a tuple of distinct (name, number or string) pairs that
    set none of `IPOPT_EXTRA_RESERVED` nor ``tol`` (the field `PlannerOptions.tol`)."""
    if not isinstance(extra, tuple):
        return False
    names: list[str] = []
    for item in extra:
        if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)
                and isinstance(item[1], (int, float, str)) and not isinstance(item[1], bool)):
            return False
        if isinstance(item[1], float) and not math.isfinite(item[1]):
            return False
        names.append(item[0].removeprefix(WARM_ONLY_PREFIX))
    return (len(set(names)) == len(names)
            and not set(names) & {*IPOPT_EXTRA_RESERVED, "tol"})

"""Which gait template `gaitsmith plan` uses for a robot, and whether `--gait` fits it.

Kept apart from the command so the planner's gait schedules (templates for any leg count) can
replace these functions without touching the command line.

Commanded gaits (`--vy`, `--yaw-rate`; issue #15) get their own choice, `commanded_gait`: a
trot, the quadruped default, balances on its support diagonal, and in MuJoCo that failed every
turn and side-step on quad12 (2026-12-01, N = 20, `--simulate`). On the side-step
(`--vx 0 --vy 0.08`) the body rolled 2-5° towards the right side for the whole cycle (planned
±0.3°), the right feet lifted 0-6 mm instead of 25 mm, one hind foot stayed down 95 % of the
cycle instead of 60 % and the robot achieved vy 0.034 m/s. A duty-0.75 walk did the same
(vy 0.027 m/s): while a right foot swung, the planned centre of mass was 28-43 mm *outside*
the support triangle, balanced only dynamically, with the centre of pressure 0.3-2.5 mm from
the triangle's edge. Open-loop position servos cannot catch a body tipping about a support edge
(`planner.search.support`: the error grows like cosh(t/τ)), so the commanded choice asks the
planner for a static walk instead of a quadruped-specific constant:

- the template: the robot's default unless that one stands on a support line for longer than
  `LINE_RUN_TAU_FRACTION`·τ at a time (`planner.search.support.line_support_durations_s`, τ the
  inverted-pendulum time √(h/g)): a tipping error grows by cosh(T/τ), 13 % over τ/2. The quad12,
  spotmicro and bittle8 trots stand on a diagonal for 1.35 τ (×2.1); star5's ripple for
  0.14 τ at a time, and it turns in place in MuJoCo (0.604 of 0.6 rad/s, PASS) — the static wave
  the choice would give it is infeasible (torque envelope). Then the first offered template
  that stands on a polygon at every phase with duty `STATIC_DUTY` (a quadruped's walk);
- duty `STATIC_DUTY` = 0.85: four one-leg swings take 0.6 of the cycle, and the 0.1-cycle
  all-feet phases between them let the centre of mass cross from one support triangle into
  the next (at duty 0.75 it would have to jump across the diagonal at one instant);
- the period that keeps the template's swing time, T·(1 − β_template)/(1 − `STATIC_DUTY`)
  (a quadruped walk: 5·√(L/g)·0.25/0.15 ≈ 8.3·√(L/g), 1.12 s on quad12). At the template's
  period a duty-0.85 swing lasts 0.1 s on quad12: lifting the foot 25 mm in half of that is
  about 1 g, and at N = 30 the side-step and the arc (`--vx 0.1 --yaw-rate 0.5`) were
  infeasible (torque envelope at its limit in 22-28 rows after 150 iterations);
- `PlannerOptions.static_margin_leg_lengths` = `STATIC_MARGIN_LEG_LENGTHS`: the centre of mass
  stays 0.05 L inside the stance polygon at every knot (9 mm on quad12; 0.08 L left quad12 82 %
  of stall torque on the turn in place);
- `PlannerOptions.mean_footprint_leg_lengths` = `MEAN_FOOTPRINT_LEG_LENGTHS`: the cycle mean of
  each foot within ±0.05 L of its nominal stance position in the base frame. Without it the
  plans sheared or turned the footprint about the body (up to 30°, feet 110 mm from nominal)
  — the entry ramp to such a gait's mean pose twisted the standing robot by 36° before its
  first step.

Robots whose default does not stand on a line for long (hex18's tripod, star5's ripple) keep
their default gait and options: their commanded gaits passed before.

Stepping in place (a zero command with a schedule that lifts a foot) plans with
`planner.nlp.command.in_place_options` (`in_place_choice`), for every robot and gait: the
footprint anchored at the stance (shifted under the centre of mass unless the schedule
`tips_on_a_line`) and half the walking swing clearance (measurements in that module).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import robots
from planner.errors import TemplateError
from planner.nlp.command import in_place_options
from planner.nlp.config import GRAVITY_M_S2, PlannerOptions
from planner.templates import (
    GENERIC_TEMPLATES,
    TEMPLATES,
    default_gait_for,
    hip_and_knee_quadruped,
    make_schedule,
    stance_foot_positions_m,
    templates_for,
)
from robots.schedule import ContactSchedule

STATIC_DUTY = 0.85
LINE_RUN_TAU_FRACTION = 0.5
STATIC_MARGIN_LEG_LENGTHS = 0.05
MEAN_FOOTPRINT_LEG_LENGTHS = 0.05


def default_gait(bot: robots.Robot, standing: bool = False) -> str:
    """The template `plan` uses without `--gait`: `stand` (all feet down) when `standing` (a
    zero command with no stepping schedule), else `planner.templates.default_gait_for` — walk
    on two legs, trot on four (walk on hip-and-knee legs), tripod on six, else ripple (wave for
    three legs)."""
    return "stand" if standing else default_gait_for(bot)


def default_speed_note(bot: robots.Robot, speed_m_s: float) -> str:
    """The line `plan` prints when it picks the speed from the body (Froude number
    Fr = v²/(g·L), `planner.nlp.config.default_speed_m_s`)."""
    leg_m = bot.leg_length_m
    froude = speed_m_s**2 / (GRAVITY_M_S2 * leg_m)
    return (f"speed {speed_m_s:.2f} m/s = Froude {froude:.3f} for L = {leg_m * 100:.0f} cm; "
            "--speed to override")


def check_gait_fits(bot: robots.Robot, gait: str) -> None:
    """`--gait` must be a template offered for this robot; the error lists those that are."""
    fitting = templates_for(bot)
    if gait not in fitting:
        known = gait in TEMPLATES or gait in GENERIC_TEMPLATES
        what = "unknown gait" if not known else (
            f"gait for {TEMPLATES[gait].n_legs} legs" if gait in TEMPLATES else "not offered")
        raise TemplateError(
            f"--gait {gait}: {what}; {bot.name} has {len(bot.legs)} legs, gaits that fit: "
            + ", ".join(fitting))


@dataclass(frozen=True)
class GaitChoice:
    """The template, its duty factor (None: the template's) and planner options to plan with."""

    gait: str
    duty_factor: float | None
    options: PlannerOptions
    reason: str
    period_s: float | None = None  # None: the template's


def always_on_polygon(bot: robots.Robot, gait: str, duty_factor: float | None = None) -> bool:
    """Does `gait` stand on a support polygon (≥ 3 non-collinear feet) at every phase?"""
    from planner.search.support import support_phases

    if len(bot.legs) < 3:  # two feet span a line at best (point feet; soles aside)
        return False
    schedule = make_schedule(bot, gait, duty_factor=duty_factor)
    feet = stance_foot_positions_m(bot)[:, :2]
    return all(p.kind == "polygon" for p in support_phases(schedule, feet))


def tips_on_a_line(bot: robots.Robot, gait: str) -> bool:
    """Does `gait` stand on a support line for longer than `LINE_RUN_TAU_FRACTION`·τ at a time?"""
    return schedule_tips_on_a_line(bot, make_schedule(bot, gait))


def commanded_gait(bot: robots.Robot, gait: str | None, vy_m_s: float, yaw_rate_rad_s: float,
                   options: PlannerOptions) -> GaitChoice:
    """The gait `plan` uses for a command (see the module docstring for the measurements).

    Straight commands and an explicit `--gait` keep `options` and the template's duty; a turn
    or side-step without `--gait` on a robot whose default stands on a support line for long
    (`tips_on_a_line`) plans a static walk.
    """
    chosen = gait or default_gait(bot)
    if gait is not None or (vy_m_s == 0.0 and yaw_rate_rad_s == 0.0):
        return GaitChoice(chosen, None, options, "as asked" if gait else "default")
    tips = tips_on_a_line(bot, chosen)
    # a hip-and-knee quadruped's default walk does not tip, but its legs cannot step sideways:
    # it turns and side-steps with the static walk as it did when its default was the trot
    if not tips and not hip_and_knee_quadruped(bot):
        return GaitChoice(chosen, None, options, "default (no long support-line phase)")
    static = next((name for name in templates_for(bot)
                   if always_on_polygon(bot, name, STATIC_DUTY)), None)
    if static is None:  # bipeds, and robots whose feet never span a polygon
        return GaitChoice(chosen, None, options, "default (no template stands on a polygon)")
    template = make_schedule(bot, static)
    swing_s = template.period_s * (1.0 - float(template.duty_factor[0]))
    return GaitChoice(
        static, STATIC_DUTY,
        replace(options, static_margin_leg_lengths=STATIC_MARGIN_LEG_LENGTHS,
                mean_footprint_leg_lengths=MEAN_FOOTPRINT_LEG_LENGTHS),
        f"static {static} (duty {STATIC_DUTY:g}, the template's swing time): "
        + (f"{chosen} stands on a support line, which open-loop servos cannot balance"
           if tips else "legs without hip roll cannot step sideways")
        + " while turning or side-stepping",
        swing_s / (1.0 - STATIC_DUTY),
    )


def steps(schedule: ContactSchedule) -> bool:
    """Does some foot lift during the cycle (duty factor < 1)? The `stand` does not."""
    return any(float(d) < 1.0 - 1e-9 for d in schedule.duty_factor)


def in_place_choice(bot: robots.Robot, schedule: ContactSchedule, vx_m_s: float, vy_m_s: float,
                    yaw_rate_rad_s: float, options: PlannerOptions) -> PlannerOptions | None:
    """The options for stepping in place (`planner.nlp.command.in_place_options`) when the
    command is zero and `schedule` steps; None otherwise (a stand, or a moving command)."""
    if (vx_m_s, vy_m_s, yaw_rate_rad_s) != (0.0, 0.0, 0.0) or not steps(schedule):
        return None
    return in_place_options(options, bot,
                            centre_under_com=not schedule_tips_on_a_line(bot, schedule))


def schedule_tips_on_a_line(bot: robots.Robot, schedule: ContactSchedule) -> bool:
    """`tips_on_a_line` for any schedule (a template's, `--duty`, `--phases`, `--schedule`)."""
    from planner.search.support import line_support_durations_s, tipping_time_constant_s

    if len(bot.legs) < 3:
        return True
    tau = tipping_time_constant_s(float(bot.stance_base_height_m))
    runs = line_support_durations_s(schedule, stance_foot_positions_m(bot))
    return any(run > LINE_RUN_TAU_FRACTION * tau for run in runs)


def grid_gait(bot: robots.Robot, family: str | None, vy_values: tuple[float, ...],
              yaw_values: tuple[float, ...], options: PlannerOptions) -> GaitChoice:
    """The gait a library grid uses for ALL its entries (they blend at equal phase, so they
    share one schedule): `commanded_gait`'s choice for the grid's turns and side-steps. A grid
    with any command vy ≠ 0 or yaw rate ≠ 0 on a robot whose default stands on a support line
    (`tips_on_a_line`) plans every entry, the straight ones too, as the static walk; a
    straight-only grid, or an explicit `family`, keeps the default/asked family and `options`.
    The choice depends only on whether the grid turns or side-steps, not on how much."""
    turning = [(vy, w) for vy in vy_values for w in yaw_values if vy != 0.0 or w != 0.0]
    if not turning:
        return commanded_gait(bot, family, 0.0, 0.0, options)
    vy, w = max(turning, key=lambda c: (abs(c[1]), abs(c[0])))
    return commanded_gait(bot, family, vy, w, options)


def _leg_counts() -> list[int]:
    return sorted({t.n_legs for t in TEMPLATES.values()})

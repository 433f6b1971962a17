"""Which gait template `gaitsmith plan` uses for a robot, and whether `--gait` fits it.

Kept apart from the command so the planner's gait schedules (templates for any leg count) can
replace these two functions without touching the command line.
"""

from __future__ import annotations

import robots
from planner.errors import TemplateError
from planner.nlp.config import GRAVITY_M_S2
from planner.templates import GENERIC_TEMPLATES, TEMPLATES, default_gait_for, templates_for


def default_gait(bot: robots.Robot, standing: bool = False) -> str:
    """The template `plan` uses without `--gait`: `stand` (all feet down) when `standing` (a
    zero command with no stepping schedule), else `planner.templates.default_gait_for` — walk
    on two legs, trot on four, tripod on six, else ripple (wave for three legs)."""
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


def _leg_counts() -> list[int]:
    return sorted({t.n_legs for t in TEMPLATES.values()})

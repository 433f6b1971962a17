"""Which gait template `gaitsmith plan` uses for a robot, and whether `--gait` fits it.

Kept apart from the command so the planner's gait schedules (templates for any leg count) can
replace these two functions without touching the command line.
"""

from __future__ import annotations

import robots
from planner.errors import TemplateError
from planner.templates import TEMPLATES, templates_for


def default_gait(bot: robots.Robot) -> str:
    """The template `plan` uses without `--gait`: among the robot's templates (by leg count),
    the one with the smallest duty factor that still has no flight phase (duty ≥ ½), i.e. the
    quickest walking-pace gait — trot on four legs, tripod on six, biped_walk on two."""
    fitting = [TEMPLATES[name] for name in templates_for(bot)]
    if not fitting:
        raise TemplateError(
            f"{bot.name}: no gait template for {len(bot.legs)} legs "
            f"(templates exist for {', '.join(str(n) for n in _leg_counts())} legs)")
    grounded = [t for t in fitting if t.duty_factor >= 0.5] or fitting
    return min(grounded, key=lambda t: t.duty_factor).name  # min keeps the first of equals


def check_gait_fits(bot: robots.Robot, gait: str) -> None:
    """`--gait` must be a template for this robot's leg count; the error lists those that are."""
    fitting = templates_for(bot)
    if gait not in fitting:
        known = "unknown gait" if gait not in TEMPLATES else (
            f"gait for {TEMPLATES[gait].n_legs} legs")
        raise TemplateError(
            f"--gait {gait}: {known}; {bot.name} has {len(bot.legs)} legs, gaits that fit: "
            + (", ".join(fitting) or "none"))


def _leg_counts() -> list[int]:
    return sorted({t.n_legs for t in TEMPLATES.values()})

"""Which gait template `gaitsmith plan` uses for a robot, and whether `--gait` fits it.

Kept apart from the command so the planner's gait schedules (templates for any leg count) can
replace these two functions without touching the command line.
"""

from __future__ import annotations

import robots
from planner.errors import TemplateError
from planner.templates import GENERIC_TEMPLATES, TEMPLATES, default_gait_for, templates_for


def default_gait(bot: robots.Robot) -> str:
    """The template `plan` uses without `--gait`: `planner.templates.default_gait_for` — walk
    on two legs, trot on four, tripod on six, else ripple (wave for three legs)."""
    return default_gait_for(bot)


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

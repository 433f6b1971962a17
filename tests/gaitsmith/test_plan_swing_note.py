"""`plan` says when the servos cannot swing the template's stride in time (planner.swing_slack)."""

from __future__ import annotations

import robots
from gaitsmith.console import console
from gaitsmith.plan_cmd import _note_swing_slack
from planner.nlp.config import PlannerOptions
from planner.templates import make_schedule


def _note(name: str, gait: str, speed: float, **timing: float) -> str:
    bot = robots.load(name)
    with console.capture() as out:
        _note_swing_slack(bot, make_schedule(bot, gait, **timing), speed, PlannerOptions())
    return out.get()


def test_knee8_default_walk_gets_the_note() -> None:
    text = _note("tests/zoo/knee8", "walk", 0.182)
    assert "swing slack 0.61 < 1 on fl_hip" in text and "--duty" in text


def test_no_note_when_the_swing_fits() -> None:
    assert _note("quad12", "trot", 0.25) == ""
    assert _note("tests/zoo/knee8", "walk", 0.182, period_s=1.3, duty_factor=0.6) == ""
    assert _note("tests/zoo/knee8", "walk", 0.0) == ""  # stepping in place: no stride

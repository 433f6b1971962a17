"""`plan` with no timing flags uses the servo-limited timing (planner.servo_limited) on a robot
whose template swing is faster than its servos, and nowhere else; the user's flags win."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import planner.search.gait_search
from gaitsmith import plan_cmd
from gaitsmith.console import console
from planner.servo_limited import (
    SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS,
    SERVO_LIMITED_MAX_TILT_RAD,
    SERVO_LIMITED_ROTOR_RESERVE,
)
from tests.gaitsmith.capture import captured_kwargs


def _plan(monkeypatch: pytest.MonkeyPatch, owner: object, name: str,
          argv: list[str]) -> tuple[dict[str, Any], str]:
    with console.capture() as out:
        seen = captured_kwargs(monkeypatch, owner, name, ["plan", *argv])
    return seen, out.get()


def test_knee8_default_plans_the_servo_limited_walk(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    seen, text = _plan(monkeypatch, plan_cmd, "GaitPlanner",
                       ["tests/zoo/knee8", "--speed", "0.182", "-o", str(tmp_path / "g.json")])
    assert "servo-limited timing" in text
    assert "period 1.373 s, duty 0.60" in text and "swing slack" not in text.split("planning")[1]
    assert seen["options"].rotor_reserve == SERVO_LIMITED_ROTOR_RESERVE
    assert seen["options"].line_capture_margin_leg_lengths == SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS
    assert seen["options"].max_tilt_rad == SERVO_LIMITED_MAX_TILT_RAD


@pytest.mark.parametrize("flags", [["--period", "1.3"], ["--duty", "0.6"], ["--gait", "walk"],
                                   ["--phases", "0,0.5,0.75,0.25"]])
def test_the_users_timing_wins(flags: list[str], tmp_path: Path,
                               monkeypatch: pytest.MonkeyPatch) -> None:
    seen, text = _plan(monkeypatch, plan_cmd, "GaitPlanner",
                       ["tests/zoo/knee8", "--speed", "0.182", *flags,
                        "-o", str(tmp_path / "g.json")])
    assert "servo-limited timing" not in text
    assert seen["options"].rotor_reserve is None
    assert seen["options"].line_capture_margin_leg_lengths is None
    assert seen["options"].max_tilt_rad == 0.35


def test_the_users_reserve_and_margin_win(tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    seen, text = _plan(monkeypatch, plan_cmd, "GaitPlanner",
                       ["tests/zoo/knee8", "--speed", "0.182", "--rotor-reserve", "0.1",
                        "--line-capture-margin", "0.13", "-o", str(tmp_path / "g.json")])
    assert "period 1.373 s" in text
    assert seen["options"].rotor_reserve == 0.1
    assert seen["options"].line_capture_margin_leg_lengths == 0.13


def test_robots_whose_servos_make_the_swing_are_untouched(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    seen, text = _plan(monkeypatch, plan_cmd, "GaitPlanner",
                       ["quad12", "--speed", "0.25", "-o", str(tmp_path / "g.json")])
    assert "servo-limited timing" not in text and "period 0.469 s" in text
    assert seen["options"].rotor_reserve is None


def test_the_search_starts_from_the_servo_limited_walk(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    seen, _ = _plan(monkeypatch, planner.search.gait_search, "search_gait",
                    ["tests/zoo/knee8", "--speed", "0.182", "--search",
                     "-o", str(tmp_path / "g.json")])
    (schedule,) = seen["seed_schedules"].values()
    assert schedule.period_s == pytest.approx(1.373, abs=1e-3)
    assert schedule.duty_factor == (0.6,) * 4
    assert seen["options"].rotor_reserve == SERVO_LIMITED_ROTOR_RESERVE
    assert seen["options"].line_capture_margin_leg_lengths == SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS
    seen, _ = _plan(monkeypatch, planner.search.gait_search, "search_gait",
                    ["quad12", "--speed", "0.2", "--search", "-o", str(tmp_path / "g.json")])
    assert seen["seed_schedules"] is None and seen["options"].rotor_reserve is None

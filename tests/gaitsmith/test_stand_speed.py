"""`gaitsmith plan` speeds from the body: no `--speed` plans at the Froude default for the
robot's leg length (and says so); `--speed 0` plans the `stand` template unless a stepping
schedule (`--gait`, `--duty`, `--phases`) is asked for. The NLP is replaced by a stand-in that
records what it was asked to solve (no IPOPT here)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

import robots
from gaitsmith import plan_cmd
from gaitsmith.cli import main
from planner.nlp.config import DEFAULT_FROUDE, GRAVITY_M_S2, default_speed_m_s
from robots.schedule import ContactSchedule
from tests.zoo.fixtures import ZOO


class Solved(Exception):
    """Raised by the stand-in planner's solve, carrying what it was asked."""

    def __init__(self, schedule: ContactSchedule, speed_m_s: float) -> None:
        super().__init__()
        self.schedule, self.speed_m_s = schedule, speed_m_s


class RecordingPlanner:
    build_time_s = 0.0

    def __init__(self, robot: robots.Robot, **kwargs: Any) -> None:
        self.robot = robot

        class Layout:
            size = 0

        self.layout = Layout()

    def solve(self, schedule: ContactSchedule, speed_m_s: float, **kwargs: Any) -> Any:
        raise Solved(schedule, speed_m_s)


@pytest.fixture(autouse=True)
def recording_planner(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(plan_cmd, "GaitPlanner", RecordingPlanner)


def _plan(robot: str, tmp_path: Path, *extra: str) -> Solved:
    with pytest.raises(Solved) as info:
        main(["plan", robot, "-o", str(tmp_path / "g.json"), *extra])
    return info.value


@pytest.mark.parametrize("robot", ["quad12", "hex18", str(ZOO / "star5"), str(ZOO / "bittle8")])
def test_no_speed_plans_at_the_froude_default_for_the_leg_length(
    robot: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    leg_m = robots.load(robot).leg_length_m
    asked = _plan(robot, tmp_path)
    expected = default_speed_m_s(leg_m)
    assert asked.speed_m_s == pytest.approx(expected)
    assert asked.speed_m_s == pytest.approx(math.sqrt(DEFAULT_FROUDE * GRAVITY_M_S2 * leg_m))
    out = " ".join(capsys.readouterr().out.split())
    assert (f"speed {expected:.2f} m/s = Froude {DEFAULT_FROUDE:.3f} for L = "
            f"{leg_m * 100:.0f} cm; --speed to override") in out


def test_a_given_speed_is_planned_as_given_without_the_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _plan("quad12", tmp_path, "--speed", "0.1").speed_m_s == 0.1
    assert "Froude" not in capsys.readouterr().out


@pytest.mark.parametrize("robot", ["quad12", "hex18", str(ZOO / "star5")])
def test_speed_zero_without_a_stepping_schedule_plans_the_stand(robot: str,
                                                                tmp_path: Path) -> None:
    asked = _plan(robot, tmp_path, "--speed", "0")
    assert asked.speed_m_s == 0.0
    assert set(asked.schedule.duty_factor) == {1.0}  # every foot down all cycle


@pytest.mark.parametrize(
    ("robot", "extra", "duty"),
    [
        ("quad12", ["--gait", "trot"], 0.6),
        ("hex18", ["--gait", "tripod"], 0.6),
        ("hex18", ["--duty", "0.8"], 0.8),  # the default gait (tripod) at that duty
        (str(ZOO / "star5"), ["--phases", "0,0.2,0.4,0.6,0.8", "--duty", "0.8"], 0.8),
    ],
)
def test_speed_zero_with_a_stepping_schedule_steps_in_place(
    robot: str, extra: list[str], duty: float, tmp_path: Path
) -> None:
    asked = _plan(robot, tmp_path, "--speed", "0", *extra)
    assert asked.speed_m_s == 0.0
    assert set(asked.schedule.duty_factor) == {duty}


def test_a_stand_at_a_nonzero_speed_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.undo()  # the real planner refuses it before building anything costly
    code = main(["plan", "quad12", "--gait", "stand", "--speed", "0.1", "--knots", "8",
                 "-o", str(tmp_path / "g.json")])
    assert code != 0
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and "never lifts off" in err[0] and "speed 0" in err[0], err
    assert not (tmp_path / "g.json").exists()


def test_sweep_without_speeds_sweeps_fixed_froude_numbers_for_the_body(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gaitsmith import sweep_cmd
    from planner.nlp.config import default_speeds_m_s

    asked: list[list[float]] = []

    def record(bot: robots.Robot, speeds: list[float], **kwargs: Any) -> Any:
        asked.append(list(speeds))
        raise Solved(ContactSchedule(1.0, ("a",), (0.0,), (1.0,)), speeds[0])

    monkeypatch.setattr(sweep_cmd, "sweep_speeds", record)
    star5 = str(ZOO / "star5")
    with pytest.raises(Solved):
        main(["sweep", star5, "-o", str(tmp_path / "sweep"), "--no-sim-accept"])
    leg_m = robots.load(star5).leg_length_m
    assert asked == [default_speeds_m_s(leg_m)]
    assert asked[0] != [0.05, 0.1, 0.2, 0.3] and asked[0][-1] < 0.21  # 0.30 m/s at 18 cm

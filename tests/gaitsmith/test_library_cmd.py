"""`gaitsmith library`: bad options fail at once (one line, exit 2) before any solve."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from gaitsmith import library_cmd
from gaitsmith.cli import main


class ExpensiveWorkStarted(Exception):
    pass


def _too_late(*args: Any, **kwargs: Any) -> Any:
    raise ExpensiveWorkStarted


@pytest.fixture(autouse=True)
def no_solve(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(library_cmd, "build_library", _too_late)


MISTAKES = [
    (["--vx", "0.1,x"], "--vx must be a comma-separated list of numbers, got '0.1,x'"),
    (["--vx", "0.1,0.1"], "--vx: repeats a value"),
    (["--vx", "0,20"], "--vx must be a number in [-10, 10] m/s, got 20"),
    (["--vy", "nan"], "--vy: nan is not a finite number"),
    (["--yaw-rate", "0,50"], "--yaw-rate must be a number in"),
    (["--yaw-rate", "0," + ",".join(str(i / 100) for i in range(1, 16))], "--yaw-rate: at most"),
    (["--knots", "3"], "--knots must be an integer in [8, 200], got 3"),
    (["--cycles", "1"], "--cycles must be an integer in"),
    (["--workers", "0"], "--workers must be an integer in [1, 1024], got 0"),
    (["--address", "ray://x:1"], "--address is for Ray: add --ray"),
    (["--family", "gallopp"], "--family gallopp: unknown gait"),
    (["--family", "tripod"], "--family tripod: gait for 6 legs"),
    (["--yaw-rate", "3.5", "--family", "walk"], "--vx/--vy/--yaw-rate: grid command vy 0, yaw rate "
     "3.5: yaw rate 3.5 rad/s turns more than a quarter turn per period"),
]


@pytest.mark.parametrize(("args", "message"), MISTAKES, ids=[m[1][:30] for m in MISTAKES])
def test_bad_options_fail_before_any_solve(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    code = main(["library", "quad12", "-o", str(tmp_path / "lib.json"), *args])
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("error: ") and message in err[0], err[0]
    assert not (tmp_path / "lib.json").exists()


def test_unwritable_output(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code = main(["library", "quad12", "-o", str(blocker / "lib.json")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("error: --output ") and "is a file" in err, err


def test_unknown_robot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["library", "nosuchbot", "-o", str(tmp_path / "lib.json")]) == 2
    assert "nosuchbot" in capsys.readouterr().err


class BuildAsked(Exception):
    """The command reached build_library; the recorded call is what it asked for."""


def _ask(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, robot: str,
         *args: str) -> dict[str, Any]:
    asked: dict[str, Any] = {}

    def record(bot: Any, grid: Any, **kwargs: Any) -> Any:
        asked.update(kwargs, grid=grid)
        raise BuildAsked

    monkeypatch.setattr(library_cmd, "build_library", record)
    with pytest.raises(BuildAsked):
        main(["library", robot, "-o", str(tmp_path / "lib.json"), *args])
    return asked


def test_a_turning_trotter_grid_plans_every_entry_as_the_static_walk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    asked = _ask(tmp_path, monkeypatch, "quad12", "--vx", "0,0.1", "--yaw-rate", "-0.4,0,0.4",
                 "--family", "auto")
    assert asked["family"] == "walk" and asked["duty_factor"] == 0.85
    assert asked["period_s"] > 1.0  # the trot's swing time at duty 0.85
    assert asked["options"].static_margin_leg_lengths == 0.05
    assert asked["options"].mean_footprint_leg_lengths == 0.05
    assert "static walk" in asked["family_reason"]
    assert asked["grid"].vx_m_s == (0.0, 0.1)  # the straight entries too: one family
    out = capsys.readouterr().out
    assert "family for every entry: walk (duty 0.85" in out and "support line" in out


def test_the_default_grid_of_a_trotter_turns_within_the_static_walks_period(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from tests.zoo.fixtures import ZOO

    asked = _ask(tmp_path, monkeypatch, str(ZOO / "spotmicro"), "--family", "auto")  # not built in
    grid, period = asked["grid"], asked["period_s"]
    assert asked["family"] == "walk" and asked["duty_factor"] == 0.85
    w = max(grid.yaw_rate_rad_s)
    assert w > 0.0 and w * period <= 0.25 * math.pi / 2 + 1e-3  # a quarter of the planner's cap


@pytest.mark.parametrize(("robot", "args", "family"), [
    ("quad12", ["--yaw-rate", "0", "--family", "auto"], "trot"),  # straight-only grid
    ("quad12", ["--vy", "0", "--family", "auto"], None),  # vy 0 alone still turns (yaw axis)
    ("quad12", [], "trot"),  # without auto: the default family, turning grid or not
    ("quad12", ["--family", "trot"], "trot"),  # --family overrides the choice
    ("hex18", [], "tripod"),  # a tripod never stands on a line: keeps its default
])
def test_straight_grids_and_family_keep_the_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, robot: str, args: list[str],
    family: str | None
) -> None:
    asked = _ask(tmp_path, monkeypatch, robot, *args)
    if family is None:
        assert asked["family"] == "walk"
        return
    assert asked["family"] == family and asked["duty_factor"] is None
    assert asked["period_s"] is None and asked["options"].static_margin_leg_lengths is None


def test_the_validator_judges_each_gait_as_it_will_be_played() -> None:
    """Issue #14: the library's entries (and its stand) on a biped with an [imu] are validated
    closed loop at the rule's gain, recorded in the verdict's conditions as `plan --simulate`
    records it (the player's pre-flight reads it); `--attitude-gain 0` validates open loop; a
    quadruped stays open loop. The factory pickles with its gain (process pool, Ray)."""
    import pickle

    import robots
    from robots.attitude import ATTITUDE_GAIN_KEY, TWO_LEG_IMU_GAIN, validated_attitude_gain
    from sim.synthetic import standing_gait

    biped, quad = robots.load("biped"), robots.load("quad12")
    by_rule = library_cmd.SimValidator(str(biped.root_dir), 3)
    assert pickle.loads(pickle.dumps(by_rule)) == by_rule
    v = by_rule()(standing_gait(biped))
    assert v["conditions"][ATTITUDE_GAIN_KEY] == TWO_LEG_IMU_GAIN
    assert validated_attitude_gain(v) == TWO_LEG_IMU_GAIN
    opened = pickle.loads(pickle.dumps(library_cmd.SimValidator(str(biped.root_dir), 3, 0.0)))
    assert ATTITUDE_GAIN_KEY not in opened()(standing_gait(biped))["conditions"]
    v_quad = library_cmd.SimValidator(str(quad.root_dir), 3)()(standing_gait(quad))
    assert ATTITUDE_GAIN_KEY not in v_quad["conditions"]

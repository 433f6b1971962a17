"""`gaitsmith plan --vx/--vy/--yaw-rate`: bad values fail at once with one line naming the option
(exit 2, before the NLP build); good ones reach the planner with the command."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from gaitsmith import plan_cmd
from gaitsmith.cli import main


class BuildStarted(Exception):
    """Raised by the stand-in of the NLP build."""


@pytest.fixture(autouse=True)
def no_nlp_build(monkeypatch: pytest.MonkeyPatch) -> None:
    def too_late(*args: Any, **kwargs: Any) -> Any:
        raise BuildStarted

    monkeypatch.setattr(plan_cmd, "GaitPlanner", too_late)


MISTAKES = [
    (["--vx", "nan"], "--vx/--speed must be a number in [-10, 10] m/s, got nan"),
    (["--vx", "-10.5"], "--vx/--speed must be a number in [-10, 10] m/s"),
    (["--vy", "inf"], "--vy must be a number in [-10, 10] m/s, got inf"),
    (["--vy", "-12"], "--vy must be a number in [-10, 10] m/s"),
    (["--yaw-rate", "nan"], "--yaw-rate must be a number"),
    # quad12's legs are 0.176 m: 0.5·√(9.81/0.176) = 3.73 rad/s
    (["--yaw-rate", "4"], "--yaw-rate must be a number in [-3.7309, 3.7309] rad/s (0.5·√(g/L)"),
    (["--yaw-rate", "-4"], "quad12's 0.176 m legs"),
    (["--search", "--yaw-rate", "0.3"], "--search plans forward gaits only"),
    (["--search", "--vy", "0.05"], "--search plans forward gaits only"),
    (["--search", "--vx", "-0.1"], "--vx/--speed must be a number in (0, 10] m/s"),
]


@pytest.mark.parametrize(("extra", "expected"), MISTAKES)
def test_bad_commands_fail_in_one_line_before_the_build(
    extra: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "-o", str(out), *extra]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("error: "), err
    assert expected in err[0]
    assert not out.exists()


@pytest.mark.parametrize(
    "extra",
    [
        ["--vx", "-0.1"],  # backwards
        ["--vx", "0", "--vy", "0.08"],  # side-step
        ["--vx", "0", "--yaw-rate", "-0.6"],  # turn in place, to the right
        ["--speed", "0.1", "--yaw-rate", "3.7"],  # --speed is --vx; just inside the bound
    ],
)
def test_good_commands_reach_the_planner(extra: list[str], tmp_path: Path) -> None:
    with pytest.raises(BuildStarted):
        main(["plan", "quad12", "--knots", "12", "-o", str(tmp_path / "g.json"), *extra])

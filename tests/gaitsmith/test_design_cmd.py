"""`gaitsmith design`: bad options fail at once — one line naming the option, exit 2 — before
any NLP is built, and leave nothing behind."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import gaitsmith.design_cmd
from gaitsmith.cli import main


class ExpensiveWorkStarted(Exception):
    """Raised by the stand-in of the design search."""


def _too_late(*args: Any, **kwargs: Any) -> Any:
    raise ExpensiveWorkStarted


@pytest.fixture(autouse=True)
def no_search(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(gaitsmith.design_cmd, "design_body", _too_late)


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


MISTAKES = [
    (["--speed", "0"], "--speed must be a number in (0, 10] m/s"),
    (["--speed", "nan"], "--speed must be"),
    (["--speed", "0.3", "--generations", "0"], "--generations must be an integer in [1, 1000]"),
    (["--speed", "0.3", "--popsize", "1"], "--popsize must be an integer in [2, 1000]"),
    (["--speed", "0.3", "--workers", "0"], "--workers must be an integer in [1, 1024]"),
    (["--speed", "0.3", "--knots", "4"], "--knots must be an integer in [8, 200]"),
    (["--speed", "0.3", "--mass-weight", "-1"], "--mass-weight must be a number in [0, 1000]"),
    (["--speed", "0.3", "--mu", "0"], "--mu must be a number in (0, 10]"),
    (["--speed", "0.3", "--vary", "thigh,,shank"], "--vary must be a comma-separated list"),
    (["--speed", "0.3", "--vary", "tail"], "--vary: 'tail' matches no leg segment of quad12"),
    (["--speed", "0.3", "--servos", "NOPE"], "--servos: unknown servo model 'NOPE'"),
    (["--speed", "0.3", "--servos", "AX_12A,STS3215_12V"], "one bus needs one protocol"),
    (["--speed", "0.3", "--simulate", "--cycles", "1"], "--cycles must be an integer"),
]


@pytest.mark.parametrize(("args", "message"), MISTAKES)
def test_bad_options_are_one_line_and_exit_2(args: list[str], message: str, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main(["design", "quad12", *args, "-o", str(out)]) == 2
    assert message in _error_line(capsys)
    assert not out.exists()


def test_a_non_empty_output_folder_is_refused(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["design", "quad12", "--speed", "0.3", "-o", str(out)]) == 2
    assert "exists and is not empty" in _error_line(capsys)
    assert [p.name for p in out.iterdir()] == ["keep.txt"]


def test_an_unknown_robot_is_one_line(tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["design", "nosuchbot", "--speed", "0.3", "-o", str(tmp_path / "o")]) == 2
    assert "nosuchbot" in _error_line(capsys)


def test_good_options_reach_the_search(tmp_path: Path) -> None:
    with pytest.raises(ExpensiveWorkStarted):
        main(["design", "quad12", "--speed", "0.3", "--vary", "thigh,shank",
              "--servos", "STS3215_7V4,STS3215_12V", "-o", str(tmp_path / "o")])


def test_sim_accept_hands_the_search_a_picklable_mujoco_check(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pickle

    seen: dict[str, Any] = {}

    def capture(*args: Any, **kwargs: Any) -> Any:
        seen.update(kwargs)
        raise ExpensiveWorkStarted

    monkeypatch.setattr(gaitsmith.design_cmd, "design_body", capture)
    with pytest.raises(ExpensiveWorkStarted):
        main(["design", "quad12", "--speed", "0.3", "--sim-accept", "-o", str(tmp_path / "o")])
    factory = seen["acceptance"]
    assert isinstance(pickle.loads(pickle.dumps(factory)), gaitsmith.design_cmd.BodyAcceptance)
    with pytest.raises(ExpensiveWorkStarted):
        main(["design", "quad12", "--speed", "0.3", "-o", str(tmp_path / "o")])
    assert seen["acceptance"] is None

"""`gaitsmith library`: bad options fail at once (one line, exit 2) before any solve."""

from __future__ import annotations

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

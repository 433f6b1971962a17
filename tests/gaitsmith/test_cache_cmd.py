"""`gaitsmith cache build ROBOT` (compiled knot derivatives ahead of time, issue #16)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from gaitsmith.cli import main
from tests.zoo.fixtures import ZOO


def _error_lines(capsys: pytest.CaptureFixture[str]) -> list[str]:
    return [line for line in capsys.readouterr().err.splitlines() if line.strip()]


def test_cache_build_without_a_compiler_is_one_line_and_writes_no_library(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("GAITSMITH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("GAITSMITH_CC", str(tmp_path / "no-such-cc"))
    assert main(["cache", "build", str(ZOO / "bittle8")]) == 2
    lines = _error_lines(capsys)
    assert len(lines) == 1 and lines[0].startswith("error: bittle8: no C compiler found")
    assert not list(tmp_path.rglob("*.so"))


def test_cache_build_of_an_unknown_robot_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("GAITSMITH_CACHE", str(tmp_path / "cache"))
    assert main(["cache", "build", "no_such_robot"]) == 2
    lines = _error_lines(capsys)
    assert len(lines) == 1 and lines[0].startswith("error:") and "no_such_robot" in lines[0]


@pytest.mark.parametrize("flag", ["--no-background-compile", "--background-compile"])
def test_plan_no_background_compile_turns_the_switch_off_for_the_command(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
    flag: str,
) -> None:
    """The flag sets $GAITSMITH_BACKGROUND_COMPILE=0 for this process (and the workers it
    spawns) before the robot is loaded; the default leaves the switch alone. (An unknown robot
    stops the command right after, before any planning.)"""
    from planner.nlp.background_compile import ENV_SWITCH

    monkeypatch.setenv(ENV_SWITCH, "1")
    assert main(["plan", "no_such_robot", "-o", str(tmp_path / "g.json"), flag]) == 2
    assert "no_such_robot" in capsys.readouterr().err
    assert os.environ[ENV_SWITCH] == ("0" if flag.startswith("--no-") else "1")

"""`gaitsmith cache build ROBOT` (compiled knot derivatives ahead of time, issue #16)."""

from __future__ import annotations

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

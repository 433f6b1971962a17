"""`gaitsmith` command-line mistakes: one line on stderr, exit code 2, never a traceback —
also with typer 0.2x, which vendors click (typer._click) and does not depend on click."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from gaitsmith.cli import main
from robots.cli_usage import usage_error_type


def _one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert lines[0].startswith("error: ")
    return lines[0]


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["plan", "quad12"], "--output"),  # missing -o
        (["plan", "quad12", "-o", "x.json", "--bogus"], "--bogus"),  # unknown option
        (["plan", "quad12", "-o", "x.json", "--speed", "abc"], "--speed"),  # not a number
        (["simulate", "g.json", "--cycles", "zero"], "--cycles"),
        (["sweep", "quad12", "--knots", "1.5", "-o", "out"], "--knots"),
        (["robots", "show"], "robot"),  # missing argument
        (["nosuchcommand"], "nosuchcommand"),
    ],
)
def test_usage_errors_are_one_line_and_exit_2(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    captured = capsys.readouterr()
    line = _one_error_line(captured.err)
    assert expected in line and "--help" in line


def test_usage_error_type_is_the_click_exception_typer_raises() -> None:
    import typer

    assert issubclass(typer.BadParameter, usage_error_type())
    assert usage_error_type().__name__ == "ClickException"


def test_usage_errors_without_click_installed(tmp_path: Path) -> None:
    """A plain `pip install -e .` may have no click (typer 0.2x does not need it): the usage
    error handler must not import it."""
    code = (
        "import sys; sys.modules['click'] = None  # `import click` now raises ImportError\n"
        "from gaitsmith.cli import main\n"
        "sys.exit(main(['plan', 'quad12', '-o', 'x.json', '--speed', 'abc']))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=False, cwd=tmp_path, env=dict(os.environ))
    import typer

    if not hasattr(typer, "_click"):  # typer ≤ 0.1x is built on click itself: nothing to test
        pytest.skip("this typer depends on click")
    assert proc.returncode == 2, proc.stderr
    assert "--speed" in _one_error_line(proc.stderr)

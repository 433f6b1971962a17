"""`gaitsmith.option_coercion`: plain option values converted without pydantic give what typer's
own (pydantic) conversion gives, and anything else still goes through typer's."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from typer._adapters import try_build_adapter
from typer.models import OptionInfo

from gaitsmith.option_coercion import _NO_FAST_PATH, fast_value, install

VALUES: dict[type, list[Any]] = {
    float: [0.25, 1, 0, -3, "0.25", "1", "-0.5", "+0.5", "1e3", "1E-3", ".5", "5.", "007", "-0",
            "0.1000000000000000055511151231257827", "12345678901234567890.5", "30", "0.0"],
    int: [30, 0, -4, "30", "-4", "+4", "007", "99999999999999999999999", "0"],
    str: ["knot", "", " a ", "0.5"],
    bool: [True, False],
}


@pytest.mark.parametrize("annotation", list(VALUES))
def test_fast_values_are_typers(annotation: type) -> None:
    adapter = try_build_adapter(annotation, OptionInfo())
    assert adapter is not None
    for value in VALUES[annotation]:
        fast = fast_value(annotation, value)
        assert fast is not _NO_FAST_PATH, value
        expected = adapter.validate_python(value)
        assert type(fast) is type(expected) and fast == expected, (value, fast, expected)
        if isinstance(expected, float):
            assert repr(fast) == repr(expected)  # the sign of -0.0 too


@pytest.mark.parametrize(
    ("annotation", "value"),
    [(float, "abc"), (float, "1_000"), (float, " 1"), (float, "inf"), (float, "nan"),
     (float, True), (float, ""), (int, "3.0"), (int, 3.0), (int, "1_000"), (int, True),
     (int, " 3"), (str, b"x"), (bool, "true"), (bool, 1), (Path, "x")],
)
def test_everything_else_is_left_to_typer(annotation: type, value: Any) -> None:
    assert fast_value(annotation, value) is _NO_FAST_PATH


def test_install_is_idempotent_and_leaves_errors_to_typer(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from gaitsmith.cli import main

    assert install() and install()
    assert main(["plan", "quad12", "-o", "x.json", "--knots", "3.5"]) == 2
    err = capsys.readouterr().err
    assert "Invalid value for '--knots': Input should be a valid integer, unable to parse " \
        "string as an integer" in err


def test_a_plan_command_imports_no_pydantic(tmp_path: Path) -> None:
    """The command's options are parsed (and the command runs up to its first solve) without
    importing pydantic."""
    code = (
        "import sys\n"
        "import gaitsmith.cli as cli\n"
        "from planner.nlp import spacetime\n"
        "class Stop(Exception):\n    pass\n"
        "def stop(self, *a, **k):\n    raise Stop\n"
        "spacetime.GaitPlanner.solve = stop\n"
        "try:\n"
        f"    cli.app(['plan', 'quad12', '--speed', '0.25', '--knots', '12', '-o', "
        f"{str(tmp_path / 'g.json')!r}], standalone_mode=False)\n"
        "except Stop:\n    pass\n"
        "print('pydantic' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=300)
    assert out.stdout.strip().splitlines()[-1] == "False", out.stderr[-2000:]

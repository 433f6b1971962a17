"""`benchmarks/half_cycle_bench.py`: bad options refused in one line; a run prints both paths;
`--against` compares two half-cycle planners."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "half_cycle_bench.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                          timeout=600, check=False)


@pytest.mark.parametrize(("args", "message"), [
    (["--knots", "13"], "--knots: '13' needs even knot counts in [8, 200]"),
    (["--knots", "x"], "--knots: 'x' is not a comma-separated list of integers"),
    (["--reps", "0"], "--reps must be ≥ 1, got 0"),
    (["--gaits", "moonwalk"], "--gaits: quad12 has no template moonwalk"),
    (["--against", "swing_wrench"], "--against: 'swing_wrench' is not FIELD=VALUE"),
    (["--against", "no_such=1"], "--against: 'no_such=1' is not FIELD=VALUE"),
    (["--against", "swing_wrench=both"], "--against: planner option swing_wrench='both'"),
    (["--against", "half_cycle_solve=False"], "--against: half_cycle_solve is not a field"),
])
def test_bad_options_are_one_line(args: list[str], message: str) -> None:
    proc = _run(*args)
    assert proc.returncode != 0 and message in proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_symmetric_template_takes_the_same_iterates_on_half_the_knots() -> None:
    proc = _run("--knots", "12", "--gaits", "trot", "--search-cap")
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [line for line in proc.stdout.splitlines() if line.startswith("| 12 | trot |")]
    assert len(rows) == 1
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    assert cells[2] == cells[4]  # the same iteration count
    assert abs(float(cells[6])) <= 1e-9  # the same cost
    assert cells[9] == "True"  # the reduced NLP was used


def test_against_solves_both_on_half_the_knots() -> None:
    proc = _run("--knots", "12", "--gaits", "trot", "--search-cap", "--against",
                "swing_wrench=bounds")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "| half it | half cost | swing_wrench=bounds it |" in proc.stdout
    rows = [line for line in proc.stdout.splitlines() if line.startswith("| 12 | trot |")]
    assert len(rows) == 1
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    assert cells[9] == "True"  # the second planner solved on half the knots too
    assert cells[10] == "0.0e+00"  # and the first's solution is its own mirror image


def test_against_takes_a_number_for_a_float_field() -> None:
    from tests.benchmarks import load_script

    bench = load_script("half_cycle_bench")
    assert bench._fields("hessian_shift_acc=3e-7") == {"hessian_shift_acc": 3e-7}
    assert bench._fields("swing_wrench=bounds,hessian_shift_acc=0") == {
        "swing_wrench": "bounds", "hessian_shift_acc": 0.0}
    for bad in ("hessian_shift_acc=abc", "hessian_shift_acc=-1"):
        with pytest.raises(SystemExit):
            bench._fields(bad)

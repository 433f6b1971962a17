"""`benchmarks/half_cycle_bench.py`: bad options refused in one line; a run prints both paths."""

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

"""`benchmarks/coldstart_screen.py` runs: its patches of `planner.nlp.spacetime` follow the
signatures they replace (its `_solve_bounds` patch broke when `GaitPlanner.solve` began passing
the swing wrench, session 40, and every run failed until session 41)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCREEN = Path(__file__).resolve().parents[2] / "benchmarks" / "coldstart_screen.py"


def test_a_screen_of_two_variants_prints_its_table() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCREEN), "quad12", "0.25", "base={}",
         "swb=opt:swing_wrench=bounds", 'clr={"_freeclr": 1}', "--templates", "trot",
         "--knots", "12"],
        capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [line.split() for line in proc.stdout.splitlines() if line.startswith("trot ")]
    assert len(rows) == 1
    # schedule, then iterations and relative cost per variant; the baseline's cost is +0
    assert rows[0][2] == "+0.0e+00" and len(rows[0]) == 7

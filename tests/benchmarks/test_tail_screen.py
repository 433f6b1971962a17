"""`benchmarks/tail_screen.py`: its variants parse into `PlannerOptions`, and a small run (two
variants, one template, a warm chain of one) prints both tables."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from planner.nlp.config import PlannerOptions
from tests.benchmarks import load_script

SCREEN = Path(__file__).resolve().parents[2] / "benchmarks" / "tail_screen.py"


def test_a_variant_is_the_baseline_with_its_ipopt_options() -> None:
    screen = load_script("tail_screen")
    base = PlannerOptions(swing_wrench="rows")
    v = screen.parse_variant('v={"tol": 1e-5, "alpha_for_y": "bound-mult"}', base)
    assert v.name == "v" and v.options.tol == 1e-5 and v.options.swing_wrench == "rows"
    assert v.options.ipopt_extra == (("alpha_for_y", "bound-mult"),)
    assert screen.parse_variant("base={}", base).options == base
    for bad in ("noequals", "v=[1]", "v={bad json", 'v={"max_iter": 3}'):
        with pytest.raises(SystemExit):
            screen.parse_variant(bad, base)


def test_a_screen_of_two_variants_prints_its_tables() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCREEN), "base={}", 'bm={"alpha_for_y": "bound-mult"}',
         "--robot", "quad12", "--templates", "trot", "--knots", "12", "--warm", "1"],
        capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [line for line in proc.stdout.splitlines() if line.startswith(("| trot", "| s0"))]
    assert len(rows) == 2, proc.stdout[-2000:]
    # the baseline's cell: iterations, then its cost relative to itself
    assert rows[0].split("|")[2].split()[1] == "+0.0e+00"
    assert "cold solves" in proc.stdout and "warm chain of 1" in proc.stdout

"""`benchmarks/half_cycle_verdicts.py`: bad options refused in one line; a run judges full, half
and a perturbed start, and a zero perturbation reproduces the full solve bit for bit."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "half_cycle_verdicts.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                          timeout=600, check=False)


@pytest.mark.parametrize(("args", "message"), [
    (["run", "--cases", "quad12"], "--cases: 'quad12' is not ROBOT@SPEED"),
    (["run", "--cases", "quad12@fast"], "speed 'fast' is not a number"),
    (["run", "--cases", "quad12@0"], "the speed must be > 0 m/s"),
    (["run", "--cases", "nosuch@0.2"], "cannot load robot 'nosuch'"),
    (["run", "--cases", "quad12@0.2:moonwalk"], "quad12 has no template moonwalk"),
    (["run", "--cases", "quad12@0.2:trot/knots13"], "knots must be even and ≥ 8"),
    (["run", "--cases", "quad12@0.2:trot/flavour3"], "unknown modifier 'flavour3'"),
    (["run", "--cases", "quad12@0.2:trot", "--sigma", "-1"], "--sigma must be finite and ≥ 0"),
    (["run", "--cases", "quad12@0.2:trot", "--seeds", "a"], "--seeds: 'a' is not"),
    (["table", "/nonexistent/rows.jsonl"], "table: no such file /nonexistent/rows.jsonl"),
])
def test_bad_options_are_one_line(args: list[str], message: str) -> None:
    proc = _run(*args)
    assert proc.returncode != 0 and message in proc.stderr, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr


def test_a_zero_perturbation_is_the_full_solve_and_margins_match_the_judge(
        tmp_path: Path) -> None:
    out = tmp_path / "rows.jsonl"
    proc = _run("run", "--cases", "quad12@0.25:trot", "--knots", "12", "--sigma", "0",
                "--seeds", "1", "--out", str(out))
    assert proc.returncode == 0, proc.stderr[-2000:]
    (row,) = [json.loads(x) for x in out.read_text().splitlines()]
    assert row["symmetric"] and set(row["runs"]) == {"full", "half", "full~1"}
    full, half, same = row["runs"]["full"], row["runs"]["half"], row["runs"]["full~1"]
    # σ = 0: the warm start under "session21" is the cold solve, bit for bit
    assert same["dx"] == 0.0 and same["cost_rel"] == 0.0 and same["same_optimum"]
    assert same["iterations"] == full["iterations"] and same["passed"] == full["passed"]
    assert half["half_cycle_used"] and not full["half_cycle_used"]
    for run in (full, half, same):
        assert run["passed"] is not None and run["checks"]
        for name, check in run["checks"].items():
            assert (check["margin"] >= 0.0) == check["ok"], (name, check)
        assert run["passed"] == all(c["ok"] for c in run["checks"].values())
    table = _run("table", str(out))
    assert table.returncode == 0, table.stderr[-2000:]
    assert "verdict flips full vs half: 0 of 1" in table.stdout
    assert "verdict flips full vs full~k: 0 of 1" in table.stdout

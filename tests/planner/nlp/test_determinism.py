"""The same plan in two fresh processes is the same NLP and the same solve, bit for bit,
whatever the hash seed and whether the derivative-direction cache is empty or warm
(docs/results/planner_determinism.md, session 31: the "30 vs 38 iterations on hex18's pronk"
were two different NLPs, `compact_rows=()` and the default ranged envelope)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[3]


def _probe(case: tuple[str, str, str], hash_seed: int, cache: Path) -> dict[str, Any]:
    env = {**os.environ, "PYTHONHASHSEED": str(hash_seed), "GAITSMITH_CACHE": str(cache),
           "GAITSMITH_BACKGROUND_COMPILE": "0", "OMP_NUM_THREADS": "1",
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(
        [sys.executable, "-m", "tests.planner.nlp.determinism_probe", *case, "12"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


@pytest.mark.slow
@pytest.mark.parametrize("case", [("quad12", "trot", "0.25"), ("hex18", "pronk", "0.15")])
def test_same_nlp_and_solve_across_processes(case: tuple[str, str, str],
                                             tmp_path: Path) -> None:
    first = _probe(case, 0, tmp_path / "a")  # empty cache: every direction created
    other_seed = _probe(case, 1, tmp_path / "b")  # empty cache, another hash seed
    warm = _probe(case, 2, tmp_path / "a")  # the directions recorded by `first`
    assert (first["directions_cached"], other_seed["directions_cached"],
            warm["directions_cached"]) == (False, False, True)
    assert first["feasible"]
    for name, run in (("another hash seed", other_seed), ("a warm cache", warm)):
        differ = sorted(k for k in first if k != "directions_cached" and first[k] != run[k])
        assert not differ, f"{case}: {name} changed {differ}"

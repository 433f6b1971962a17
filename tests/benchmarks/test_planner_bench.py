"""`benchmarks/planner_bench.py`: the warm chains' symmetric perturbation keeps a schedule
half-cycle symmetric (so the half-cycle NLP fits it), the plain one does not (session 41);
`--cache` builds the paths from the given disk cache (session 43)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import robots
from planner.nlp.mirror import schedule_symmetric
from planner.templates import make_schedule, mirror_permutation
from tests.benchmarks import load_script

bench = load_script("planner_bench")


def test_symmetric_perturbations_stay_half_cycle_symmetric() -> None:
    for name, gait in (("quad12", "trot"), ("hex18", "tripod")):
        robot = robots.load(name)
        image = mirror_permutation(robot)
        assert image is not None
        base = make_schedule(robot, gait)
        rng = np.random.default_rng(1)
        chain = [bench.symmetric_perturbed(base, image, rng) for _ in range(8)]
        assert all(schedule_symmetric(s, image, 30) for s in chain)
        assert len({s.contact_matrix(30).tobytes() for s in chain}) > 1  # they do change
        # the plain perturbation (seed 1's first draw) breaks the symmetry
        assert not schedule_symmetric(bench.perturbed(base, np.random.default_rng(1)), image, 30)


def test_paths_build_from_the_given_cache(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                          ) -> None:
    """`--cache DIR`: the paths are built from DIR (what it holds is reported: here nothing
    compiled, so the knot derivatives are built and their directions written there), and the
    process's own GAITSMITH_CACHE is put back afterwards."""
    before = os.environ.get("GAITSMITH_CACHE")
    planners = bench._build_paths(robots.load("quad12"), 8, ["default"], tmp_path)
    assert os.environ.get("GAITSMITH_CACHE") == before
    assert planners["default"].derivative_cache is not None
    assert not planners["default"].derivative_cache.compiled
    assert list(tmp_path.glob("directions-*.json"))  # the build used (and wrote to) DIR
    out = capsys.readouterr().out
    assert f"build default: from {tmp_path}" in out and "not compiled" in out

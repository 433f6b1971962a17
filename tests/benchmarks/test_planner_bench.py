"""`benchmarks/planner_bench.py`'s warm chains: the symmetric perturbation keeps a schedule
half-cycle symmetric (so the half-cycle NLP fits it), the plain one does not (session 41)."""

from __future__ import annotations

import numpy as np

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

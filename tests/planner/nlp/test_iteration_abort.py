"""planner.nlp.iteration_abort: stop a coarse solve whose constraint violation stalls, without
changing any iterate before the stop (what makes `benchmarks/abort_replay.py` exact)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.iteration_abort import StallAbort
from planner.nlp.spacetime import GaitPlanner
from planner.search.gait_search import ABORTED_STATUS, TimingSolver, TimingSpace
from planner.templates import make_schedule


def test_the_rule_fires_only_late_above_the_floor_and_when_the_violation_stopped_halving(
) -> None:
    rule = StallAbort(after_iter=3, min_violation=0.03, window=2, fall_factor=0.5)
    assert not rule.fires([1.0, 0.5, 0.4])  # k = 2 < after_iter
    assert rule.fires([1.0, 0.5, 0.4, 0.3])  # 0.3 ≥ ½·min(0.5, 0.4)
    assert not rule.fires([1.0, 0.5, 0.4, 0.1])  # halved: still falling
    assert not rule.fires([1.0, 0.5, 0.04, 0.02])  # below the floor: may still converge
    assert rule.fires([1.0, 0.5, 0.06, 0.05, 0.04])  # judged at its last entry


@pytest.fixture(scope="module")
def coarse_planner() -> GaitPlanner:
    # the full NLP's solver and abort, asked for (the half-cycle solve's own: test_half_cycle.py)
    return GaitPlanner(robots.load("quad12"), n_knots=12,
                       options=PlannerOptions(half_cycle_solve=False))


def test_an_aborted_solve_stops_where_the_rule_fires_on_the_same_iterates(
    coarse_planner: GaitPlanner,
) -> None:
    schedule = make_schedule(coarse_planner.robot, "trot")
    full = coarse_planner.solve(schedule, 0.2, warm_start=False)
    assert not coarse_planner.last_solve_aborted
    # fires at iteration 3 whatever the violation (> 0) does
    coarse_planner.set_iteration_abort(StallAbort(after_iter=3, min_violation=0.0, window=1,
                                                  fall_factor=0.0))
    try:
        stopped = coarse_planner.solve(schedule, 0.2, warm_start=False)
        assert coarse_planner.last_solve_aborted
        assert stopped.status == "User_Requested_Stop" and stopped.iterations == 3
        log, ref = stopped.stats["iterations"], full.stats["iterations"]
        # the callback only reads: IPOPT's iterates up to the stop are the unaborted solve's
        assert log["inf_pr"] == ref["inf_pr"][:4] and log["obj"] == ref["obj"][:4]
        # and the violation the rule sees is IPOPT's own inf_pr (the replay's input)
        abort = coarse_planner._abort
        assert abort is not None
        np.testing.assert_allclose(abort.inf_pr, ref["inf_pr"][:4], rtol=1e-9, atol=1e-12)
        # a sample the search stopped ranks after every solved one
        space = TimingSpace.for_robot(coarse_planner.robot)
        x = space.encode(schedule)
        assert x is not None
        r = TimingSolver(coarse_planner, space, 0.2)(x)
        assert r.status == ABORTED_STATUS and not r.feasible and not r.plan_feasible
        assert math.isinf(r.violation) and math.isinf(r.cost) and r.n_fevals == 4
    finally:
        coarse_planner.set_iteration_abort(None)
    again = coarse_planner.solve(schedule, 0.2, warm_start=False)
    assert not coarse_planner.last_solve_aborted
    np.testing.assert_array_equal(again.warm_start.x, full.warm_start.x)
    assert again.iterations == full.iterations


def test_a_rule_that_never_fires_leaves_the_solve_bit_identical(
    coarse_planner: GaitPlanner,
) -> None:
    schedule = make_schedule(coarse_planner.robot, "trot")
    plain = coarse_planner.solve(schedule, 0.2, warm_start=False)
    coarse_planner.set_iteration_abort(StallAbort(after_iter=10**6))
    try:
        watched = coarse_planner.solve(schedule, 0.2, warm_start=False)
    finally:
        coarse_planner.set_iteration_abort(None)
    assert watched.feasible == plain.feasible and watched.iterations == plain.iterations
    np.testing.assert_array_equal(watched.warm_start.x, plain.warm_start.x)
    assert watched.cost == plain.cost

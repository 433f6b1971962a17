"""planner.nlp.iteration_abort: stopping coarse solves whose constraint violation stalls."""

from __future__ import annotations

import numpy as np

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.iteration_abort import StallAbort
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule


def test_the_rule_fires_only_late_high_and_not_halving() -> None:
    rule = StallAbort(after_iter=3, min_violation=0.03, window=2, fall_factor=0.5)
    assert not rule.fires([0.5, 0.4, 0.3])  # too early
    assert rule.fires([0.5, 0.4, 0.3, 0.2])  # high, 0.2 ≥ 0.5 · min(0.4, 0.3)
    assert not rule.fires([0.5, 0.4, 0.3, 0.1])  # halved: still converging
    assert not rule.fires([0.5, 0.4, 0.3, 0.02])  # low enough
    assert not StallAbort().fires([])


def test_a_fired_rule_stops_ipopt_and_the_point_is_judged_infeasible() -> None:
    bot = robots.load("quad12")
    planner = GaitPlanner(bot, 12, PlannerOptions(max_iter=60))
    schedule = make_schedule(bot, "trot")
    free = planner.solve(schedule, 0.25, warm_start=False)
    assert free.feasible
    # fires at iteration 2 whatever the violation (it is > 0 there)
    planner.set_iteration_abort(StallAbort(after_iter=2, min_violation=0.0, window=1,
                                           fall_factor=0.0))
    stopped = planner.solve(schedule, 0.25, warm_start=False)
    assert not stopped.feasible
    assert stopped.iterations <= 3
    assert stopped.stats["return_status"] == "User_Requested_Stop"
    # the violations the callback saw are IPOPT's inf_pr
    inf_pr = stopped.stats["iterations"]["inf_pr"]
    assert planner._abort is not None
    np.testing.assert_allclose(planner._abort.inf_pr[: len(inf_pr)], inf_pr, rtol=1e-9)
    # the default rule leaves a converging solve alone: same iterations and cost
    planner.set_iteration_abort(StallAbort())
    again = planner.solve(schedule, 0.25, warm_start=False)
    assert again.feasible and again.iterations == free.iterations
    assert abs(again.cost - free.cost) <= 1e-12 * max(1.0, abs(free.cost))
    planner.set_iteration_abort(None)
    assert planner.solve(schedule, 0.25, warm_start=False).iterations == free.iterations

"""The gait search's final phase on the executor's workers (`search_gait(final_on_workers=)`,
docs/results/planner_speed_search.md §4)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.search import executors
from planner.search.basin_cma import LocalResult
from planner.search.executors import SerialExecutor
from planner.search.gait_search import (
    FinalSolve,
    TimingSolverFactory,
    _FinalChooser,
    final_solve_on_worker,
    search_gait,
)


class _Plan:
    def __init__(self, cost: float, feasible: bool) -> None:
        self.cost, self.feasible = cost, feasible


def _take(outcomes: list[tuple[bool, bool | None]]) -> tuple[Any, int, bool]:
    chooser = _FinalChooser()
    searched = LocalResult(np.zeros(1), 0.0, True)
    done = chooser.take((searched, FinalSolve(_Plan(float(i), feas), 0.0, ok))  # type: ignore[arg-type]
                        for i, (feas, ok) in enumerate(outcomes))
    assert chooser.chosen is not None
    return chooser.chosen, len(chooser.solves), done


def test_the_first_feasible_accepted_candidate_wins_and_later_ones_are_dropped() -> None:
    chosen, n, done = _take([(False, None), (True, False), (True, True), (True, True)])
    assert (chosen[0].cost, chosen[2], n, done) == (2.0, True, 3, True)


def test_without_an_accepted_candidate_the_first_feasible_one_is_kept() -> None:
    chosen, n, done = _take([(False, None), (True, False), (True, False)])
    assert (chosen[0].cost, chosen[2], n, done) == (1.0, False, 3, False)
    chosen, _, _ = _take([(False, None), (False, None)])
    assert (chosen[0].cost, chosen[2]) == (0.0, None)


def test_final_solve_needs_a_search_worker_with_a_final_planner() -> None:
    executors._WORKER_SOLVE = None
    with pytest.raises(PlannerConfigError, match="gait-search worker"):
        final_solve_on_worker(np.zeros(4))
    factory = TimingSolverFactory(str(robots.load("quad12").root_dir), 12, 0.25, True)
    SerialExecutor(factory)  # builds this process's worker solve, without a final spec
    try:
        with pytest.raises(PlannerConfigError, match="without a final planner"):
            final_solve_on_worker(np.zeros(4))
    finally:
        executors._WORKER_SOLVE = None


@pytest.mark.slow
def test_process_workers_re_solve_the_final_candidates_like_one_process() -> None:
    """The final full-resolution re-solves on the pool's workers (two candidates at a time)
    pick the same winner, plans and verdicts as the one-by-one loop in this process."""
    robot = robots.load("quad12")
    kw: dict[str, Any] = dict(n_knots=16, max_generations=1, popsize=2, seed=1,
                              final_candidates=3, executor="process", workers=2)
    here = search_gait(robot, 0.2, final_on_workers=False, **kw)
    pooled = search_gait(robot, 0.2, **kw)
    assert pooled.template_costs == pytest.approx(here.template_costs, rel=1e-9)
    assert pooled.search_cost == pytest.approx(here.search_cost, rel=1e-9)
    assert [(p.cost, ok) for p, _, ok in pooled.final_solves] == pytest.approx(
        [(p.cost, ok) for p, _, ok in here.final_solves], rel=1e-9)
    assert pooled.best.cost == pytest.approx(here.best.cost, rel=1e-9)
    assert pooled.accepted == here.accepted and pooled.label == here.label
    assert pooled.planner.n_knots == 16 and pooled.best.feasible
    assert pooled.planner.to_gait(pooled.best, "search").joint_angles_rad.shape[0] > 0
    assert here.phase_s["final_build"] > 0 and min(pooled.phase_s.values()) >= 0

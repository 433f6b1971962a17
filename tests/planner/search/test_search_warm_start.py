"""Search warm starts (`search_gait(warm_start=...)`, planner_speed_search.md "Session 30"):
which earlier solution the main process starts a sample from, and what a worker does with it;
no NLP is solved here."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.spacetime import WarmStart
from planner.nlp.variables import Layout
from planner.search.executors import SerialExecutor
from planner.search.gait_search import (
    WARM_STARTS_KEPT,
    SampleStart,
    TimingResult,
    TimingSolver,
    TimingSpace,
    WarmStartExecutor,
    search_gait,
)

LAYOUT = Layout(12, 12, 4)


@dataclass
class _Result:
    cost: float
    feasible: bool
    warm_start: WarmStart
    iterations: int = 3
    max_violation: float = 0.0
    status: str = "Solve_Succeeded"
    stats: dict[str, Any] = field(default_factory=dict)


@dataclass
class _StubPlanner:
    """Records the start of every solve; returns `costs` in turn (feasible), its solution a
    vector of the coarse layout filled with the call index."""

    costs: list[float]
    starts: list[Any] = field(default_factory=list)
    last_solve_aborted: bool = False  # GaitPlanner's: no iteration abort here
    layout: Layout = LAYOUT
    n_knots: int = 12

    def primal_start(self, x: np.ndarray) -> WarmStart:
        return WarmStart(x, np.zeros_like(x), np.zeros(5))

    def solve(self, schedule: Any, speed_m_s: float, warm_start: Any = None) -> _Result:
        self.starts.append(warm_start)
        k = len(self.starts) - 1
        x = np.full(LAYOUT.size, float(k))
        return _Result(self.costs[k], True, WarmStart(x, x, x))


def _solver(policy: str, costs: list[float]) -> tuple[TimingSolver, _StubPlanner]:
    stub = _StubPlanner(costs)
    space = TimingSpace.for_robot(robots.load("quad12"))
    return TimingSolver(stub, space, 0.25, warm_start=policy), stub  # type: ignore[arg-type]


def _samples(space: TimingSpace) -> list[np.ndarray]:
    lo, hi = space.bounds()
    return [lo + f * (hi - lo) for f in (0.2, 0.8, 0.25, 0.75)]


@pytest.mark.parametrize(("policy", "expected"), [
    # first batch (samples 0, 1) cold; then sample 2 is nearest sample 0, sample 3 nearest 1
    ("nearest", [False, False, 0.0, 1.0]),
    # the cheapest of the first batch: sample 1 (cost 1)
    ("incumbent", [False, False, 1.0, 1.0]),
])
def test_each_policy_starts_from_an_earlier_batch(policy: str, expected: list[Any]) -> None:
    solver, stub = _solver(policy, [5.0, 1.0, 3.0, 2.0])
    pool = WarmStartExecutor(SerialExecutor(), solver.space, policy)
    xs = _samples(solver.space)
    pool.map(solver, xs[:2])
    pool.map(solver, xs[2:])  # one batch: neither sample starts from the other
    got = [s if s is False else float(s.x[0]) for s in stub.starts]
    assert got == expected
    assert len(pool.solved) == 4


def test_the_solutions_kept_are_bounded_and_the_worst_goes_first() -> None:
    solver, _ = _solver("nearest", [])
    pool = WarmStartExecutor(SerialExecutor(), solver.space, "nearest")
    x = _samples(solver.space)[0]
    for k in range(WARM_STARTS_KEPT + 3):
        # costs 0, 1, 2, ... except one very cheap late sample
        cost = -1.0 if k == WARM_STARTS_KEPT + 1 else float(k)
        result = TimingResult(x, cost, True, solution=np.full(LAYOUT.size, float(k)))
        pool.remember(x, result)
    assert len(pool.solved) == WARM_STARTS_KEPT
    kept = sorted(s[1][1] for s in pool.solved)
    assert kept[0] == -1.0 and kept[-1] == float(WARM_STARTS_KEPT - 2)


def test_cold_policy_returns_no_solution_and_needs_no_executor_wrapper() -> None:
    solver, stub = _solver("cold", [1.0])
    r = solver(_samples(solver.space)[0])
    assert r.solution is None and not r.warm and stub.starts == [False]
    with pytest.raises(PlannerConfigError, match="warm policy"):
        WarmStartExecutor(SerialExecutor(), solver.space, "cold")


def test_warm_result_is_marked_and_carries_its_solution() -> None:
    solver, _ = _solver("nearest", [1.0, 2.0])
    x = _samples(solver.space)[0]
    first = solver(x)
    assert first.solution is not None and not first.warm
    second = solver(SampleStart(x, first.solution, x, retime=False))
    assert second.warm


def test_a_start_of_another_layout_is_refused_in_one_line() -> None:
    solver, _ = _solver("nearest", [1.0])
    x = _samples(solver.space)[0]
    with pytest.raises(PlannerConfigError, match="same search") as err:
        solver(SampleStart(x, np.zeros(7), x, retime=False))
    assert "\n" not in str(err.value)


def test_retimed_start_reaches_the_worker_rescaled() -> None:
    solver, stub = _solver("nearest-retimed", [1.0])
    lo, hi = solver.space.bounds()
    source, target = lo + 0.5 * (hi - lo), lo + 0.5 * (hi - lo)
    target[0] = source[0] / 2.0 if source[0] / 2.0 >= lo[0] else lo[0]
    x = np.ones(LAYOUT.size)
    solver(SampleStart(target, x, source, retime=True))
    start = stub.starts[0].x
    v0 = LAYOUT.indices("vel")[0, 0]  # knot 0's first rate
    rate = source[0] / target[0]
    assert start[v0] == pytest.approx(rate) and rate > 1.0


def test_unknown_warm_start_is_one_line() -> None:
    with pytest.raises(PlannerConfigError, match="warm_start must be one of") as err:
        search_gait(robots.load("quad12"), 0.25, warm_start="hot")
    assert "\n" not in str(err.value)


def test_timing_result_defaults_keep_old_records_loadable() -> None:
    r = TimingResult(np.zeros(1), 1.0, True)
    assert r.solution is None and r.warm is False

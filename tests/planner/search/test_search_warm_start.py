"""Search warm starts (`search_gait(warm_start=...)`, docs/results/planner_speed_threads.md):
which earlier solution a worker starts a sample from; no NLP is solved here."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.spacetime import WarmStart
from planner.search.gait_search import (
    WARM_START_MEMORY,
    TimingSolver,
    TimingSpace,
    search_gait,
)


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
    """Records the start of every solve; returns `costs` in turn (feasible), tagging its start
    point with the call index."""

    costs: list[float]
    starts: list[Any] = field(default_factory=list)
    last_solve_aborted: bool = False  # GaitPlanner's: no iteration abort here

    def solve(self, schedule: Any, speed_m_s: float, warm_start: Any = None) -> _Result:
        self.starts.append(warm_start)
        k = len(self.starts) - 1
        tag = np.full(1, float(k))
        return _Result(self.costs[k], True, WarmStart(tag, tag, tag))


def _solver(policy: str, costs: list[float]) -> tuple[TimingSolver, _StubPlanner]:
    robot = robots.load("quad12")
    stub = _StubPlanner(costs)
    space = TimingSpace.for_robot(robot)
    return TimingSolver(stub, space, 0.25, warm_start=policy), stub  # type: ignore[arg-type]


def _samples(space: TimingSpace) -> list[np.ndarray]:
    lo, hi = space.bounds()
    return [lo + f * (hi - lo) for f in (0.2, 0.8, 0.25, 0.75)]


@pytest.mark.parametrize(("policy", "expected"), [
    ("cold", [False, False, False, False]),
    # sample 2 is nearest sample 0, sample 3 nearest sample 1
    ("nearest", [False, 0.0, 0.0, 1.0]),
    # the cheapest so far: sample 1 (cost 1) once solved
    ("incumbent", [False, 0.0, 1.0, 1.0]),
])
def test_each_policy_starts_from_the_expected_solution(policy: str, expected: list[Any]) -> None:
    solver, stub = _solver(policy, [5.0, 1.0, 3.0, 2.0])
    for x in _samples(solver.space):
        solver(x)
    got = [s if s is False else float(s.x[0]) for s in stub.starts]
    assert got == expected
    assert len(solver.solved) == (0 if policy == "cold" else 4)


def test_memory_is_bounded() -> None:
    solver, _ = _solver("nearest", [1.0] * (WARM_START_MEMORY + 5))
    x = _samples(solver.space)[0]
    for _ in range(WARM_START_MEMORY + 5):
        solver(x)
    assert len(solver.solved) == WARM_START_MEMORY


def test_unknown_warm_start_is_one_line() -> None:
    with pytest.raises(PlannerConfigError, match="warm_start must be one of") as err:
        search_gait(robots.load("quad12"), 0.25, warm_start="hot")
    assert "\n" not in str(err.value)

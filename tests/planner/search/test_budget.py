"""The final phase's candidates (`planner.search.budget`): 8 when the coarse check accepted no
sample, else 4; and that `search_gait` re-solves what the rule says unless told otherwise."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.search.budget import (
    FINAL_CANDIDATES,
    FINAL_CANDIDATES_NONE_ACCEPTED,
    any_accepted,
    final_candidate_count,
    final_candidates_reason,
)
from planner.search.gait_search import TimingResult, TimingSolverFactory


def _records(accepted: list[bool]) -> list[tuple[np.ndarray, TimingResult]]:
    """Samples whose plans all solved; `accepted` says which passed the coarse check."""
    out = []
    for i, ok in enumerate(accepted):
        x = np.full(4, float(i))
        out.append((x, TimingResult(x, 1.0 + i, ok, 0, 0.0 if ok else 1e-9, True)))
    return out


def test_eight_final_candidates_only_when_nothing_was_accepted() -> None:
    assert not any_accepted(_records([False] * 10))
    assert final_candidate_count(_records([False] * 10)) == FINAL_CANDIDATES_NONE_ACCEPTED == 8
    assert final_candidate_count(_records([False] * 9 + [True])) == FINAL_CANDIDATES == 4
    assert final_candidate_count([]) == FINAL_CANDIDATES_NONE_ACCEPTED
    assert final_candidate_count(_records([False] * 10), 3) == 3  # given: wins
    with pytest.raises(PlannerConfigError, match="final_candidates must be ≥ 1"):
        final_candidate_count(_records([True]), 0)
    assert final_candidates_reason(_records([False] * 3)) == "the coarse check accepted no sample"
    assert final_candidates_reason(_records([True])) == "a sample passed the coarse check"
    assert final_candidates_reason(_records([True]), 5) == "given"


class _FinalPlanner(Exception):
    """Raised by the stub final planner: the search reached its final phase."""


def _search(monkeypatch: pytest.MonkeyPatch, robot: str, accepted: bool, **kwargs: Any,
            ) -> tuple[dict[str, Any], list[Any]]:
    """A `search_gait` with its solves stubbed: every sample's plan solves and is `accepted`
    or rejected by the coarse check; basin-CMA is a stub that evaluates 12 distinct samples.
    Returns basin-CMA's keyword arguments and the final phase's tasks."""
    import planner.search.gait_search as gs

    cma_kwargs: dict[str, Any] = {}
    tasks: list[Any] = []

    class FakeExecutor:
        def __init__(self, factory: TimingSolverFactory) -> None:
            self.factory = factory

        def __enter__(self) -> FakeExecutor:
            return self

        def __exit__(self, *exc: object) -> None:
            return None

        def local_solve(self, x: np.ndarray) -> TimingResult:
            return TimingResult(x, float(np.sum(x)), accepted, 0,
                                0.0 if accepted else 1e-9, True)

        def map(self, fn: Any, xs: Any) -> list[Any]:
            return [fn(x) for x in xs]

    def fake_cma(local_solve: Any, x0: np.ndarray, sigma0: Any, bounds: Any, **kw: Any) -> None:
        cma_kwargs.update(kw)
        kw["executor"].map(local_solve, [x0 + 1e-3 * (i + 1) for i in range(12)])

    real_final_tasks = gs.final_tasks

    def recorded_final_tasks(*args: Any) -> Any:
        out = real_final_tasks(*args)
        tasks.extend(out[0])
        return out

    def stub_planner(*args: Any) -> None:
        raise _FinalPlanner

    monkeypatch.setattr(gs, "make_executor", lambda kind, factory, **kw: FakeExecutor(factory))
    monkeypatch.setattr(gs, "basin_cma", fake_cma)
    monkeypatch.setattr(gs, "final_tasks", recorded_final_tasks)
    monkeypatch.setattr(gs, "GaitPlanner", stub_planner)
    with pytest.raises(_FinalPlanner):
        gs.search_gait(robots.load(robot), 0.2, n_knots=20, acceptance=lambda: None, **kwargs)
    return cma_kwargs, tasks


@pytest.mark.parametrize(("accepted", "given", "searched"), [
    (True, None, FINAL_CANDIDATES), (False, None, FINAL_CANDIDATES_NONE_ACCEPTED),
    (False, 2, 2), (True, 6, 6),
])
def test_the_final_phase_reads_eight_candidates_when_nothing_was_accepted(
    monkeypatch: pytest.MonkeyPatch, accepted: bool, given: int | None, searched: int,
) -> None:
    """The final tasks: the cheapest searched timings (as many as the rule or `final_candidates`
    says), then the seeding templates (the fallback)."""
    cma_kwargs, tasks = _search(monkeypatch, "quad12", accepted, final_candidates=given)
    assert cma_kwargs["max_generations"] == 6  # every body: fewer lost (session 34)
    assert sum(task.template is None for task in tasks) == searched
    assert all(task.template is not None for task in tasks[searched:])

"""The search's budget by body (`planner.search.budget`): generations by the timing space's
dimension, 8 final candidates when the coarse check accepted nothing; and that `search_gait`
runs what the rule says unless told otherwise."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.search.budget import (
    DEFAULT_GENERATIONS,
    FINAL_CANDIDATES,
    FINAL_CANDIDATES_NONE_ACCEPTED,
    SMALL_SEARCH_GENERATIONS,
    SearchBudget,
    any_accepted,
    final_candidate_count,
    search_budget,
)
from planner.search.gait_search import TimingResult, TimingSolverFactory, search_space


@pytest.mark.parametrize(("robot", "dim", "generations"), [
    ("quad12", 4, 4), ("hex18", 6, 6), ("biped", 2, 4), ("tests/zoo/spotmicro", 4, 4),
    ("tests/zoo/bittle8", 4, 4), ("tests/zoo/knee8", 4, 4), ("tests/zoo/phantomx18", 6, 6),
    ("tests/zoo/star5", 10, 6), ("tests/zoo/humanoid20", 2, 4),
])
def test_the_rule_per_body(robot: str, dim: int, generations: int) -> None:
    """The dimension of the space the search searches (a star's mirror pairs run no template
    half a period apart: every foot is searched) and the generations the rule gives it."""
    space = search_space(robots.load(robot))
    assert space.dim == dim
    budget = search_budget(space.dim)
    assert budget.generations == generations
    assert str(dim) in budget.reason and ("≤" if generations == 4 else ">") in budget.reason


def test_the_rule_without_symmetry_is_the_larger_space() -> None:
    """--no-symmetric: a quadruped searches 8 variables and keeps 6 generations."""
    space = search_space(robots.load("quad12"), symmetric=False)
    assert space.dim == 8 and search_budget(space.dim).generations == DEFAULT_GENERATIONS


@pytest.mark.parametrize(("dim", "given"), [(4, 6), (10, 2), (2, 1)])
def test_given_generations_win(dim: int, given: int) -> None:
    assert search_budget(dim, given) == SearchBudget(given, "given")


@pytest.mark.parametrize(("dim", "given", "match"), [
    (0, None, "at least 1 variable"), (4, 0, "generations must be ≥ 1"),
])
def test_bad_budget_inputs_are_one_line(dim: int, given: int | None, match: str) -> None:
    with pytest.raises(PlannerConfigError, match=match) as err:
        search_budget(dim, given)
    assert "\n" not in str(err.value)


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


@pytest.mark.parametrize(("robot", "given", "expected"), [
    ("quad12", None, SMALL_SEARCH_GENERATIONS), ("hex18", None, DEFAULT_GENERATIONS),
    ("quad12", 6, 6), ("hex18", 3, 3),
])
def test_the_search_runs_the_rule_unless_given(monkeypatch: pytest.MonkeyPatch, robot: str,
                                               given: int | None, expected: int) -> None:
    cma_kwargs, _ = _search(monkeypatch, robot, True, max_generations=given)
    assert cma_kwargs["max_generations"] == expected


@pytest.mark.parametrize(("accepted", "given", "searched"), [
    (True, None, FINAL_CANDIDATES), (False, None, FINAL_CANDIDATES_NONE_ACCEPTED),
    (False, 2, 2), (True, 6, 6),
])
def test_the_final_phase_reads_eight_candidates_when_nothing_was_accepted(
    monkeypatch: pytest.MonkeyPatch, accepted: bool, given: int | None, searched: int,
) -> None:
    """The final tasks: the cheapest searched timings (as many as the rule or `final_candidates`
    says), then the seeding templates (the fallback)."""
    _, tasks = _search(monkeypatch, "quad12", accepted, final_candidates=given)
    assert sum(task.template is None for task in tasks) == searched
    assert all(task.template is not None for task in tasks[searched:])


def test_bad_generations_are_one_line_before_any_solve() -> None:
    from planner.search.gait_search import search_gait

    with pytest.raises(PlannerConfigError, match="max_generations must be ≥ 1") as err:
        search_gait(robots.load("quad12"), 0.25, max_generations=0)
    assert "\n" not in str(err.value)

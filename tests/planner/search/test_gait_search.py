"""Gait search (basin-CMA over contact timings) and the gait-from-speed sweep."""

from __future__ import annotations

import math
import pickle
from dataclasses import dataclass, replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.search.basin_cma import LocalResult
from planner.search.defaults import (
    FINAL_HALF_CYCLE,
    FINAL_SWING_WRENCH,
    SEARCH_HALF_CYCLE,
    SEARCH_SWING_WRENCH,
)
from planner.search.executors import SerialExecutor
from planner.search.gait_search import (
    DEFAULT_TIPPING_WEIGHT,
    RecordingExecutor,
    SearchLogRow,
    TimingResult,
    TimingSolver,
    TimingSolverFactory,
    TimingSpace,
    cost_of_transport,
    final_options,
    identical_schedules,
    search_gait,
    searchable_templates,
    write_search_log,
)
from planner.search.speed_sweep import row_from, to_csv, to_markdown, write_sweep
from planner.search.support import TippingCost
from planner.templates import make_schedule, templates_for
from robots import ContactSchedule, Gait


@pytest.mark.parametrize("name", ["quad12", "hex18"])
def test_timing_space_round_trips_the_symmetric_templates(name: str) -> None:
    robot = robots.load(name)
    space = TimingSpace.for_robot(robot, symmetric=True)
    assert space.dim == 1 + (len(robot.legs) // 2 - 1) + len(robot.legs) // 2
    encoded = 0
    for gait in templates_for(robot):
        sched = make_schedule(robot, gait)
        x = space.encode(sched)
        if x is None:  # bound, gallop, pronk break left/right half-period symmetry
            assert gait in ("bound", "gallop_rotary", "gallop_transverse", "pronk", "ripple",
                            "wave", "stand")
            continue
        encoded += 1
        back = space.decode(x)
        shift = back.touchdown_phase[0] - sched.touchdown_phase[0]
        np.testing.assert_allclose((np.subtract(back.touchdown_phase, sched.touchdown_phase)
                                    - shift + 0.5) % 1.0 - 0.5, 0.0, atol=1e-12)
        np.testing.assert_allclose(back.duty_factor, sched.duty_factor)
        assert back.period_s == pytest.approx(sched.period_s)
    assert encoded >= (3 if name == "quad12" else 1)


def test_asymmetric_space_encodes_every_template() -> None:
    robot = robots.load("quad12")
    space = TimingSpace.for_robot(robot, symmetric=False)
    assert space.dim == 1 + 3 + 4
    lo, hi = space.bounds()
    for gait in searchable_templates(robot):
        x = space.encode(make_schedule(robot, gait))
        assert x is not None
        assert np.all(x >= lo - 1e-12) and np.all(x <= hi + 1e-12)
        assert space.decode(x).touchdown_phase[0] == 0.0


def test_decode_wraps_phases_and_clips_durations() -> None:
    space = TimingSpace.for_robot(robots.load("quad12"), symmetric=True)
    sched = space.decode(np.array([0.5, 1.3, 2.0, -1.0]))
    assert all(0.0 <= p < 1.0 for p in sched.touchdown_phase)
    assert max(sched.duty_factor) <= 0.9 and min(sched.duty_factor) >= 0.35


@pytest.fixture(scope="module")
def small_quad_planner() -> GaitPlanner:
    # the search's final planner: half-cycle unless asked (`final_options`; since session 40)
    return GaitPlanner(robots.load("quad12"), n_knots=20, options=final_options(PlannerOptions()))


def test_timing_solver_is_a_cma_only_projection(small_quad_planner: GaitPlanner) -> None:
    """W&P §4.1.2: timing variables are CMA-only — the local solve does not move them."""
    robot = small_quad_planner.robot
    space = TimingSpace.for_robot(robot)
    solver = TimingSolver(small_quad_planner, space, 0.2)
    x = space.encode(make_schedule(robot, "trot"))
    assert x is not None
    r = solver(x)
    np.testing.assert_array_equal(r.x_projected, x)
    assert r.feasible and math.isfinite(r.cost) and r.n_fevals > 0


def test_timing_solver_adds_the_support_term_of_the_timing(
    small_quad_planner: GaitPlanner,
) -> None:
    robot = small_quad_planner.robot
    space = TimingSpace.for_robot(robot)
    tipping = TippingCost.for_robot(robot, 0.05)
    x = space.encode(make_schedule(robot, "trot"))
    assert x is not None
    plain = TimingSolver(small_quad_planner, space, 0.2)(x)
    with_support = TimingSolver(small_quad_planner, space, 0.2, tipping)(x)
    assert tipping(space.decode(x)) > 0
    assert with_support.cost == pytest.approx(plain.cost + tipping(space.decode(x)), rel=1e-6)


@dataclass(frozen=True)
class _Verdict:
    passed: bool
    badness: float


def test_rejected_samples_rank_after_feasible_and_before_infeasible_ones(
    small_quad_planner: GaitPlanner,
) -> None:
    """A feasible plan whose gait fails acceptance becomes infeasible with a tiny violation."""
    robot = small_quad_planner.robot
    space = TimingSpace.for_robot(robot)
    x = space.encode(make_schedule(robot, "trot"))
    assert x is not None
    seen: list[Gait] = []

    def reject(gait: Gait) -> _Verdict:
        seen.append(gait)
        return _Verdict(False, 2.0)

    r = TimingSolver(small_quad_planner, space, 0.2, None, reject)(x)
    assert len(seen) == 1 and seen[0].n_knots == small_quad_planner.n_knots
    assert not r.feasible and math.isfinite(r.cost)
    assert 0 < r.violation < 1e-6  # ranks ahead of plans that violate the NLP (≥ 1e-4)
    assert r.solve_s > 0 and r.accept_s > 0 and r.build_s == 0  # timed for the benchmarks
    assert r.cpu_s > 0 and r.accept_cpu_s > 0
    # IPOPT's iterates, iteration 0 first: the last objective is the NLP's cost
    assert len(r.iteration_log) == r.n_fevals
    assert r.iteration_log[-1][0] == pytest.approx(r.cost, rel=1e-12)
    assert all(len(row) == 3 and min(row[1:]) >= 0 for row in r.iteration_log)
    ok = TimingSolver(small_quad_planner, space, 0.2, None, lambda g: _Verdict(True, 0.0))(x)
    assert ok.feasible and ok.cost == pytest.approx(r.cost)


def test_recording_executor_ranks_distinct_feasible_samples() -> None:
    def fake(x: np.ndarray) -> LocalResult:
        return LocalResult(x, float(x[0]), bool(x[0] < 3))

    rec = RecordingExecutor(SerialExecutor())
    xs = [np.array([v]) for v in (2.0, 1.0, 4.0, 1.0, 0.5)]
    assert [r.cost for r in rec.map(fake, xs)] == [2.0, 1.0, 4.0, 1.0, 0.5]
    best = rec.best_feasible(3)
    assert [float(x[0]) for x, _ in best] == [0.5, 1.0, 2.0]  # 4.0 infeasible, 1.0 once
    # plans that solved but failed acceptance come after every feasible sample, by cost
    rec.map(lambda x: TimingResult(x, 0.1, False, 0, 1e-9, True), [np.array([9.0])])
    rec.map(lambda x: TimingResult(x, 0.2, False, 0, 1.0, False), [np.array([8.0])])
    assert [float(x[0]) for x, _ in rec.best_feasible(5)] == [0.5, 1.0, 2.0, 9.0]


def test_factory_is_picklable_for_process_and_ray_workers() -> None:
    f = TimingSolverFactory(str(robots.load("quad12").root_dir), 20, 0.2, True)
    assert pickle.loads(pickle.dumps(f)) == f


class _PlannerBuilt(Exception):
    """Raised by the stub final planner: the search got as far as building it."""


def _planners_of_a_search(monkeypatch: pytest.MonkeyPatch, options: Any, **kwargs: Any,
                          ) -> tuple[list[TimingSolverFactory], list[tuple[int, Any]]]:
    """The coarse planners' factory (as a worker receives it) and the final planner's (knots,
    options) of a `search_gait` on quad12 whose solves are stubbed (nothing is solved)."""
    import planner.search.gait_search as gs

    factories: list[TimingSolverFactory] = []
    built: list[tuple[int, Any]] = []

    class FakeExecutor:
        def __init__(self, factory: TimingSolverFactory) -> None:
            factories.append(pickle.loads(pickle.dumps(factory)))  # what a worker receives

        def __enter__(self) -> FakeExecutor:
            return self

        def __exit__(self, *exc: object) -> None:
            return None

        def local_solve(self, x: np.ndarray) -> TimingResult:
            return TimingResult(x, float(np.sum(x)), True, 0, 0.0, True)

        def map(self, fn: Any, xs: Any) -> list[Any]:
            return [fn(x) for x in xs]

    def stub_planner(robot: Any, n_knots: int, opts: Any) -> GaitPlanner:
        built.append((n_knots, opts))
        raise _PlannerBuilt

    monkeypatch.setattr(gs, "make_executor", lambda kind, factory, **kw: FakeExecutor(factory))
    monkeypatch.setattr(gs, "GaitPlanner", stub_planner)
    with pytest.raises(_PlannerBuilt):
        search_gait(robots.load("quad12"), 0.2, n_knots=20, options=options, max_generations=1,
                    popsize=2, search_knots=12, **kwargs)
    return factories, built


def test_the_search_planners_carry_the_rotor_reserve_and_swing_clearance(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`rotor_reserve` and `swing_clearance_m` reach every NLP of the search: the workers'
    coarse planners (through the picklable factory the process/Ray workers get) and the final
    full-resolution planner (which writes the gait file's metadata); `max_iter`,
    `inactive_rows` ("rows" for the coarse solves), `half_cycle_solve` (`SEARCH_HALF_CYCLE`) and
    `swing_wrench` (`SEARCH_SWING_WRENCH`) are the only options the search changes for its
    coarse NLP."""
    options = PlannerOptions(rotor_reserve=0.15, swing_clearance_m=0.018)
    (factory,), built = _planners_of_a_search(monkeypatch, options, search_max_iter=50)
    assert factory.n_knots == 12
    assert factory.options == replace(options, max_iter=50, inactive_rows="rows",
                                      half_cycle_solve=SEARCH_HALF_CYCLE,
                                      swing_wrench=SEARCH_SWING_WRENCH)
    assert built == [(20, final_options(options))]


@pytest.mark.parametrize(("own", "coarse"), [
    ("rows", None), ("rows", "bounds"), ("bounds", "rows"), ("bounds", None),
])
def test_search_swing_wrench_reaches_the_coarse_solves_only(
    monkeypatch: pytest.MonkeyPatch, own: str, coarse: str | None,
) -> None:
    """`search_swing_wrench` is the coarse NLP's `swing_wrench` (None: the options' own); the
    final planner takes `final_swing_wrench` (here its default, `final_options`'), whatever
    the coarse solves use."""
    options = PlannerOptions(swing_wrench=own)
    (factory,), built = _planners_of_a_search(monkeypatch, options, search_max_iter=60,
                                              search_swing_wrench=coarse)
    assert factory.options.swing_wrench == (coarse or own)
    assert factory.options == replace(options, max_iter=60, swing_wrench=coarse or own,
                                      inactive_rows="rows", half_cycle_solve=SEARCH_HALF_CYCLE)
    assert built == [(20, final_options(options))]


@pytest.mark.parametrize(("own", "coarse"), [
    ("free stance", None), ("free", None), ("rows", None), ("free stance", "free"),
])
def test_coarse_solves_keep_rows_and_the_final_planner_the_options_inactive_rows(
    monkeypatch: pytest.MonkeyPatch, own: str, coarse: str | None,
) -> None:
    """The coarse (12-knot) NLP gets `search_inactive_rows` ("rows" unless asked: "free" lost
    2 of 35 optima at N = 12, planner_speed_ipopt.md session 33), whatever the options say; the
    final planner is built with the options' own `inactive_rows`."""
    options = PlannerOptions(inactive_rows=own)
    kwargs = {} if coarse is None else {"search_inactive_rows": coarse}
    (factory,), built = _planners_of_a_search(monkeypatch, options, search_max_iter=60, **kwargs)
    assert factory.options == replace(options, max_iter=60, inactive_rows=coarse or "rows",
                                      half_cycle_solve=SEARCH_HALF_CYCLE,
                                      swing_wrench=SEARCH_SWING_WRENCH)
    assert built == [(20, final_options(options))]


@pytest.mark.parametrize(("clearance", "centrality"), [
    ("rows", "none"), ("free", "none"), ("rows", "reciprocal"), ("free", "reciprocal"),
])
def test_coarse_solves_keep_the_stance_clearance_rows_and_the_mu_oracle(
    monkeypatch: pytest.MonkeyPatch, clearance: str, centrality: str,
) -> None:
    """The coarse NLP gets `SEARCH_STANCE_CLEARANCE` ("rows") and `SEARCH_COLD_MU_CENTRALITY`
    ("none"), measured at N = 30 only (planner_speed_coldstart.md, session 39), whatever the
    options say; the final planner the options' own."""
    options = PlannerOptions(stance_clearance=clearance, cold_mu_centrality=centrality)
    (factory,), built = _planners_of_a_search(monkeypatch, options, search_max_iter=60)
    assert factory.options.stance_clearance == "rows"
    assert factory.options.cold_mu_centrality == "none"
    assert factory.options == replace(options, max_iter=60, inactive_rows="rows",
                                      stance_clearance="rows", cold_mu_centrality="none",
                                      half_cycle_solve=SEARCH_HALF_CYCLE,
                                      swing_wrench=SEARCH_SWING_WRENCH)
    assert built == [(20, final_options(options))]
    assert built[0][1].stance_clearance == clearance
    assert built[0][1].cold_mu_centrality == centrality


def test_unknown_search_inactive_rows_is_one_line_before_any_solve() -> None:
    with pytest.raises(PlannerConfigError,
                       match=r"search_inactive_rows must be one of rows, free.*'none'") as err:
        search_gait(robots.load("quad12"), 0.25, search_inactive_rows="none")
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("tol", [None, 1e-4])
def test_search_tol_reaches_the_coarse_solves_only(
    monkeypatch: pytest.MonkeyPatch, tol: float | None,
) -> None:
    """`search_tol` is the coarse NLP's IPOPT `tol`; the final planner keeps the options' own
    (so final costs compare between settings); None: the options' own for both."""
    options = PlannerOptions()
    (factory,), built = _planners_of_a_search(monkeypatch, options, search_max_iter=40,
                                              search_tol=tol)
    assert factory.options == replace(options, max_iter=40, inactive_rows="rows",
                                      tol=options.tol if tol is None else tol,
                                      half_cycle_solve=SEARCH_HALF_CYCLE,
                                      swing_wrench=SEARCH_SWING_WRENCH)
    assert built == [(20, final_options(options))]


@pytest.mark.parametrize(("own", "final"), [(True, None), (False, None), (True, True),
                                            (False, True), (True, False)])
def test_the_final_planner_takes_final_half_cycle_not_the_options(
    monkeypatch: pytest.MonkeyPatch, own: bool, final: bool | None,
) -> None:
    """The final re-solves' `half_cycle_solve` is `final_half_cycle` (default
    `FINAL_HALF_CYCLE`, on since session 40), whatever the options say (`PlannerOptions`'
    default, on, is the template path's); the coarse solves' is `search_half_cycle`'s."""
    options = PlannerOptions(half_cycle_solve=own)
    kwargs = {} if final is None else {"final_half_cycle": final}
    (factory,), built = _planners_of_a_search(monkeypatch, options, **kwargs)
    final_half = FINAL_HALF_CYCLE if final is None else final
    assert built == [(20, replace(options, half_cycle_solve=final_half,
                                  swing_wrench=FINAL_SWING_WRENCH))]
    assert factory.options.half_cycle_solve is SEARCH_HALF_CYCLE


def test_a_final_planner_that_disagrees_with_final_half_cycle_is_refused_before_any_solve(
    small_quad_planner: GaitPlanner,
) -> None:
    """A final planner passed in must have the final re-solves' `half_cycle_solve` (a planner
    built for the default, half-cycle since session 40, would silently re-solve a
    `final_half_cycle=False` search's candidates on half the knots)."""
    assert small_quad_planner.options.half_cycle_solve is True
    with pytest.raises(PlannerConfigError, match=r"half_cycle_solve=True.*final_half_cycle="
                       r"False: build it with final_options\(\)") as err:
        search_gait(small_quad_planner.robot, 0.2, n_knots=20, planner=small_quad_planner,
                    final_half_cycle=False)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("tol", [0.0, 1.0, -1e-4, math.nan])
def test_a_bad_search_tol_is_one_line_before_any_solve(tol: float) -> None:
    with pytest.raises(PlannerConfigError, match=r"search_tol must be in \(0, 1\)") as err:
        search_gait(robots.load("quad12"), 0.25, search_tol=tol)
    assert "\n" not in str(err.value)


def test_final_tasks_rank_rejected_templates_by_their_plans_cost() -> None:
    """When the coarse check rejected every template, the fallback tries them as candidates are
    ranked (`final_rank`): plan-feasible ones by plan cost, then those with no plan — not in
    template order (session 34: a 10-knot README search wrote the walk at 0.738 before trying
    the trot, which passes at 0.525)."""
    from planner.search.final_phase import FinalPlannerSpec
    from planner.search.gait_search import REJECTED_VIOLATION, final_rank, final_tasks

    robot = robots.load("quad12")
    space = TimingSpace.for_robot(robot)
    own = {name: make_schedule(robot, name) for name in ("walk", "pace", "trot")}
    x_of = {name: space.encode(schedule) for name, schedule in own.items()}
    seeds = {"walk": TimingResult(x_of["walk"], 0.7, False, 0, REJECTED_VIOLATION, True),
             "pace": TimingResult(x_of["pace"], 0.1, False, 0, 1.0, False),
             "trot": TimingResult(x_of["trot"], 0.4, False, 0, REJECTED_VIOLATION, True)}
    assert [final_rank(seeds[n]) for n in own] == [(1, 0.7), (2, math.inf), (1, 0.4)]
    lo, hi = space.bounds()
    sample = TimingResult(0.5 * (lo + hi), 0.3, True, 0, 0.0, True)
    spec = FinalPlannerSpec.new(robot, 30, None, 0.25, None)  # type: ignore[arg-type]
    tasks, _ = final_tasks(spec, space, [(sample.x_projected, sample)], 4,
                           (x_of["trot"], seeds["trot"]), seeds, own)
    assert [t.template for t in tasks] == [None, "trot", "walk", "pace"]


def test_final_tasks_are_the_candidates_then_the_other_templates_by_cost() -> None:
    """The final phase's order: the cheapest usable samples (`final_candidates_of`), then — with
    a check — the seeds by search cost (infeasible last), as their own schedules, skipping one
    identical to a candidate; with nothing usable, CMA's start."""
    from planner.search.final_phase import FinalPlannerSpec
    from planner.search.gait_search import final_tasks

    robot = robots.load("quad12")
    space = TimingSpace.for_robot(robot)
    own = {name: make_schedule(robot, name) for name in ("trot", "walk", "pace")}
    x_of: dict[str, np.ndarray] = {}
    for name, schedule in own.items():
        x = space.encode(schedule)
        assert x is not None
        x_of[name] = x
    seeds = {"trot": TimingResult(x_of["trot"], 0.6, True, 0, 0.0, True),
             "walk": TimingResult(x_of["walk"], 0.5, True, 0, 0.0, True),
             "pace": TimingResult(x_of["pace"], 0.1, False, 0, 1.0, False)}
    lo, hi = space.bounds()
    sample = TimingResult(0.5 * (lo + hi), 0.3, True, 0, 0.0, True)
    spec = FinalPlannerSpec.new(robot, 30, None, 0.25, None)  # type: ignore[arg-type]
    records = [(x_of[n], r) for n, r in seeds.items()] + [(sample.x_projected, sample)]
    tasks, searched = final_tasks(spec, space, records, 2, (x_of["walk"], seeds["walk"]), seeds,
                                  own)
    # candidates: the sample (0.3) and the walk's encoding (0.5); then walk, trot, pace own
    assert [t.template for t in tasks] == [None, None, "walk", "trot", "pace"]
    assert [id(r) for r in searched] == [id(r) for r in (sample, seeds["walk"], seeds["walk"],
                                                         seeds["trot"], seeds["pace"])]
    assert identical_schedules(tasks[2].schedule, own["walk"])
    # the trot's encoding starts its first foot at 0 as the template does: not re-solved twice
    trot_first = [(x_of["trot"], seeds["trot"])]
    tasks, _ = final_tasks(spec, space, trot_first, 2, trot_first[0], seeds, own)
    assert identical_schedules(space.decode(x_of["trot"]), own["trot"])
    assert [t.template for t in tasks] == [None, "walk", "pace"]
    # "compete" skips a template only for a candidate the choice always reads
    # (`templates_read_first`): the trot's encoding is the second candidate, "first" reads one
    from planner.search.gait_search import templates_read_first

    assert templates_read_first("cheapest-of-2", "fallback", 4) is None
    assert templates_read_first("cheapest-of-2", "compete", 4) == 2
    assert templates_read_first("cheapest", "compete", 4) == 4
    trot_second = [(sample.x_projected, sample), (x_of["trot"], seeds["trot"])]
    tasks, _ = final_tasks(spec, space, trot_second, 2, trot_first[0], seeds, own)
    assert [t.template for t in tasks] == [None, None, "walk", "pace"]
    for choice, templates in (("first", "compete"), ("cheapest-of-2", "compete")):
        tasks, _ = final_tasks(spec, space, trot_second, 2, trot_first[0], seeds, own,
                               templates_read_first(choice, templates, 2))
        kept = ["walk", "trot", "pace"] if choice == "first" else ["walk", "pace"]
        assert [t.template for t in tasks] == [None, None, *kept]
    # the templates are solved as the template path plans them, the candidates as the options
    tasks, _ = final_tasks(spec, space, records, 2, (x_of["walk"], seeds["walk"]), seeds, own,
                           template_half_cycle=True, template_swing_wrench="rows")
    assert [t.half_cycle for t in tasks] == [None, None, True, True, True]
    assert [t.swing_wrench for t in tasks] == [None, None, "rows", "rows", "rows"]
    # no check: the candidates only; nothing usable: CMA's start
    tasks, searched = final_tasks(spec, space, records[2:3], 4, (x_of["walk"], seeds["walk"]),
                                  seeds, None)
    assert [t.template for t in tasks] == [None] and searched[0] is seeds["walk"]
    assert identical_schedules(tasks[0].schedule, space.decode(x_of["walk"]))


@pytest.mark.parametrize(("own", "final"), [
    ("rows", None), ("rows", "bounds"), ("bounds", "rows"),
])
def test_final_swing_wrench_reaches_the_final_planner_only(
    monkeypatch: pytest.MonkeyPatch, own: str, final: str | None,
) -> None:
    """`final_swing_wrench` is the final planner's `swing_wrench` (`final_options`; None: the
    options' own); the coarse solves keep theirs (`search_swing_wrench`, here the options')."""
    options = PlannerOptions(swing_wrench=own)
    (factory,), built = _planners_of_a_search(monkeypatch, options, search_swing_wrench=None,
                                              final_swing_wrench=final)
    assert factory.options.swing_wrench == own
    assert built == [(20, final_options(options, final_swing_wrench=final))]
    assert built[0][1].swing_wrench == (final or own)


def test_unknown_final_swing_wrench_or_a_planner_without_it_is_one_line() -> None:
    """An unknown `final_swing_wrench`, or a final planner passed in with another swing wrench
    than the final re-solves', is a one-line error before any solve."""
    with pytest.raises(PlannerConfigError,
                       match=r"final_swing_wrench must be one of rows, bounds.*'free'") as err:
        search_gait(robots.load("quad12"), 0.25, final_swing_wrench="free")
    assert "\n" not in str(err.value)
    stub = SimpleNamespace(n_knots=30,
                           options=final_options(PlannerOptions(), final_swing_wrench="rows"))
    with pytest.raises(PlannerConfigError, match=r"swing_wrench='rows'.*'bounds'.*final_options"):
        search_gait(robots.load("quad12"), 0.25, planner=stub,  # type: ignore[arg-type]
                    final_swing_wrench="bounds")


def test_unknown_search_swing_wrench_is_one_line_before_any_solve() -> None:
    with pytest.raises(PlannerConfigError,
                       match=r"search_swing_wrench must be one of rows, bounds.*'free'") as err:
        search_gait(robots.load("quad12"), 0.25, search_swing_wrench="free")
    assert "\n" not in str(err.value)


def test_the_coarse_search_nlp_has_the_rotor_reserve_rows() -> None:
    """A worker's planner built by the factory (the search's 12-knot NLP, assembled Jacobian)
    has the 2·J·N rotor-reserve rows (ranged, `PlannerOptions.compact_rows`) and the given
    swing clearance."""
    robot = robots.load("quad12")
    options = PlannerOptions(rotor_reserve=0.15, swing_clearance_m=0.018)
    solver = TimingSolverFactory(str(robot.root_dir), 12, 0.2, True, options)()
    sizes = {name: sl.stop - sl.start for name, sl in solver.planner._slices}
    assert sizes["rotor reserve"] == 2 * len(robot.joints) * 12
    assert solver.planner.options.nlp_jacobian == "assembled"
    assert solver.planner.swing_clearance_m == 0.018
    plain = TimingSolverFactory(str(robot.root_dir), 12, 0.2, True)()
    assert "rotor reserve" not in dict(plain.planner._slices)


def test_search_beats_or_matches_the_best_template_and_logs(
    small_quad_planner: GaitPlanner, tmp_path: Path
) -> None:
    robot = small_quad_planner.robot
    rows: list[SearchLogRow] = []
    result = search_gait(robot, 0.2, n_knots=20, max_generations=2, popsize=4, seed=1,
                         planner=small_quad_planner, progress=rows.append)
    assert result.best.feasible
    best_template_cost = result.template_costs[result.best_template]
    assert math.isfinite(best_template_cost) and best_template_cost == result.best_template_cost
    assert result.search_cost <= best_template_cost * (1 + 1e-6)
    assert result.label in templates_for(result.robot)
    # the final solve is at the gait file's resolution; the support term is the winner's
    assert result.best.warm_start.x.size == small_quad_planner.layout.size
    assert result.support_cost == pytest.approx(
        TippingCost.for_robot(robot, DEFAULT_TIPPING_WEIGHT)(result.best.schedule))
    assert result.total_cost == pytest.approx(result.best.cost + result.support_cost)
    assert [r.generation for r in result.log] == [0, 1]
    assert len(rows) == 3  # the seeding notice + one per generation
    assert result.cost_of_transport == pytest.approx(cost_of_transport(result.best, robot))
    assert result.froude == pytest.approx(0.04 / (9.81 * robot.leg_length_m))
    # what gait_search_bench measures: every local solve (templates first), the worker's one
    # build, the full-resolution re-solves and the phases' wall times
    assert len(result.samples) == result.cma.n_local_solves + len(result.template_costs)
    timed = [r for _, r in result.samples if isinstance(r, TimingResult)]
    assert len(timed) == len(result.samples)
    assert sum(r.build_s > 0 for r in timed) == 1  # the serial worker, built once
    assert all(r.solve_s > 0 for r in timed)
    assert any(plan is result.best for plan, _, _ in result.final_solves)
    assert set(result.phase_s) == {"seed", "cma", "final_build", "final"}
    assert result.phase_s["final_build"] == 0 and min(result.phase_s.values()) >= 0
    # this process's CPU in the same phases (the serial executor solves in this process)
    cpu = result.phase_cpu_s
    assert set(cpu) == {"seed", "cma", "final_build", "final", "total"}
    assert cpu["final_build"] == 0 and cpu["cma"] > 0 and min(cpu.values()) >= 0
    assert cpu["total"] >= cpu["seed"] + cpu["cma"] + cpu["final"] - 1e-9
    assert sum(r.cpu_s for r in timed) <= cpu["seed"] + cpu["cma"] + 1e-6
    log = tmp_path / "search.csv"
    write_search_log(result, log)
    text = log.read_text().splitlines()
    assert text[0].startswith("generation,best_cost") and len(text) >= 3
    assert any(line.startswith("# final solve: 20 knots") for line in text)
    # the sweep table/plot writers work on search results
    row = row_from(result)
    assert row.gait_label == result.label and row.feasible
    assert "speed_m_s" in to_csv([row]) and result.label in to_markdown([row])
    paths = write_sweep([row, row], tmp_path / "sweep", robot)
    assert all(p.stat().st_size > 0 for p in paths.values())


def test_a_template_that_passes_at_full_resolution_is_the_fallback(
    small_quad_planner: GaitPlanner,
) -> None:
    """When no searched timing passes the final acceptance, the seeding templates are re-solved
    at full resolution and judged too: the coarse acceptance may reject a template that walks
    at `n_knots` (humanoid20, docs/results/zoo_gaits.md "Session 25"). Here the check passes
    only the full-resolution pace, so the search must return it, accepted."""
    robot = small_quad_planner.robot
    pace = make_schedule(robot, "pace")

    def relative(phases: tuple[float, ...]) -> np.ndarray:  # gait files start at any knot
        return (np.asarray(phases) - phases[0]) % 1.0

    def only_full_pace(gait: Gait) -> _Verdict:
        ok = (gait.n_knots == small_quad_planner.n_knots
              and np.allclose(relative(gait.schedule.touchdown_phase),
                              relative(pace.touchdown_phase))
              and np.allclose(gait.schedule.duty_factor, pace.duty_factor)
              and math.isclose(gait.period_s, pace.period_s))
        return _Verdict(ok, 0.0 if ok else 1.0)

    result = search_gait(robot, 0.2, n_knots=20, max_generations=1, popsize=4, seed=1,
                         planner=small_quad_planner, final_candidates=1,
                         acceptance=lambda: only_full_pace)
    assert result.accepted is True and result.best.feasible
    assert np.allclose(relative(result.best.schedule.touchdown_phase),
                       relative(pace.touchdown_phase))
    assert math.isclose(result.best.schedule.period_s, pace.period_s)
    assert len(result.final_solves) >= 2  # the searched candidate failed, then the templates
    assert result.fallback_template == "pace"
    assert result.final_solves[-1][0] is result.best and result.final_solves[-1][2] is True


def test_the_fallback_plans_the_template_as_the_template_command_does(
    small_quad_planner: GaitPlanner,
) -> None:
    """The search encodes a timing with its first foot at phase 0, so the walk template
    (LF at 0.25) is searched as a phase-rotated copy whose knots fall elsewhere in the cycle —
    another NLP, which can end on another local optimum (bittle8's walk at 0.13 m/s: the
    template passes MuJoCo, the rotated copy turns −7.4°). The fallback must re-solve the
    template's own schedule, the one `gaitsmith plan` would write."""
    robot = small_quad_planner.robot
    walk = make_schedule(robot, "walk")
    space = TimingSpace.for_robot(robot)
    x = space.encode(walk)
    assert x is not None
    encoded = space.decode(x)
    assert not identical_schedules(encoded, walk)  # the premise: the encoding rotates it

    seen: list[ContactSchedule] = []  # the final planner's solves, in order
    solve = small_quad_planner.solve

    def recording_solve(schedule: ContactSchedule, *args: Any, **kwargs: Any) -> PlanResult:
        seen.append(schedule)
        return solve(schedule, *args, **kwargs)

    def only_the_own_walk(gait: Gait) -> _Verdict:  # judges the schedule just solved
        ok = (gait.n_knots == small_quad_planner.n_knots and bool(seen)
              and identical_schedules(seen[-1], walk))
        return _Verdict(ok, 0.0 if ok else 1.0)

    small_quad_planner.solve = recording_solve  # type: ignore[method-assign]
    try:
        result = search_gait(robot, 0.15, n_knots=20, max_generations=1, popsize=4, seed=1,
                             planner=small_quad_planner, final_candidates=1,
                             acceptance=lambda: only_the_own_walk)
    finally:
        del small_quad_planner.solve
    assert result.fallback_template == "walk" and result.accepted is True
    assert identical_schedules(result.best.schedule, walk)
    assert not any(identical_schedules(s, encoded) for s in seen[1:])


def test_identical_schedules_tells_a_phase_rotation_apart() -> None:
    robot = robots.load("quad12")
    walk = make_schedule(robot, "walk")
    assert identical_schedules(walk, walk)
    shifted = replace(walk, touchdown_phase=tuple((p + 0.25) % 1.0
                                                  for p in walk.touchdown_phase))
    assert not identical_schedules(walk, shifted)
    wrapped = replace(walk, touchdown_phase=tuple(1 - 1e-12 if p == 0 else p
                                                  for p in walk.touchdown_phase))
    assert identical_schedules(walk, wrapped)


def test_seed_schedules_are_encoded_and_widen_the_period_box() -> None:
    """A user's schedule seeds the search: encoded in the robot's timing space, the period box
    grows to hold its period (in the workers too), and one the search cannot represent is
    refused by name (duty outside the search's bounds, mirror legs not half a period apart)."""
    from planner.search.gait_search import (
        DUTY_BOUNDS,
        TimingSolverFactory,
        TimingSpace,
        _encoded_seeds,
    )

    robot = robots.load("quad12")
    space = TimingSpace.for_robot(robot, True)
    slow = make_schedule(robot, "walk", period_s=2.0 * space.period_bounds_s[1])
    x = _encoded_seeds(space, {"mine": slow})["mine"]
    assert x[0] == pytest.approx(slow.period_s)
    wide = replace(space, period_bounds_s=(space.period_bounds_s[0], 1.25 * slow.period_s))
    assert wide.decode(x).period_s == pytest.approx(slow.period_s)  # not clipped to the old box
    assert space.decode(x).period_s == pytest.approx(space.period_bounds_s[1])
    factory = TimingSolverFactory(str(robot.root_dir), 12, 0.2, True,
                                  period_bounds_s=wide.period_bounds_s)
    assert factory().space.period_bounds_s == wide.period_bounds_s
    too_long = replace(slow, duty_factor=(DUTY_BOUNDS[1] + 0.05,) * 4)
    with pytest.raises(PlannerConfigError, match="duty factors lie in"):
        _encoded_seeds(space, {"mine": too_long})
    limp = replace(slow, touchdown_phase=(0.0, 0.3, 0.5, 0.8))
    with pytest.raises(PlannerConfigError, match="half a period apart"):
        _encoded_seeds(space, {"mine": limp})

"""The swing feet's wrench fixed by bounds (`PlannerOptions.swing_wrench`)."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.metadata import planner_metadata
from planner.nlp.spacetime import GaitPlanner, PlanResult, SolveBounds
from planner.nlp.swing_wrench import swing_wrench_bounds
from planner.templates import make_schedule


def test_bounds_fix_the_swing_wrench_and_free_only_its_rows(quad_planner: GaitPlanner) -> None:
    pl = quad_planner
    schedule = make_schedule(pl.robot, "walk")
    contact = schedule.contact_matrix(pl.n_knots).astype(bool)
    slices = dict(pl._slices)
    lbg0 = pl._row_lower_bounds(schedule)
    lbx, ubx, lbg = swing_wrench_bounds(pl.layout, pl.model, contact, slices, pl._lbx, pl._ubx,
                                        lbg0)
    n, nf = pl.n_knots, pl.layout.n_feet
    f_lo = pl.layout.view(lbx, "forces").reshape(n, nf, 3)
    f_hi = pl.layout.view(ubx, "forces").reshape(n, nf, 3)
    assert np.all(f_lo[~contact] == 0.0) and np.all(f_hi[~contact] == 0.0)
    base_lo = pl.layout.view(pl._lbx, "forces").reshape(n, nf, 3)
    assert np.array_equal(f_lo[contact], base_lo[contact])  # stance forces untouched
    outside = np.ones(pl.layout.size, dtype=bool)
    outside[pl.layout.block("forces")] = False
    assert np.array_equal(lbx[outside], pl._lbx[outside])  # every other bound untouched
    assert np.array_equal(ubx[outside], pl._ubx[outside])
    freed = np.flatnonzero(lbg != lbg0)
    assert np.all(np.isneginf(lbg[freed]))
    swing_rows = int((~contact).sum())
    assert freed.size == 5 * swing_rows  # 4 friction rows and the swing-force row each
    friction, force = slices["friction"], slices["swing force"]
    in_groups = ((freed >= friction.start) & (freed < friction.stop)) | (
        (freed >= force.start) & (freed < force.stop))
    assert in_groups.all()


def test_bounds_give_the_same_optimum(quad_planner: GaitPlanner) -> None:
    """The feasible set is the same: a trot reaches the rows' optimum (quad12 N = 30: 19 → 16
    iterations, docs/results/planner_speed_init.md; "bounds" is the default since session 42)."""
    assert quad_planner.options.swing_wrench == "bounds"
    rows = GaitPlanner(quad_planner.robot, quad_planner.n_knots,
                       PlannerOptions(swing_wrench="rows"))
    a, b = _trot_optima(rows, quad_planner)
    assert b.iterations < a.iterations


def test_flat_feet_moments_and_cone_rows() -> None:
    robot = robots.load("biped")
    pl = GaitPlanner(robot, 12)
    schedule = make_schedule(robot, "biped_walk")
    contact = schedule.contact_matrix(12).astype(bool)
    slices = dict(pl._slices)
    lbg0 = pl._row_lower_bounds(schedule)
    lbx, ubx, lbg = swing_wrench_bounds(pl.layout, pl.model, contact, slices, pl._lbx, pl._ubx,
                                        lbg0)
    flat = list(pl.model.flat_feet)
    m_lo = pl.layout.view(lbx, "moments").reshape(12, len(flat), 3)
    m_hi = pl.layout.view(ubx, "moments").reshape(12, len(flat), 3)
    swing = ~contact[:, flat]
    assert np.all(m_lo[swing] == 0.0) and np.all(m_hi[swing] == 0.0)
    assert np.all(np.isinf(m_lo[~swing]))
    cone = slices["contact wrench cone"]
    freed = np.flatnonzero(lbg[cone] != lbg0[cone])
    assert freed.size == 16 * int(swing.sum())


def test_bounds_with_the_swing_force_rows_already_bounds(quad_planner: GaitPlanner) -> None:
    """`swing_wrench="bounds"` on top of `compact_rows` with "swing force" (no such rows left):
    the same optimum as the rows."""
    both = GaitPlanner(quad_planner.robot, quad_planner.n_knots,
                       PlannerOptions(swing_wrench="bounds",
                                      compact_rows=("torque envelope", "swing force")))
    assert "swing force" not in dict(both._slices)
    _trot_optima(quad_planner, both)


def _trot_optima(rows: GaitPlanner, bounded: GaitPlanner) -> tuple[PlanResult, PlanResult]:
    """Cold trot solves of both planners: both feasible, the same cost to 1e-4, the bounded
    one's swing forces exactly 0."""
    schedule = make_schedule(rows.robot, "trot")
    a = rows.solve(schedule, 0.25, warm_start=False)
    b = bounded.solve(schedule, 0.25, warm_start=False)
    assert a.feasible and b.feasible
    assert b.cost == pytest.approx(a.cost, rel=1e-4)
    swing = ~schedule.contact_matrix(rows.n_knots).astype(bool)
    assert np.all(b.contact_forces_n[swing] == 0.0)
    return a, b


def test_reports_judge_the_bounds_the_solve_used(quad_planner: GaitPlanner) -> None:
    """`GaitPlanner._result` judges a point against the bounds it is handed, not the built
    ones: a joint limit tightened below the optimum is reported violated where it is, and with
    the swing wrench fixed (its friction rows freed) a swing foot's f_x is no friction
    violation but still an infeasible point."""
    pl = quad_planner
    schedule = make_schedule(pl.robot, "walk")
    done = pl.solve(schedule, 0.25, warm_start=False)
    assert done.feasible, done.message
    p = pl._solver_parameters(schedule, 0.25)
    built = pl._solve_bounds(schedule, "rows")  # every row, the swing feet's friction rows too
    stats = {"return_status": "Solve_Succeeded", "iter_count": 0}

    def result(x: np.ndarray, bounds: SolveBounds) -> PlanResult:
        ws = done.warm_start
        return pl._result(schedule, 0.25, p, {"x": x, "lam_x": ws.lam_x, "lam_g": ws.lam_g,
                                              "f": done.cost}, stats, 0.0, bounds)

    x = done.warm_start.x.copy()
    assert result(x, built).feasible
    knot, joint = 7, 2
    ubx = built.ubx.copy()
    ubx[pl.layout.indices("q")[knot, joint]] = pl.layout.view(x, "q")[knot, joint] - 0.05
    tight = result(x, SolveBounds(built.lbx, ubx, built.lbg, built.ubg))
    assert not tight.feasible and dict(tight.binding)["joint limits"] == pytest.approx(0.05)
    assert f"{pl.robot.joint_names[joint]}@{knot}" in tight.message
    contact = schedule.contact_matrix(pl.n_knots).astype(bool)
    k, foot = (int(i[0]) for i in np.nonzero(~contact))
    pl.layout.view(x, "forces").reshape(pl.n_knots, -1, 3)[k, foot, 0] = 0.01
    assert "friction" in dict(result(x, built).binding)
    fixed = SolveBounds(*swing_wrench_bounds(pl.layout, pl.model, contact, dict(pl._slices),
                                             built.lbx, built.ubx, built.lbg), built.ubg)
    off = result(x, fixed)
    assert not off.feasible and "friction" not in dict(off.binding)
    assert off.max_violation >= 0.01 - 1e-12


def test_solve_bounds_compute_the_contact_matrix_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Swing-force rows as bounds, the swing wrench by bounds and line-capture rows all depend
    on the schedule's contact matrix: `_solve_bounds` computes it once for the three, and its
    bounds are those each computes on its own."""
    bot = robots.load("quad12")
    options = PlannerOptions(compact_rows=("torque envelope", "swing force"),
                             swing_wrench="bounds", line_capture_margin_leg_lengths=0.1)
    pl = GaitPlanner(bot, 12, options)
    schedule = make_schedule(bot, "walk")
    contact = schedule.contact_matrix(pl.n_knots)
    lbx, ubx = pl._variable_bounds(schedule)
    separate = swing_wrench_bounds(pl.layout, pl.model, contact, dict(pl._slices), lbx, ubx,
                                   pl._row_lower_bounds(schedule))
    calls: list[int] = []
    matrix = type(schedule).contact_matrix

    def counted(self: robots.ContactSchedule, n: int) -> np.ndarray:
        calls.append(n)
        return matrix(self, n)

    monkeypatch.setattr(type(schedule), "contact_matrix", counted)
    once = pl._solve_bounds(schedule)
    assert calls == [pl.n_knots]
    for a, b in zip((once.lbx, once.ubx, once.lbg), separate, strict=True):
        assert np.array_equal(a, b)


def test_a_solve_may_hold_the_swing_wrench_its_own_way(quad_planner: GaitPlanner) -> None:
    """`GaitPlanner.solve(swing_wrench=)` overrides the options' own for one solve (the search's
    final re-solves, `search_gait(final_swing_wrench=)`): the bounds are those of a planner
    built with it, and a rows planner asked for "bounds" solves the trot as a bounds planner
    does (the same iterations and cost); an unknown value is a one-line error."""
    pl = GaitPlanner(quad_planner.robot, quad_planner.n_knots, PlannerOptions(swing_wrench="rows"))
    schedule = make_schedule(pl.robot, "trot")
    bounded = quad_planner  # "bounds", the default since session 42
    assert bounded.options.swing_wrench == "bounds"
    for asked_for, built_with in ((pl._solve_bounds(schedule, "bounds"),
                                   bounded._solve_bounds(schedule)),
                                  (bounded._solve_bounds(schedule, "rows"),
                                   pl._solve_bounds(schedule))):
        for field in ("lbx", "ubx", "lbg", "ubg"):
            assert np.array_equal(getattr(asked_for, field), getattr(built_with, field))
    asked = pl.solve(schedule, 0.25, warm_start=False, swing_wrench="bounds")
    built = bounded.solve(schedule, 0.25, warm_start=False)
    assert asked.feasible and built.feasible
    assert asked.iterations == built.iterations and asked.cost == built.cost
    # the gait file says how the written plan was solved, not what the options say
    assert planner_metadata(pl, asked)["solver"]["swing_wrench"] == "bounds"
    assert planner_metadata(bounded, built)["solver"]["swing_wrench"] == "bounds"
    rows = bounded.solve(schedule, 0.25, warm_start=False, swing_wrench="rows")
    assert planner_metadata(bounded, rows)["solver"]["swing_wrench"] == "rows"
    with pytest.raises(PlannerConfigError, match=r"swing_wrench must be one of rows, bounds"):
        pl.solve(schedule, 0.25, warm_start=False, swing_wrench="free")

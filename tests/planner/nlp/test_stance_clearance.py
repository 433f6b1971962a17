"""The stance feet's clearance rows freed per solve (`PlannerOptions.stance_clearance`)."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.stance_clearance import free_stance_clearance
from planner.templates import make_schedule


def test_free_unbounds_exactly_the_clearance_rows_of_stance_pairs(
    quad_planner: GaitPlanner,
) -> None:
    pl = quad_planner
    schedule = make_schedule(pl.robot, "walk")
    contact = schedule.contact_matrix(pl.n_knots).astype(bool)
    slices = dict(pl._slices)
    built = pl._solve_bounds(schedule)
    lbg = free_stance_clearance(slices, contact, built.lbg)
    freed = np.flatnonzero(lbg != built.lbg)
    rows = slices["swing clearance"]
    assert freed.size == int(contact.sum()) > 0
    assert np.all(np.isneginf(lbg[freed])) and np.all(np.isposinf(built.ubg[freed]))
    # knot-major, feet within a knot: the freed rows are the stance (knot, foot) pairs
    assert np.array_equal(freed - rows.start, np.flatnonzero(contact.ravel()))
    free = GaitPlanner(pl.robot, pl.n_knots, PlannerOptions(stance_clearance="free"))
    got = free._solve_bounds(schedule)  # the planner's own per-solve bounds
    assert np.array_equal(got.lbg, lbg)
    assert np.array_equal(got.lbx, built.lbx) and np.array_equal(got.ubg, built.ubg)


def test_the_freed_rows_repeat_the_stance_height_equality(quad_planner: GaitPlanner) -> None:
    """Why freeing them keeps the feasible set: at any point, a stance pair's clearance row
    equals its "stance height" row (which must be 0), so it adds no condition."""
    pl = quad_planner
    schedule = make_schedule(pl.robot, "gallop_rotary")
    contact = schedule.contact_matrix(pl.n_knots).astype(bool).ravel()
    p = pl._solver_parameters(schedule, 0.25)
    rng = np.random.default_rng(3)
    x = pl.primal_start(np.zeros(pl.layout.size)).x
    for _ in range(3):
        x = np.clip(x + 0.05 * rng.standard_normal(x.size), pl._lbx, pl._ubx)
        g = np.asarray(pl._evaluate(x, p)[0]).ravel()
        slices = dict(pl._slices)
        clearance, height = g[slices["swing clearance"]], g[slices["stance height"]]
        assert np.abs(clearance[contact]).max() > 1e-3  # a point off the ground: not trivial
        np.testing.assert_allclose(clearance[contact], height[contact], rtol=0, atol=1e-12)
        swing = ~contact
        assert not np.allclose(clearance[swing], height[swing])  # swing rows differ


def test_free_reaches_the_rows_optimum_and_meets_every_built_row(
    hex_planner: GaitPlanner,
) -> None:
    """hex18's tripod (N = 30, the half-cycle solve): the same optimum to 1e-4, and the point
    "free" returns meets the clearance rows it did not hand IPOPT (to IPOPT's tolerance)."""
    free = GaitPlanner(hex_planner.robot, hex_planner.n_knots,
                       PlannerOptions(stance_clearance="free"))
    schedule = make_schedule(hex_planner.robot, "tripod")
    a = hex_planner.solve(schedule, 0.15, warm_start=False)
    b = free.solve(schedule, 0.15, warm_start=False)
    assert a.feasible and b.feasible
    assert b.cost == pytest.approx(a.cost, rel=1e-4)
    p = free._solver_parameters(schedule, 0.15)
    g = np.asarray(free._evaluate(b.warm_start.x, p)[0]).ravel()
    rows = dict(free._slices)["swing clearance"]
    assert g[rows].min() >= free._lbg[rows].min() - 1e-5


def test_no_clearance_rows_leaves_the_bounds() -> None:
    lbg = np.zeros(4)
    out = free_stance_clearance({"stance height": slice(0, 4)}, np.ones((2, 2)), lbg)
    assert np.array_equal(out, lbg)
    with pytest.raises(ValueError, match="rows for"):
        free_stance_clearance({"swing clearance": slice(0, 3), "stance height": slice(3, 7)},
                              np.ones((2, 2)), np.zeros(7))


def test_unknown_value_is_one_line() -> None:
    with pytest.raises(PlannerConfigError, match="stance_clearance='x'"):
        PlannerOptions(stance_clearance="x")


def test_biped_flat_feet_have_the_rows_too() -> None:
    """The flat feet's point rows are the same groups: "free" unbounds their stance pairs."""
    bot = robots.load("biped")
    pl = GaitPlanner(bot, 12, PlannerOptions(stance_clearance="free"))
    schedule = make_schedule(bot, "biped_walk")
    contact = schedule.contact_matrix(12).astype(bool)
    got = pl._solve_bounds(schedule).lbg[dict(pl._slices)["swing clearance"]]
    assert np.array_equal(np.isneginf(got), contact.ravel())

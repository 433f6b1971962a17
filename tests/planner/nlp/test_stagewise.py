"""The stage-wise NLP (planner.nlp.stagewise) is the planner's NLP, row for row."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import build_groups, knot_quantities
from planner.nlp.costs import cost_terms, weighted_objective
from planner.nlp.diagnostics import FEASIBILITY_TOL
from planner.nlp.model import RobotModel
from planner.nlp.stagewise import build_stagewise, stage_bounds
from planner.nlp.variables import (
    Layout,
    initial_guess,
    make_symbols,
    parameter_vector,
    variable_bounds,
)
from planner.templates import make_schedule

N_KNOTS = 8


def _planner_nlp(model: RobotModel, layout: Layout, options: PlannerOptions) -> tuple[
    ca.Function, np.ndarray, np.ndarray
]:
    sym = make_symbols(layout)
    kq = knot_quantities(model, sym, N_KNOTS)
    groups = build_groups(model, sym, kq, N_KNOTS, options)
    f = weighted_objective(cost_terms(model, sym, kq, N_KNOTS), options.weights)
    g = ca.vertcat(*[grp.expr for grp in groups])
    lbg = np.concatenate([grp.lb for grp in groups])
    ubg = np.concatenate([grp.ub for grp in groups])
    return ca.Function("planner_nlp", [sym.x, sym.p], [f, g]), lbg, ubg


@pytest.mark.parametrize(("robot_name", "gait", "speed"), [("quad12", "trot", 0.25),
                                                           ("hex18", "tripod", 0.15)])
def test_stage_rows_are_the_planner_rows_at_any_point(robot_name: str, gait: str,
                                                      speed: float) -> None:
    """At an arbitrary point (not feasible: every row has some value) the stage-wise NLP has the
    planner's objective, exactly the planner's constraint rows with their bounds, and zeros on
    the rows it adds (gap-closing dynamics, wrap-around copies), which hold as equalities."""
    robot = robots.load(robot_name)
    model = RobotModel(robot)
    options = PlannerOptions(normal_force_rate_weights_per_t0=None,  # no stage-wise form
                             servo_goal_form="direct")  # goals: a stage state already
    layout = Layout(N_KNOTS, model.n_joints, model.n_feet)
    planner_nlp, lbg, ubg = _planner_nlp(model, layout, options)
    schedule = make_schedule(robot, gait)
    p = parameter_vector(schedule, N_KNOTS, speed, options.swing_clearance_for(
        robot.leg_length_m))
    rng = np.random.default_rng(3)
    x = initial_guess(layout, model, schedule) + 0.05 * rng.standard_normal(layout.size)
    f_ref, g_ref = (np.asarray(v).ravel() for v in planner_nlp(x, p))

    sw = build_stagewise(model, N_KNOTS, options, layout)
    w = np.asarray(sw.to_stage(x, p)).ravel()
    np.testing.assert_array_equal(w[sw.from_planner_index], x)
    f_st, g_st = (np.asarray(v).ravel() for v in ca.Function(
        "stage_nlp", [sw.w, sw.p], [sw.f, sw.g])(w, p))
    assert f_st[0] == pytest.approx(f_ref[0], rel=1e-12)

    n_added = g_st.size - g_ref.size
    assert n_added == N_KNOTS * sw.stage.nx + 2 * sw.stage.n_core + 2
    # the added rows are equalities at 0; the rest are the planner's rows and bounds
    added = np.zeros(n_added)
    values = np.sort(np.concatenate([g_ref, added]))
    np.testing.assert_allclose(np.sort(g_st), values, atol=1e-9)
    assert sw.lbg.size == g_st.size and sw.equality.count(True) == int(
        np.sum(lbg == ubg)) + n_added
    bounds = sorted(zip(lbg, ubg, strict=True)) + [(0.0, 0.0)] * n_added
    assert sorted(zip(sw.lbg, sw.ubg, strict=True)) == sorted(bounds)
    # the planner's variable bounds sit on its own variables, copies are free
    lbx, ubx = variable_bounds(layout, model, options)
    lo, hi = stage_bounds(sw, lbx, ubx)
    assert np.isfinite(lo).sum() == np.isfinite(lbx).sum()
    assert np.isfinite(hi).sum() == np.isfinite(ubx).sum()
    # stage structure: x₀ u₀ … x_N, one block of rows per stage
    assert sum(sw.nx) + sum(sw.nu) == sw.size
    assert sum(sw.nx[1:]) + sum(sw.ng) == g_st.size


def test_a_row_over_every_knot_is_refused() -> None:
    robot = robots.load("quad12")
    model = RobotModel(robot)
    options = PlannerOptions(mean_footprint_leg_lengths=0.2, servo_goal_form="direct")
    layout = Layout(N_KNOTS, model.n_joints, model.n_feet)
    with pytest.raises(PlannerConfigError, match="mean_footprint"):
        build_stagewise(model, N_KNOTS, options, layout)
    rate = PlannerOptions(normal_force_rate_weights_per_t0=5.0, servo_goal_form="direct")
    with pytest.raises(PlannerConfigError, match="normal_force_rate"):
        build_stagewise(model, N_KNOTS, rate, layout)


@pytest.mark.slow
def test_fatrop_planner_keeps_ipopts_optimum() -> None:
    """End to end (stage maps, bounds, FATROP's manual structure, the verdict on the planner's
    NLP): started at IPOPT's optimum, a few FATROP iterations stay on it."""
    from planner.nlp.fatrop_solver import FatropPlanner
    from planner.nlp.metadata import planner_metadata
    from planner.nlp.spacetime import GaitPlanner

    robot = robots.load("quad12")
    schedule = make_schedule(robot, "trot")
    no_rate = PlannerOptions(normal_force_rate_weights_per_t0=None,  # no stage-wise form
                             servo_goal_form="direct")
    ref = GaitPlanner(robot, N_KNOTS, no_rate).solve(schedule, 0.25, warm_start=False)
    assert ref.feasible
    fatrop = FatropPlanner(robot, N_KNOTS, PlannerOptions(max_iter=3,
                                                          normal_force_rate_weights_per_t0=None),
                           {"mu_init": 1e-6, "bound_push": 1e-8, "bound_frac": 1e-8})
    res = fatrop.solve(schedule, 0.25, warm_start=ref.warm_start)
    assert res.iterations <= 4  # FATROP counts the iteration it stops at
    # every row and bound of the planner's NLP met to the planner's own tolerance (FATROP did not
    # stop on its test, so the verdict stays "not feasible": see docs/results/planner_speed_fatrop)
    assert res.max_violation <= FEASIBILITY_TOL
    assert not res.feasible and res.status.startswith("fatrop_return_flag")
    assert abs(res.cost - ref.cost) <= 1e-4 * abs(ref.cost)
    # FATROP solves with the built bounds: asked for "bounds", the swing wrench is still the rows'
    asked = fatrop.solve(schedule, 0.25, warm_start=ref.warm_start, swing_wrench="bounds")
    assert planner_metadata(fatrop, asked)["solver"]["swing_wrench"] == "rows"

"""How the NLP uses the knot function (issue #16, docs/results/planner_speed_threads.md): the
objective's own ω function, the base x, y outside the knot, the Hessian skipping J when its seeds
are zero — same values and derivatives as before, fewer knot evaluations."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import (
    knot_function,
    knot_output_rows,
    knot_quantities,
    omega_function,
    stacked_knot,
)
from planner.nlp.model import RobotModel
from planner.nlp.solver_cache import with_knot_derivatives
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import Layout, make_symbols
from tests.planner.nlp.toy_knot import toy_knot
from tests.zoo.fixtures import ZOO


def _called(function: ca.Function) -> list[str]:
    return [
        function.instruction_MX(k).which_function().name()
        for k in range(function.n_instructions())
        if function.instruction_id(k) == ca.OP_CALL
    ]


def test_omega_function_is_the_knot_w_output() -> None:
    model = RobotModel(robots.load("quad12"))
    knot, omega = knot_function(model), omega_function(model)
    rng = np.random.default_rng(1)
    args = [rng.normal(size=knot.size_in(i)) for i in range(knot.n_in())]
    w = knot(*args)[knot.index_out("w")]
    b, bd, yaw_rate = args[0], args[2], args[knot.index_in("yaw_rate")]
    np.testing.assert_array_equal(np.asarray(omega(b[3:], bd[3:], yaw_rate)), np.asarray(w))


def test_objective_gradient_does_not_evaluate_the_knot() -> None:
    planner = GaitPlanner(robots.load("quad12"), 8)
    for name in ("nlp_grad_f", "nlp_f"):
        called = _called(planner._solver.get_function(name))
        assert called and not any(c.endswith("_knot") for c in called), (name, called)


@pytest.mark.parametrize("linear", [True, False])
def test_knot_hessian_skips_the_jacobian_only_when_its_seeds_are_zero(linear: bool) -> None:
    """A Lagrangian linear in the knot's outputs gives zero Δλ seeds (J is not evaluated); a
    nonlinear one does not: both equal CasADi's own AD of the plain knot."""
    plain = toy_knot()
    custom = with_knot_derivatives(plain).knot

    def hessian(knot: ca.Function) -> ca.Function:
        x, y, lam = ca.MX.sym("X", 4, 6), ca.MX.sym("Y", 2, 6), ca.MX.sym("L", 3, 6)
        a, b = knot.map(6)(x, y)
        v = ca.vertcat(ca.vec(x), ca.vec(y))
        lagrangian = ca.dot(ca.vec(lam[:2, :]), ca.vec(a)) + ca.dot(lam[2, :], b)
        if not linear:
            lagrangian += ca.sumsqr(b)
        return ca.Function("h", [x, y, lam], [ca.hessian(lagrangian, v)[0]])

    rng = np.random.default_rng(2)
    args = rng.normal(size=(4, 6)), rng.normal(size=(2, 6)), rng.normal(size=(3, 6))
    np.testing.assert_allclose(
        np.asarray(hessian(custom)(*args)), np.asarray(hessian(plain)(*args)),
        rtol=1e-12, atol=1e-12,
    )


@pytest.mark.parametrize("robot_name", ["quad12", "hex18", "biped"])
def test_knot_rows_do_not_depend_on_the_base_x_y_and_its_feet_move_with_them(
    robot_name: str,
) -> None:
    knot = knot_function(RobotModel(robots.load(robot_name)))
    rng = np.random.default_rng(4)
    args = [rng.normal(size=knot.size_in(i)) for i in range(knot.n_in())]
    at_origin = [a.copy() for a in args]
    at_origin[0][:2] = 0.0
    moved, origin = knot(*args), knot(*at_origin)
    for i in range(knot.n_out()):
        got, ref = np.asarray(origin[i]), np.asarray(moved[i])
        if knot.name_out(i) == "feet":
            got = got.reshape(-1, 3) + np.r_[args[0][:2].ravel(), 0.0]
            ref = ref.reshape(-1, 3)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12, err_msg=knot.name_out(i))


def test_quad12_nlp_jacobian_evaluates_every_knot_jacobian_once() -> None:
    """66 → 64 knot inputs that are NLP variables: one batch of 64 forward directions (CasADi's
    AD Jacobian; the assembled one evaluates J once whatever the count: test_lifted.py)."""
    planner = GaitPlanner(robots.load("quad12"), 8, PlannerOptions(nlp_jacobian="ad"))
    called = _called(planner._solver.get_function("nlp_jac_g"))
    assert [c for c in called if c.startswith("fwd")] == ["fwd64_map8_knot"]


@pytest.mark.parametrize("robot_name", ["quad12", "hex18", "humanoid20"])
def test_stacked_knot_is_the_knot_and_the_nlp_sees_the_same_quantities(robot_name: str) -> None:
    """`stacked_knot` (one input, one output: a faster IPOPT construction, session 26) gives the
    plain knot's outputs bit for bit, and `knot_quantities` the same NLP quantities with it."""
    robot = robots.load(ZOO / robot_name if robot_name == "humanoid20" else robot_name)
    model = RobotModel(robot)
    plain = knot_function(model)
    stacked = stacked_knot(plain)
    rows = knot_output_rows(model)
    assert rows == tuple(plain.size1_out(i) for i in range(plain.n_out()))
    assert stacked.n_in() == stacked.n_out() == 1 and stacked.size1_out(0) == sum(rows)
    rng = np.random.default_rng(5)
    args = [rng.normal(size=plain.size_in(i)) for i in range(plain.n_in())]
    want = np.concatenate([np.asarray(y).ravel() for y in plain(*args)])
    got = np.asarray(stacked(np.concatenate([a.ravel() for a in args]))).ravel()
    np.testing.assert_array_equal(got, want)
    n = 8
    layout = Layout(n, model.n_joints, model.n_feet, len(model.flat_feet))
    sym = make_symbols(layout)
    quantities = []
    for knot in (plain, stacked):
        kq = knot_quantities(model, sym, n, knot)
        values = [kq.base_rows, kq.tau_rnea_nm, kq.feet_m, kq.body_z_m, kq.omega_world]
        quantities.append(ca.Function("q", [sym.x, sym.p], values))
    x, p = rng.normal(size=sym.x.shape), rng.normal(size=sym.p.shape)
    for a, b in zip(quantities[0](x, p), quantities[1](x, p), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))

"""The assembled Lagrangian Hessian (`planner.nlp.assembled_hessian`), issue #16: the same Hessian
as CasADi's AD from one knot H per knot (docs/results/planner_speed.md, session 29)."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.assembled_hessian import assembled_hessian
from planner.nlp.assembled_jacobian import KnotCall
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import stacked_knot
from planner.nlp.solver_cache import jacobian_and_hessian
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import parameter_vector
from planner.templates import make_schedule
from tests.planner.nlp.toy_knot import toy_knot

N_TOY = 3


def _toy_nlp(square_inputs: bool = False) -> tuple[ca.MX, ca.MX, ca.MX, ca.MX, KnotCall]:
    """A small NLP around the toy knot, mapped over `N_TOY` knots: inputs affine in x with a
    parameter coefficient and one input broadcast to every knot; f and g use the knot's outputs
    nonlinearly and times x (so every block of ∇²_zz L̃ is non-zero). `square_inputs`: the
    first input is x² instead (not affine)."""
    n = N_TOY
    x, p = ca.MX.sym("x", 6 * n + 2), ca.MX.sym("p", 2)
    first = ca.reshape(x[: 4 * n], 4, n)
    first = first * first if square_inputs else first * p[0] + 1
    shared = x[-2:]  # one column: every knot's second input
    call_u = ca.vertcat(first, ca.repmat(shared, 1, n))
    y = stacked_knot(toy_knot()).map(n)(call_u)
    a, b = ca.vertsplit(y, [0, 2, 3])
    f = p[1] * ca.sumsqr(x) + ca.sum1(ca.sin(ca.vec(a))) + ca.dot(x[4 * n : 5 * n], ca.vec(b))
    g = ca.vertcat(ca.vec(a) * x[: 2 * n], ca.vec(b) ** 2, x[1] * x[2], ca.vec(a))
    return x, p, f, g, KnotCall((first, shared), (a, b))


def test_toy_assembled_hessian_is_casadis_own() -> None:
    x, p, f, g, call = _toy_nlp()
    jac, hess = jacobian_and_hessian(toy_knot())
    assembled = assembled_hessian(x, p, f, g, [(call, jac, hess)], N_TOY)
    _assert_casadis_hessian(assembled, x, p, f, g, seed=1)
    assert assembled.sparsity_out(0).is_triu()


def _assert_casadis_hessian(assembled: ca.Function, x: ca.MX, p: ca.MX, f: ca.MX, g: ca.MX,
                            seed: int) -> None:
    """`assembled` gives triu(∇²ₓₓ(σf + λᵀg)) of CasADi's AD at three random points."""
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", g.shape[0])
    want = ca.Function(
        "ad", [x, p, lam_f, lam_g], [ca.triu(ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0])]
    )
    rng = np.random.default_rng(seed)
    for _ in range(3):
        args = (rng.normal(size=x.shape[0]), rng.normal(size=2), rng.normal(),
                rng.normal(size=g.shape[0]))
        got, ref = (np.asarray(fn(*args).full()) for fn in (assembled, want))
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_toy_hessian_at_the_knots_read_is_casadis_own() -> None:
    """`knots_read_only`: rows and an objective that read the outputs of knots 0 and 1 only
    (the half-cycle solve's kept rows) evaluate the knot, H and J at those two knots (maps of
    2) and give CasADi's AD Hessian, the x–Y and Y–Y terms included."""
    x, p, _, _, call = _toy_nlp()
    call = KnotCall(call.inputs, call.outputs, stacked_knot(toy_knot()))
    a, b = call.outputs
    f = p[1] * ca.sumsqr(x) + ca.sin(a[0, 0] * b[0, 1]) + x[3] * a[1, 1]
    kept = ca.vertcat(a[0, 0] * x[0], a[1, 1] * x[1] ** 2, ca.cos(b[0, 1]) * a[0, 1],
                      x[1] * x[2])
    jac, hess = jacobian_and_hessian(toy_knot())
    read = assembled_hessian(x, p, f, kept, [(call, jac, hess)], N_TOY, knots_read_only=True)
    called = read.get_function()
    assert [c for c in called if "knot" in c] == ["map2_H_knot", "map2_J_knot", "map2_knot"]
    _assert_casadis_hessian(read, x, p, f, kept, seed=4)


def test_toy_inputs_not_affine_in_x_are_refused() -> None:
    x, p, f, g, call = _toy_nlp(square_inputs=True)
    jac, hess = jacobian_and_hessian(toy_knot())
    with pytest.raises(PlannerConfigError, match="nlp_hessian"):
        assembled_hessian(x, p, f, g, [(call, jac, hess)], N_TOY)


def _hessians(robot_name: str, gait: str) -> tuple[GaitPlanner, np.ndarray, np.ndarray, tuple]:
    robot = robots.load(robot_name)
    ad = GaitPlanner(robot, 8, PlannerOptions(nlp_hessian="ad"))
    assembled = GaitPlanner(robot, 8, PlannerOptions(nlp_hessian="assembled"))
    p = parameter_vector(make_schedule(robot, gait), 8, 0.2, ad.swing_clearance_m, 0.05, 0.1)
    rng = np.random.default_rng(3)
    args = (rng.normal(scale=0.2, size=ad.layout.size), p, 0.7, rng.normal(size=ad._lbg.size))
    f_ad, f_as = (pl._solver.get_function("nlp_hess_l") for pl in (ad, assembled))
    assert f_as.sparsity_out(0).nnz() == f_ad.sparsity_out(0).nnz()
    want, got = (np.asarray(fn(*args).full()) for fn in (f_ad, f_as))
    return assembled, want, got, args


@pytest.mark.parametrize(("robot_name", "gait"), [("quad12", "trot"), ("biped", "biped_walk")])
def test_assembled_hessian_is_casadis_own(robot_name: str, gait: str) -> None:
    """Same values and sparsity as CasADi's AD of the NLP at a random point; the biped's flat
    feet use the knot's outputs nonlinearly (the x–Y and Y–Y terms)."""
    _, want, got, _ = _hessians(robot_name, gait)
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())


def test_assembled_hessian_is_the_derivative_of_the_assembled_gradient() -> None:
    """H·v against central differences of ∇L = σ∇f + Jᵀλ (the assembled Jacobian's)."""
    planner, _, hess, (x, p, sigma, lam) = _hessians("quad12", "trot")
    full = np.triu(hess) + np.triu(hess, 1).T
    grad_f = planner._solver.get_function("nlp_grad_f")
    jac_g = planner._solver.get_function("nlp_jac_g")

    def grad_l(at: np.ndarray) -> np.ndarray:
        jac = np.asarray(jac_g(at, p)[1].full())
        return sigma * np.asarray(grad_f(at, p)[1]).ravel() + jac.T @ lam

    rng = np.random.default_rng(7)
    step = 1e-6
    for _ in range(3):
        v = rng.normal(size=x.size)
        fd = (grad_l(x + step * v) - grad_l(x - step * v)) / (2 * step)
        np.testing.assert_allclose(full @ v, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_assembled_hessian_calls_one_knot_hessian_map_and_no_knot_derivative() -> None:
    planner = GaitPlanner(robots.load("quad12"), 8, PlannerOptions(nlp_hessian="assembled"))
    called = planner._solver.get_function("nlp_hess_l").get_function()
    # the knot's H is "H_knot", or "gaitsmith_H_<hash>" when the test cache (a developer's own
    # $GAITSMITH_CACHE) holds the compiled knot derivatives
    h_maps = [c for c in called if c.endswith("H_knot") or "gaitsmith_H_" in c]
    assert len(h_maps) == 1 and h_maps[0].startswith("map8_"), called
    assert not [c for c in called if c.endswith("_knot") and c.startswith(("fwd", "adj"))]


def test_options_are_checked() -> None:
    with pytest.raises(PlannerConfigError, match="nlp_hessian"):
        PlannerOptions(nlp_hessian="exact")


def test_assembled_hessian_reaches_the_ad_optimum() -> None:
    robot = robots.load("quad12")
    schedule = make_schedule(robot, "trot")
    ad = GaitPlanner(robot, 8, PlannerOptions(nlp_hessian="ad")).solve(schedule, 0.2)
    options = replace(PlannerOptions(), nlp_hessian="assembled")
    assembled = GaitPlanner(robot, 8, options).solve(schedule, 0.2)
    assert ad.feasible and assembled.feasible
    assert assembled.cost == pytest.approx(ad.cost, rel=1e-6)

"""The assembled constraint Jacobian (`planner.nlp.assembled_jacobian`), issue #16: the same
Jacobian as CasADi's AD from one knot J per knot (docs/results/planner_speed_lifted.md)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.assembled_jacobian import KnotCall, assembled_jacobian, at_read_knots
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import stacked_knot
from planner.nlp.solver_cache import jacobian_and_hessian
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import parameter_vector
from planner.templates import make_schedule
from tests.planner.nlp.toy_knot import toy_knot


def _jacobian(planner: GaitPlanner, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.asarray(planner._solver.get_function("nlp_jac_g")(x, p)[1].full())


@pytest.mark.parametrize("robot_name", ["quad12", "biped"])
def test_assembled_jacobian_is_casadis_own(robot_name: str) -> None:
    """Same values and sparsity as CasADi's AD of the NLP, at a random point; the biped's flat
    feet use the knot's outputs nonlinearly, so ∂G/∂Y depends on Y there."""
    robot = robots.load(robot_name)
    ad = GaitPlanner(robot, 8, PlannerOptions(nlp_jacobian="ad"))
    assembled = GaitPlanner(robot, 8, PlannerOptions(nlp_jacobian="assembled"))
    schedule = make_schedule(robot, "biped_walk" if robot_name == "biped" else "trot")
    p = parameter_vector(schedule, 8, 0.2, ad.swing_clearance_m, 0.05, 0.1)
    rng = np.random.default_rng(3)
    x = rng.normal(scale=0.2, size=ad.layout.size)
    f_ad, f_as = (pl._solver.get_function("nlp_jac_g") for pl in (ad, assembled))
    assert f_as.sparsity_out(1).nnz() == f_ad.sparsity_out(1).nnz()
    want, got = _jacobian(ad, x, p), _jacobian(assembled, x, p)
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())
    np.testing.assert_array_equal(
        np.asarray(f_as(x, p)[0]).ravel(), np.asarray(f_ad(x, p)[0]).ravel()
    )


def test_toy_jacobian_at_the_knots_read_is_casadis_own() -> None:
    """`knots_read_only`: rows that read the outputs of knots 1 and 3 of 4 evaluate the knot and
    its J there only (maps of 2) and give CasADi's AD Jacobian and the same row values;
    `at_read_knots` gives those rows the same values from the same two knots."""
    n = 4
    x, p = ca.MX.sym("x", 4 * n + 2), ca.MX.sym("p")
    first = ca.reshape(x[: 4 * n], 4, n) * p + 1
    shared = x[-2:]  # one column: every knot's second input
    knot = stacked_knot(toy_knot())
    y = knot.map(n)(ca.vertcat(first, ca.repmat(shared, 1, n)))
    a, b = ca.vertsplit(y, [0, 2, 3])
    call = KnotCall((first, shared), (a, b), knot)
    rows = ca.vertcat(a[0, 1] * x[0], ca.sin(b[0, 3]) + a[1, 3] * a[0, 1], x[2] * x[5])
    jac, _ = jacobian_and_hessian(toy_knot())
    read = assembled_jacobian(x, p, rows, call, jac, n, knots_read_only=True)
    assert [c for c in read.get_function() if "knot" in c] == ["map2_J_knot", "map2_knot"]
    (evaluated,) = at_read_knots([rows], call, n)
    want = ca.Function("ad", [x, p], [rows, ca.jacobian(rows, x)])
    by_read = ca.Function("read", [x, p], [evaluated])
    assert [c for c in by_read.get_function() if "knot" in c] == ["map2_knot"]
    rng = np.random.default_rng(6)
    for _ in range(3):
        args = (rng.normal(size=x.shape[0]), rng.normal())
        (g_ref, j_ref), (g_got, j_got) = want(*args), read(*args)
        np.testing.assert_array_equal(np.asarray(g_got), np.asarray(g_ref))
        np.testing.assert_array_equal(np.asarray(by_read(*args)), np.asarray(g_ref))
        np.testing.assert_allclose(np.asarray(j_got.full()), np.asarray(j_ref.full()),
                                   rtol=1e-12, atol=1e-12)


def _called(function: ca.Function) -> list[str]:
    return [
        function.instruction_MX(k).which_function().name()
        for k in range(function.n_instructions())
        if function.instruction_id(k) == ca.OP_CALL
    ]


@pytest.mark.parametrize("robot_name", ["quad12", "hex18"])
def test_assembled_jacobian_evaluates_every_knot_jacobian_once(robot_name: str) -> None:
    """On hex18 (88 knot inputs) CasADi's AD evaluates J twice (fwd64 and one more batch);
    assembled: one map of J and no forward derivative of the knot, on any robot."""
    robot = robots.load(robot_name)
    planner = GaitPlanner(robot, 8)
    called = _called(planner._solver.get_function("nlp_jac_g"))
    assert not [c for c in called if c.startswith("fwd")], called
    assert [c for c in called if c.endswith("J_knot")] == ["map8_J_knot"], called
    if robot_name == "hex18":
        ad = GaitPlanner(robot, 8, PlannerOptions(nlp_jacobian="ad"))
        fwd = [c for c in _called(ad._solver.get_function("nlp_jac_g")) if c.startswith("fwd")]
        assert len(fwd) == 2 and fwd[0].startswith("fwd64_"), fwd


def test_options_are_checked() -> None:
    with pytest.raises(PlannerConfigError, match="nlp_jacobian"):
        PlannerOptions(nlp_jacobian="exact")


def test_assembled_jacobian_is_the_default_with_knot_derivatives_only() -> None:
    robot = robots.load("quad12")
    assert GaitPlanner(robot, 8)._jac_g is not None
    assert GaitPlanner(robot, 8, PlannerOptions(nlp_jacobian="ad"))._jac_g is None
    # the expanded NLP differentiates its own SX
    assert GaitPlanner(robot, 8, PlannerOptions(derivatives="expanded"))._jac_g is None


def test_assembled_jacobian_with_threaded_knots() -> None:
    """`knot_threads` > 1: the knots' map is threaded, the assembled J map serial; the same
    Jacobian as the serial AD one."""
    robot = robots.load("quad12")
    ad = GaitPlanner(robot, 8, PlannerOptions(nlp_jacobian="ad"))
    threaded = GaitPlanner(robot, 8, PlannerOptions(knot_threads=2))
    p = parameter_vector(make_schedule(robot, "trot"), 8, 0.25, ad.swing_clearance_m)
    x = np.random.default_rng(5).normal(scale=0.2, size=ad.layout.size)
    want, got = _jacobian(ad, x, p), _jacobian(threaded, x, p)
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())

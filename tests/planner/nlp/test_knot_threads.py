"""The knot function on threads (`PlannerOptions.knot_threads`, issue #16,
docs/results/planner_speed_threads.md): same values and derivatives as the serial map."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import mapped_knots
from planner.nlp.solver_cache import used_directions, with_knot_derivatives
from planner.nlp.spacetime import GaitPlanner
from tests.planner.nlp.toy_knot import toy_knot


def _mapped_derivatives(mapped: ca.Function, n: int) -> ca.Function:
    x, y, lam = ca.MX.sym("X", 4, n), ca.MX.sym("Y", 2, n), ca.MX.sym("L", 3, n)
    a, b = mapped(x, y)
    v = ca.vertcat(ca.vec(x), ca.vec(y))
    lagrangian = ca.dot(ca.vec(lam[:2, :]), ca.vec(a)) + ca.dot(lam[2, :], b) + ca.sumsqr(a)
    return ca.Function(
        "derivs", [x, y, lam], [ca.jacobian(ca.vertcat(ca.vec(a), ca.vec(b)), v),
                                ca.hessian(lagrangian, v)[0]]
    )


@pytest.mark.parametrize(("threads", "name"), [
    (2, "threadmap2_map6_knot"), (4, "threadmap4_map3_knot"), (5, "threadmap4_map3_knot"),
    (12, "threadmap12_knot"), (13, "threadmap12_knot"),
])
def test_threaded_map_has_the_serial_derivatives(threads: int, name: str) -> None:
    knot = with_knot_derivatives(toy_knot()).knot
    rng = np.random.default_rng(5)
    args = rng.normal(size=(4, 12)), rng.normal(size=(2, 12)), rng.normal(size=(3, 12))
    serial = _mapped_derivatives(mapped_knots(knot, 12), 12)(*args)
    threaded_map = mapped_knots(knot, 12, threads)
    assert threaded_map.name() == name  # equal chunks: a divisor of 12
    threaded = _mapped_derivatives(threaded_map, 12)(*args)
    for ref, got in zip(serial, threaded, strict=True):
        assert got.sparsity() == ref.sparsity()
        np.testing.assert_allclose(np.asarray(got), np.asarray(ref), rtol=1e-12, atol=1e-12)


def test_threaded_planner_has_the_serial_nlp_derivatives() -> None:
    robot = robots.load("quad12")
    # CasADi's AD Jacobian (the default assembled one evaluates J serially: test_lifted.py) and
    # AD Hessian (it calls the threaded maps' second-order directions)
    serial = GaitPlanner(robot, 8, PlannerOptions(nlp_jacobian="ad", nlp_hessian="ad"))
    threaded = GaitPlanner(
        robot, 8, PlannerOptions(knot_threads=2, nlp_jacobian="ad", nlp_hessian="ad"))
    rng = np.random.default_rng(0)
    for name in ("nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l"):
        ref_fn = serial._solver.get_function(name)
        got_fn = threaded._solver.get_function(name)
        args = [rng.normal(size=ref_fn.size_in(i)) for i in range(ref_fn.n_in())]
        for ref, got in zip(ref_fn(*args) if ref_fn.n_out() > 1 else [ref_fn(*args)],
                            got_fn(*args) if got_fn.n_out() > 1 else [got_fn(*args)],
                            strict=True):
            assert got.sparsity() == ref.sparsity(), name
            np.testing.assert_allclose(
                np.asarray(got), np.asarray(ref), rtol=1e-9, atol=1e-9, err_msg=name
            )
    # the derivative directions of the threaded maps are found (saved for the next build)
    forward, second = used_directions(threaded._solver, "knot")
    assert forward and second
    assert (forward, second) == used_directions(serial._solver, "knot")


def test_uneven_thread_counts_fall_back_to_a_divisor_or_serial() -> None:
    knot = toy_knot()
    assert mapped_knots(knot, 13, 2).name() == "map13_knot"  # prime: serial
    assert mapped_knots(knot, 30, 4).name() == "threadmap3_map10_knot"


@pytest.mark.parametrize("threads", [0, -1, 65, 2.0, True])
def test_knot_threads_is_validated_in_one_line(threads: object) -> None:
    with pytest.raises(PlannerConfigError, match="knot_threads") as err:
        PlannerOptions(knot_threads=threads)  # type: ignore[arg-type]
    assert "\n" not in str(err.value)

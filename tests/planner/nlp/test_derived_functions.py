"""The flat feet's and soles' per-knot functions with the knot's derivative treatment
(`planner.nlp.solver_cache.DerivedFunctions`, issue #16 session 26b)."""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import robots
from planner.nlp import flat_foot
from planner.nlp.config import PlannerOptions
from planner.nlp.model import RobotModel
from planner.nlp.solver_cache import DerivedFunctions, load_directions
from planner.nlp.spacetime import GaitPlanner


def _mapped_derivatives(fn: ca.Function, n: int) -> ca.Function:
    """Jacobian and Hessian of a nonlinear Lagrangian of `fn` mapped over n knots, by MX AD."""
    args = [ca.MX.sym(f"a{i}", fn.size1_in(i), fn.size2_in(i) * n) for i in range(fn.n_in())]
    outs = fn.map(n)(*args)
    outs = outs if isinstance(outs, (list, tuple)) else [outs]
    y = ca.vertcat(*[ca.vec(o) for o in outs])
    u = ca.vertcat(*[ca.vec(a) for a in args])
    lam = ca.MX.sym("lam", y.shape[0])
    lagrangian = ca.dot(lam, y) + ca.sumsqr(ca.sin(y))  # nonlinear in y: Δλ ≠ 0 too
    return ca.Function("derivs", [*args, lam], [ca.jacobian(y, u), ca.hessian(lagrangian, u)[0]])


@pytest.fixture(scope="module")
def humanoid() -> RobotModel:
    return RobotModel(robots.load("tests/zoo/humanoid20"))


@pytest.mark.parametrize("which", ["flat_knot", "soles"])
def test_derived_functions_equal_casadi_ad(
    humanoid: RobotModel, which: str, tmp_path: Path
) -> None:
    # flat_knot ignores the other legs' joints: its J has zero columns (dense adjoints kept)
    plain = flat_foot._knot_function(humanoid, 0.5) if which == "flat_knot" else humanoid.soles
    # CasADi's AD Hessian asks for the second-order directions served here
    derived = DerivedFunctions(3, PlannerOptions(nlp_hessian="ad"), tmp_path)(plain)
    rng = np.random.default_rng(5)
    ref_fn, our_fn = _mapped_derivatives(plain, 3), _mapped_derivatives(derived, 3)
    args = [rng.uniform(-0.5, 0.5, ref_fn.sparsity_in(i).shape) for i in range(ref_fn.n_in())]
    for ref, got in zip(ref_fn(*args), our_fn(*args), strict=True):
        np.testing.assert_allclose(np.asarray(got), np.asarray(ref), rtol=1e-10, atol=1e-10)


def test_planner_serves_the_flat_foot_derivatives_and_records_their_directions(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("GAITSMITH_CACHE", str(tmp_path))
    options = PlannerOptions(nlp_hessian="ad")  # its Hessian calls the second-order directions
    planner = GaitPlanner(robots.load("tests/zoo/humanoid20"), 8, options)
    assert planner.derived is not None
    names = {name for name, *_ in planner.derived.made}
    assert names == {"flat_knot", "soles"}
    hessian = planner._solver.get_function("nlp_hess_l")
    called = {
        hessian.instruction_MX(k).which_function().name()
        for k in range(hessian.n_instructions())
        if hessian.instruction_id(k) == ca.OP_CALL
    }
    assert any("adj1" in c and "flat_knot" in c for c in called)
    for _, _, path, _ in planner.derived.made:
        recorded = load_directions(path)
        assert recorded is not None and recorded[1]  # the Hessian's second-order counts
    again = GaitPlanner(robots.load("tests/zoo/humanoid20"), 8, options)
    assert again.derived is not None
    assert all(known is not None for *_, known in again.derived.made)

"""Eliminated rates and torques (`planner.nlp.lifted`) and the assembled constraint Jacobian
(`planner.nlp.assembled_jacobian`), issue #16: the same NLP in fewer variables, and the same
Jacobian from one knot J per knot (docs/results/planner_speed_lifted.md)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import eliminated_slots, parameter_vector
from planner.templates import make_schedule


def _jacobian(planner: GaitPlanner, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.asarray(planner._solver.get_function("nlp_jac_g")(x, p)[1].full())


@pytest.mark.parametrize("robot_name", ["quad12", "biped"])
@pytest.mark.parametrize("lifted_rates", ["all", "none"])
def test_assembled_jacobian_is_casadis_own(robot_name: str, lifted_rates: str) -> None:
    """Same values and sparsity as CasADi's AD of the NLP, at a random point; the biped's flat
    feet use the knot's outputs nonlinearly, so ∂G/∂Y depends on Y there."""
    robot = robots.load(robot_name)
    ad = GaitPlanner(robot, 8, PlannerOptions(lifted_rates=lifted_rates, nlp_jacobian="ad"))
    assembled = GaitPlanner(
        robot, 8, PlannerOptions(lifted_rates=lifted_rates, nlp_jacobian="assembled")
    )
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


def _called(function: ca.Function) -> list[str]:
    return [
        function.instruction_MX(k).which_function().name()
        for k in range(function.n_instructions())
        if function.instruction_id(k) == ca.OP_CALL
    ]


@pytest.mark.parametrize("robot_name", ["quad12", "hex18"])
def test_assembled_jacobian_evaluates_every_knot_jacobian_once(robot_name: str) -> None:
    """With the rates eliminated (quad12: 66 variables per knot) and on hex18 (88 inputs)
    CasADi's AD evaluates J twice (fwd64 and one more batch); assembled: one map of J and no
    forward derivative of the knot."""
    robot = robots.load(robot_name)
    for rates in ("all", "none"):
        planner = GaitPlanner(robot, 8, PlannerOptions(lifted_rates=rates))
        called = _called(planner._solver.get_function("nlp_jac_g"))
        assert not [c for c in called if c.startswith("fwd")], called
        assert [c for c in called if c.endswith("J_knot")] == ["map8_J_knot"], called
    ad = GaitPlanner(robot, 8, PlannerOptions(lifted_rates="none", nlp_jacobian="ad"))
    fwd = [c for c in _called(ad._solver.get_function("nlp_jac_g")) if c.startswith("fwd")]
    assert len(fwd) == 2 and fwd[0].startswith("fwd64_"), fwd


def test_eliminated_slots_are_fixed_and_dropped_rows() -> None:
    robot = robots.load("quad12")
    lifted = GaitPlanner(robot, 8)
    eliminated = GaitPlanner(robot, 8, PlannerOptions(lifted_rates="none", lifted_torques=False))
    mask = eliminated_slots(eliminated.layout, eliminated.options)
    n, nj = 8, 12
    assert mask.sum() == 2 * (6 + nj) * n + nj * n
    assert not eliminated_slots(lifted.layout, lifted.options).any()
    np.testing.assert_array_equal(eliminated._lbx[mask], 0.0)
    np.testing.assert_array_equal(eliminated._ubx[mask], 0.0)
    names = {name for name, _ in eliminated._slices}
    assert "finite differences" not in names and "inverse dynamics" not in names
    assert lifted._lbg.size - eliminated._lbg.size == 2 * (6 + nj) * n + nj * n
    velocities = GaitPlanner(robot, 8, PlannerOptions(lifted_rates="velocities"))
    mask_v = eliminated_slots(velocities.layout, velocities.options)
    assert mask_v.sum() == (6 + nj) * n and mask_v[mask.nonzero()[0][(6 + nj) * n]]
    assert not mask_v[mask.nonzero()[0][0]]  # the first rate slot stays lifted
    assert dict(velocities._slices)["velocity differences"].stop - dict(velocities._slices)[
        "velocity differences"].start == (6 + nj) * n
    xy = GaitPlanner(robot, 8, PlannerOptions(lifted_rates="base_xy"))
    assert eliminated_slots(xy.layout, xy.options).sum() == 2 * (4 + nj) * n
    assert dict(xy._slices)["base xy differences"].stop - dict(xy._slices)[
        "base xy differences"].start == 4 * n


@pytest.mark.slow
def test_eliminated_rates_reach_the_lifted_optimum_and_warm_start_it() -> None:
    """quad12 trot, N = 12: the same verdict and cost (1e-4 relative), the same motion; the
    eliminated planner's warm start carries the rates its poses imply, so the lifted planner
    starts from a consistent point and needs few iterations."""
    robot = robots.load("quad12")
    schedule = make_schedule(robot, "trot")
    lifted = GaitPlanner(robot, 12)
    eliminated = GaitPlanner(
        robot, 12, PlannerOptions(lifted_rates="none", nlp_jacobian="assembled")
    )
    a = lifted.solve(schedule, 0.25, warm_start=False)
    b = eliminated.solve(schedule, 0.25, warm_start=False)
    assert a.feasible and b.feasible
    assert b.cost == pytest.approx(a.cost, rel=1e-4)
    np.testing.assert_allclose(b.joint_angles_rad, a.joint_angles_rad, atol=1e-3)
    np.testing.assert_allclose(b.joint_torques_nm, a.joint_torques_nm, atol=1e-3)
    # the filled warm start equals the lifted solution's lifted part (both satisfy the rows)
    mask = eliminated_slots(eliminated.layout, eliminated.options)
    np.testing.assert_allclose(b.warm_start.x[mask], a.warm_start.x[mask], atol=1e-2)
    again = lifted.solve(schedule, 0.25, warm_start=b.warm_start)
    assert again.feasible and again.cost == pytest.approx(a.cost, rel=1e-4)
    assert again.iterations < a.iterations


def test_options_are_checked() -> None:
    with pytest.raises(PlannerConfigError, match="lifted_rates"):
        PlannerOptions(lifted_rates="some")
    with pytest.raises(PlannerConfigError, match="lifted_torques"):
        PlannerOptions(lifted_torques=1)  # type: ignore[arg-type]
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

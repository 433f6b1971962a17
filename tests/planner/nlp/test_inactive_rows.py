"""The schedule's switched-off equality rows freed per solve (`PlannerOptions.inactive_rows`)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.inactive_rows import RowActivity, free_inactive_rows
from planner.nlp.spacetime import GaitPlanner, ipopt_options
from planner.nlp.variables import parameter_vector
from planner.templates import make_schedule


def _equality_jacobian(pl: GaitPlanner, gait: str, speed: float, seed: int
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(J at a random point inside the bounds, the rows the solve's bounds make equalities, the
    rows the built NLP has as equalities) for the schedule of `gait`."""
    schedule = make_schedule(pl.robot, gait)
    p = parameter_vector(schedule, pl.n_knots, speed, pl.swing_clearance_m)
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(pl._lbx, -1.0), np.minimum(pl._ubx, 1.0)
    x = lo + (hi - lo) * rng.uniform(0.2, 0.8, lo.size)
    assert pl._jac_g is not None
    _, jac = pl._jac_g(x / pl._x_scale, p)
    bounds = pl._solve_bounds(schedule)
    return (np.asarray(jac.full()), np.flatnonzero(bounds.lbg == bounds.ubg),
            np.flatnonzero(pl._lbg == pl._ubg))


@pytest.mark.parametrize(("name", "gait", "speed"), [("quad12", "walk", 0.2),
                                                     ("biped", "biped_walk", 0.2)])
def test_free_unbounds_exactly_the_zero_rows_and_leaves_full_rank(
        name: str, gait: str, speed: float) -> None:
    """The equality rows "free" unbounds are those whose Jacobian row is zero at a random point
    (swing feet's stance rows; on the biped the soles' too), and what stays has full row rank:
    the zero rows were the equality Jacobian's whole rank deficiency."""
    robot = robots.load(name)
    pl = GaitPlanner(robot, 10, PlannerOptions(inactive_rows="free"))
    jac, eq, built_eq = _equality_jacobian(pl, gait, speed, 0)
    zero = built_eq[np.abs(jac[built_eq]).max(axis=1) == 0.0]
    assert zero.size > 0
    assert np.array_equal(np.setdiff1d(built_eq, eq), zero)
    names = {n for n, sl in pl._slices for r in zero if sl.start <= r < sl.stop}
    expected = {"stance height", "stance no-slip"} | (
        {"sole level", "sole yaw hold"} if robot.legs[0].sole_half_extents_m else set())
    assert names == expected
    free_cols = pl._lbx != pl._ubx
    block = jac[np.ix_(eq, free_cols)]
    assert np.linalg.matrix_rank(block) == eq.size



def _freed_groups(pl: GaitPlanner, gait: str) -> dict[str, int]:
    """How many rows of each group the solve's bounds free (equalities built, not in the solve)."""
    bounds = pl._solve_bounds(make_schedule(pl.robot, gait))
    freed = np.flatnonzero((pl._lbg == pl._ubg) & (bounds.lbg != bounds.ubg))
    return {n: int(((freed >= sl.start) & (freed < sl.stop)).sum()) for n, sl in pl._slices
            if ((freed >= sl.start) & (freed < sl.stop)).any()}


def test_free_stance_frees_the_stance_rows_only() -> None:
    """"free stance" frees a swing foot's "stance height" and "stance no-slip" rows as "free"
    does and keeps a flat foot's "sole level" and "sole yaw hold" rows (0 = 0) as rows; on point
    feet, which have no sole rows, it gives the solve the same bounds as "free"."""
    quad = robots.load("quad12")
    point = {v: GaitPlanner(quad, 10, PlannerOptions(inactive_rows=v))
             for v in ("free", "free stance")}
    a, b = (point[v]._solve_bounds(make_schedule(quad, "walk")) for v in ("free", "free stance"))
    assert np.array_equal(a.lbg, b.lbg) and np.array_equal(a.ubg, b.ubg)
    biped = robots.load("biped")
    freed = {v: _freed_groups(GaitPlanner(biped, 10, PlannerOptions(inactive_rows=v)),
                              "biped_walk") for v in ("free", "free stance")}
    assert set(freed["free"]) == {"stance height", "stance no-slip", "sole level",
                                  "sole yaw hold"}
    assert freed["free stance"] == {k: freed["free"][k]
                                    for k in ("stance height", "stance no-slip")}


def test_rows_keeps_every_equality(quad_planner: GaitPlanner) -> None:
    schedule = make_schedule(quad_planner.robot, "trot")
    # the swing wrench by rows ("bounds", the default since session 42, frees the rows it pins)
    bounds = quad_planner._solve_bounds(schedule, "rows")
    assert np.array_equal(bounds.lbg, quad_planner._lbg)
    assert np.array_equal(bounds.ubg, quad_planner._ubg)


@pytest.mark.parametrize("variant", ["free", "free stance"])
def test_free_reaches_the_same_trot_optimum(quad_planner: GaitPlanner, variant: str) -> None:
    """The same feasible set: the quad12 trot at N = 30 ends at the same optimum (on point feet
    "free stance" frees the same rows as "free")."""
    assert quad_planner.options.inactive_rows == "rows"  # the default
    free = GaitPlanner(quad_planner.robot, quad_planner.n_knots,
                       PlannerOptions(inactive_rows=variant))
    schedule = make_schedule(quad_planner.robot, "trot")
    a = quad_planner.solve(schedule, 0.25, warm_start=False)
    b = free.solve(schedule, 0.25, warm_start=False)
    assert a.feasible and b.feasible and a.optimal and b.optimal
    assert b.cost <= a.cost * (1 + 1e-4)
    assert b.max_violation < 1e-5


def test_regularised_keeps_the_rows_and_reaches_the_same_trot_optimum(
        quad_planner: GaitPlanner) -> None:
    """"regularised" hands IPOPT the same rows and bounds with δ_c > 0 from the start (as "rows"
    after IPOPT's degeneracy test): the same optimum (the iterates differ by rounding, so the
    iteration counts may too: 19 and 22 on this trot, docs/results/planner_speed_ipopt.md)."""
    options = PlannerOptions(inactive_rows="regularised")
    assert ipopt_options(options, False)["perturb_always_cd"] == "yes"
    assert "perturb_always_cd" not in ipopt_options(PlannerOptions(), False)
    reg = GaitPlanner(quad_planner.robot, quad_planner.n_knots, options)
    schedule = make_schedule(quad_planner.robot, "trot")
    bounds = reg._solve_bounds(schedule, "rows")
    assert np.array_equal(bounds.lbg, reg._lbg) and np.array_equal(bounds.ubg, reg._ubg)
    a = quad_planner.solve(schedule, 0.25, warm_start=False)
    b = reg.solve(schedule, 0.25, warm_start=False)
    assert a.optimal and b.optimal
    assert b.cost <= a.cost * (1 + 1e-4)


def test_free_keeps_rows_whose_bounds_exclude_zero() -> None:
    lbg, ubg = np.array([0.0, 1.0, -1.0, 0.0]), np.array([0.0, 2.0, 1.0, 0.0])
    lo, hi = free_inactive_rows(np.array([0, 1, 2]), lbg, ubg)
    assert np.isneginf(lo[[0, 2]]).all() and np.isposinf(hi[[0, 2]]).all()
    assert (lo[1], hi[1], lo[3], hi[3]) == (1.0, 2.0, 0.0, 0.0)
    assert lbg[0] == 0.0  # the inputs are not modified


def test_activity_must_depend_on_the_contacts_only() -> None:
    p = ca.MX.sym("p", 5)
    with pytest.raises(ValueError, match="other than the contacts"):
        RowActivity(p, np.arange(2), ca.vertcat(p[0], p[4]), 4)
    with pytest.raises(ValueError, match="activity factors"):
        RowActivity(p, np.arange(3), ca.vertcat(p[0], p[1]), 4)
    act = RowActivity(p, np.array([7, 9]), ca.vertcat(p[0], 1 - p[3]), 4)
    assert act.inactive(np.array([[0.0, 1.0], [1.0, 1.0]])).tolist() == [7, 9]
    assert act.inactive(np.array([[1.0, 1.0], [1.0, 0.0]])).tolist() == []


def test_unknown_value_is_refused() -> None:
    with pytest.raises(PlannerConfigError, match="inactive_rows='none'") as err:
        PlannerOptions(inactive_rows="none")
    assert "\n" not in str(err.value) and "free stance" in str(err.value)

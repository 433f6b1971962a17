"""planner.nlp.handover: on a biped's last double-support knots before a lift-off, the landing
leg's torques with the trailing foot's normal load moved onto it stay within the servo envelope."""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import group_labels, knot_function
from planner.nlp.handover import (
    foot_height_jacobian,
    handover_pairs,
    handover_torques_nm,
    lift_off_window,
    window_knots,
)
from planner.nlp.model import RobotModel
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import parameter_vector
from planner.templates import make_schedule

BIPED = Path(__file__).parents[1] / "fixtures" / "biped12"


def test_pairs_are_a_bipeds_two_handovers_and_nothing_on_more_feet() -> None:
    """Biped: (0 → 1) and (1 → 0), each bounding the landing leg's joints (disjoint legs);
    a quadruped gets no pair (module docstring)."""
    model = RobotModel(robots.load(BIPED))
    first, second = handover_pairs(model)
    assert (first.trailing, first.landing, second.trailing, second.landing) == (0, 1, 1, 0)
    assert first.joints and second.joints and not set(first.joints) & set(second.joints)
    assert handover_pairs(RobotModel(robots.load("quad12"))) == ()


def test_moved_load_is_the_inverse_dynamics_with_the_force_on_the_landing_foot() -> None:
    """τ_alt on the landing leg equals the knot's inverse dynamics evaluated with the trailing
    foot's normal force added to the landing foot's (and taken off the trailing one), at a
    random state: τ is linear in the forces, the formula is exact for that load case."""
    model = RobotModel(robots.load(BIPED))
    knot = knot_function(model)
    rng = np.random.default_rng(7)
    args = [rng.normal(scale=0.2, size=knot.size1_in(i)) for i in range(knot.n_in())]
    args[0][2] = 0.3  # base height
    fi = knot.index_in("f")
    f = np.abs(args[fi]).reshape(-1)
    args[fi] = f
    weight_n = model.total_mass_kg * float(np.linalg.norm(model.gravity_m_s2))
    dz = np.asarray(foot_height_jacobian(model)(args[0][3:], args[1]).full())
    tau = np.asarray(knot(*args)[1].full()).ravel()
    for pair in handover_pairs(model):
        moved = f.copy()
        moved[3 * pair.landing + 2] += f[3 * pair.trailing + 2]
        moved[3 * pair.trailing + 2] = 0.0
        want = np.asarray(knot(*[moved if i == fi else a for i, a in enumerate(args)])[1].full())
        fz = ca.DM(f[2::3].reshape(-1, 1))
        got = handover_torques_nm(
            ca.DM(tau), fz, [ca.DM(dz[i]) for i in range(model.n_feet)], weight_n, pair
        )
        np.testing.assert_allclose(np.asarray(got.full()).ravel(),
                                   want.ravel()[list(pair.joints)], atol=1e-9)


def test_lift_off_window_marks_the_last_stance_knots() -> None:
    c = np.array([[1, 1, 1, 1, 0, 0, 0, 1], [0, 1, 1, 1, 1, 1, 1, 1]], dtype=float)
    got = np.asarray(ca.DM(lift_off_window(ca.DM(c), 2)))
    np.testing.assert_array_equal(got, [[0, 0, 1, 1, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 1, 1]])
    assert window_knots(0.1, 30) == 3 and window_knots(0.001, 30) == 1


def test_option_off_by_default_and_validated() -> None:
    assert PlannerOptions().handover_window_cycles is None
    for bad in (0.0, -0.1, 0.5, math.inf, math.nan):
        with pytest.raises(PlannerConfigError, match="handover_window_cycles"):
            PlannerOptions(handover_window_cycles=bad)


@pytest.mark.parametrize("lifted_torques", [True, False])
def test_assembled_jacobian_with_the_handover_rows_is_casadis_own(lifted_torques: bool) -> None:
    """The group's rows (a map of the feet's height Jacobians outside the knot map) through
    `planner.nlp.assembled_jacobian`: the same Jacobian as CasADi's AD to 1e-10."""
    robot = robots.load("biped")
    ad, assembled = (
        GaitPlanner(robot, 8, PlannerOptions(nlp_jacobian=path, handover_window_cycles=0.2,
                                             lifted_torques=lifted_torques))
        for path in ("ad", "assembled")
    )
    labels = group_labels(ad.model, 8)["handover torque"]
    assert len(labels) == 4 * 8 * sum(len(p.joints) for p in handover_pairs(ad.model))
    p = parameter_vector(make_schedule(robot, "biped_walk"), 8, 0.2, ad.swing_clearance_m,
                         0.05, 0.1)
    x = np.random.default_rng(3).normal(scale=0.2, size=ad.layout.size)
    f_ad, f_as = (pl._solver.get_function("nlp_jac_g") for pl in (ad, assembled))
    want, got = (np.asarray(f(x, p)[1].full()) for f in (f_ad, f_as))
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())
    plain = GaitPlanner(robot, 8, PlannerOptions(lifted_torques=lifted_torques))
    extra = 4 * 8 * sum(len(p.joints) for p in handover_pairs(ad.model))
    assert want.shape[0] == plain._solver.get_function("nlp_jac_g").sparsity_out(1).size1() + extra


@pytest.mark.slow
def test_a_planned_biped_walk_meets_the_handover_bound() -> None:
    """A 12-knot walk of the flat-footed test biped: on the last double-support knot before
    each lift-off, the landing leg's torques with the trailing load moved stay in the envelope."""
    bot = robots.load(BIPED)
    options = PlannerOptions(handover_window_cycles=0.1)
    planner = GaitPlanner(bot, 12, options)
    result = planner.solve(make_schedule(bot, "biped_walk"), 0.1)
    assert result.feasible
    model = planner.model
    weight_n = model.total_mass_kg * float(np.linalg.norm(model.gravity_m_s2))
    stall = np.array([j.servo.stall_torque_nm for j in bot.joints]) * options.torque_margin
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in bot.joints])
    dz_fn = foot_height_jacobian(model)
    contact = result.contact_forces_n[:, :, 2] > 1e-6 * weight_n  # N × F
    n = contact.shape[0]
    checked = 0
    for k in range(n):
        dz = np.asarray(dz_fn(result.base_pose[k, 3:], result.joint_angles_rad[k]).full())
        fz = result.contact_forces_n[k, :, 2:3] / weight_n
        for pair in handover_pairs(model):
            if not (contact[k, pair.trailing] and contact[k, pair.landing]
                    and not contact[(k + 1) % n, pair.trailing]):
                continue
            tau = np.asarray(handover_torques_nm(
                ca.DM(result.joint_torques_nm[k]), ca.DM(fz), [ca.DM(d) for d in dz],
                weight_n, pair).full()).ravel()
            rows = list(pair.joints)
            room = stall[rows] * (1 - np.abs(result.joint_speeds_rad_s[k, rows]) / omega0[rows])
            assert np.all(np.abs(tau) <= room * (1 + 1e-4) + 1e-6)
            checked += 1
    assert checked >= 2

"""Flat feet in the planner: the contact wrench cone (Caron, Pham & Nakamura 2015), its
derivatives, the contact moment in the inverse dynamics, and plans of a biped with flat feet."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import casadi as ca
import mujoco
import numpy as np
import pytest
from scipy.optimize import linprog

import robots
from planner.nlp.flat_foot import (
    N_CWC_ROWS,
    _knot_function,
    cwc_rows,
    moment_scale,
    sole_tilt_rad,
    wrench_of_corner_forces,
)
from planner.nlp.model import RobotModel
from planner.nlp.rotations import rpy_to_matrix_np
from robots.sole import sole_corners_local

BIPED = Path(__file__).parents[1] / "fixtures" / "biped12"
X, Y, MU = 0.05, 0.03, 0.5


@pytest.fixture(scope="module")
def biped_model() -> RobotModel:
    return RobotModel(robots.load(BIPED))


def test_cwc_of_a_pure_normal_force_by_hand() -> None:
    rows = cwc_rows(np.array([0.0, 0.0, 10.0]), np.zeros(3), X, Y, MU)
    # µ f_z = 5 (four friction faces), Y f_z = 0.3, X f_z = 0.5, µ (X+Y) f_z = 0.4 (eight yaw faces)
    np.testing.assert_allclose(rows, [5, 5, 5, 5, 0.3, 0.3, 0.5, 0.5] + [0.4] * 8)


@pytest.mark.parametrize(
    ("force", "moment", "inside"),
    [
        ((0, 0, 10), (0.3, 0, 0), True),  # centre of pressure on the left edge: y = Y
        ((0, 0, 10), (0.31, 0, 0), False),  # beyond it
        ((0, 0, 10), (0, -0.5, 0), True),  # CoP on the front edge: x = −τ_y/f_z = X
        ((0, 0, 10), (0, -0.51, 0), False),
        ((0, 0, 10), (0, 0, 0.4), True),  # yaw torque µ(X+Y)f_z: all four corners slide
        ((0, 0, 10), (0, 0, -0.41), False),
        ((5, 0, 10), (0, 0, 0), True),  # on the friction pyramid's face
        ((5.1, 0, 10), (0, 0, 0), False),
        # pushing forward at the limit leaves only the sideways friction (pyramid) for yaw:
        # |τ_z| ≤ µ(X+Y)f_z − Y|f_x| = µ X f_z = 0.25
        ((5, 0, 10), (0, 0, 0.25), True),
        ((5, 0, 10), (0, 0, 0.26), False),
        ((0, 0, 0), (0, 0, 0), True),  # swing: zero wrench
        ((0, 0, 0), (0, 0, 1e-3), False),  # no moment without a normal force
    ],
)
def test_cwc_hand_computed_cases(
    force: tuple[float, ...], moment: tuple[float, ...], inside: bool
) -> None:
    rows = cwc_rows(np.array(force, float), np.array(moment, float), X, Y, MU)
    assert (rows.min() >= -1e-12) == inside, rows


def _corner_lp_feasible(force: np.ndarray, moment: np.ndarray) -> bool:
    """Is the wrench the sum of four corner forces, each in the pyramid |f_t| ≤ µ f_z?"""
    corners = np.array([[X, Y, 0.0], [-X, Y, 0.0], [-X, -Y, 0.0], [X, -Y, 0.0]])
    a_eq = np.zeros((6, 12))
    for c, p in enumerate(corners):
        a_eq[:3, 3 * c : 3 * c + 3] = np.eye(3)
        a_eq[3:, 3 * c : 3 * c + 3] = np.array(
            [[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]]
        )
    a_ub = np.zeros((16, 12))
    for c in range(4):
        for k, (ix, s) in enumerate(((0, 1), (0, -1), (1, 1), (1, -1))):
            a_ub[4 * c + k, 3 * c + ix] = s
            a_ub[4 * c + k, 3 * c + 2] = -MU
    res = linprog(
        np.zeros(12),
        A_ub=a_ub,
        b_ub=np.zeros(16),
        A_eq=a_eq,
        b_eq=np.r_[force, moment],
        bounds=[(None, None)] * 12,
        method="highs",
    )
    return bool(res.status == 0)


def test_cwc_equals_the_span_of_the_corner_pyramids() -> None:
    """Caron et al. 2015 Theorem 1: the closed form is exactly the set of wrenches four corner
    forces in their friction pyramids produce (checked both ways, by linear programming)."""
    rng = np.random.default_rng(7)
    agree = inside = 0
    for _ in range(300):
        force = np.r_[rng.normal(size=2) * 2.0, rng.uniform(0.0, 10.0)]
        moment = rng.normal(size=3) * np.array([Y, X, MU * (X + Y)]) * 2.5
        rows_ok = bool(cwc_rows(force, moment, X, Y, MU).min() >= 0.0)
        lp_ok = _corner_lp_feasible(force, moment)
        margin = np.abs(cwc_rows(force, moment, X, Y, MU)).min()
        if margin > 1e-7:  # skip samples on a face, where the LP's tolerance decides
            assert rows_ok == lp_ok, (force, moment)
            agree += 1
            inside += rows_ok
    assert agree > 250 and 30 < inside < agree - 30  # both sides well sampled


def test_wrench_of_corner_forces_lies_in_the_cone() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        fz = rng.uniform(0, 5, 4)
        tangential = rng.uniform(-1, 1, (4, 2)) * MU * fz[:, None]
        force, moment = wrench_of_corner_forces(np.c_[tangential, fz], (X, Y))
        assert cwc_rows(force, moment, X, Y, MU).min() >= -1e-12


def test_flat_foot_rows_match_finite_differences(biped_model: RobotModel) -> None:
    """CasADi's Jacobian of the sole/wrench rows (level, heading, corners, CWC, sole centres)
    vs central FD."""
    fn = _knot_function(biped_model, MU / np.sqrt(2.0))
    n_in = [fn.size1_in(i) for i in range(fn.n_in())]
    x = ca.SX.sym("x", sum(n_in))
    parts = ca.vertsplit(x, list(np.cumsum([0, *n_in])))
    out = ca.vertcat(*fn(*parts))
    jac = ca.Function("flat_rows_jacobian", [x], [out, ca.jacobian(out, x)])
    rng = np.random.default_rng(11)
    lo, hi = biped_model.joint_limits_rad()
    for _ in range(3):
        point = np.r_[
            rng.normal(size=3) * 0.05,
            rng.uniform(-0.3, 0.3, 3),
            rng.uniform(lo, hi),
            rng.normal(size=n_in[2]),
            rng.normal(size=n_in[3]) * 0.05,
        ]
        value, analytic = (np.asarray(v) for v in jac(point))
        assert value.shape[0] == 2 * 2 + 2 * 2 + 4 * 2 + N_CWC_ROWS * 2 + 2 * 2
        eps = 1e-6
        numeric = np.zeros_like(analytic)
        for i in range(point.size):
            step = np.zeros(point.size)
            step[i] = eps
            hi_v = np.asarray(jac(point + step)[0]).ravel()
            lo_v = np.asarray(jac(point - step)[0]).ravel()
            numeric[:, i] = (hi_v - lo_v) / (2 * eps)
        np.testing.assert_allclose(analytic, numeric, atol=1e-6, rtol=1e-5)


def test_contact_moment_enters_through_the_foot_jacobian(biped_model: RobotModel) -> None:
    """inverse_dynamics_wrench = mj_inverse − J_pᵀ f − J_rᵀ m (J_p at the sole centre, J_r the
    foot body's rotational Jacobian)."""
    m = biped_model
    mj = m.mj_model
    data = mujoco.MjData(mj)
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    rng = np.random.default_rng(5)
    dofs = np.r_[np.arange(6), m.joint_dofadr]
    from robots.sole import sole_pose_world

    for _ in range(10):
        base = np.r_[rng.normal(size=2) * 0.1, 0.25, rng.uniform(-0.4, 0.4, 3)]
        q = rng.uniform(*m.joint_limits_rad())
        vel, acc = rng.normal(size=6 + m.n_joints), rng.normal(size=6 + m.n_joints) * 10
        forces, moments = rng.normal(size=(3, 2)) * 8.0, rng.normal(size=(3, 2)) * 0.5
        data.qpos[:] = m.mujoco_qpos(base, q)
        data.qvel[dofs], data.qacc[dofs] = vel, acc
        mujoco.mj_inverse(mj, data)
        expected = data.qfrc_inverse.copy()
        for f, leg in enumerate(m.robot.legs):
            centre, _ = sole_pose_world(mj, data, leg)
            body = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, leg.foot_body)
            jp, jr = np.zeros((3, mj.nv)), np.zeros((3, mj.nv))
            mujoco.mj_jac(mj, data, jp, jr, centre, body)
            expected -= jp.T @ forces[:, f] + jr.T @ moments[:, f]
        rot = rpy_to_matrix_np(base[3:])
        base_rows, tau = m.inverse_dynamics_wrench(
            base[:3],
            base[3:],
            q,
            vel[:3],
            rot @ vel[3:6],
            vel[6:],
            acc[:3],
            rot @ acc[3:6],
            acc[6:],
            forces,
            moments,
        )
        ours = np.r_[np.asarray(base_rows).ravel(), np.asarray(tau).ravel()]
        ref = expected[dofs]
        assert np.max(np.abs(ours - ref)) <= 1e-6 * max(1.0, np.max(np.abs(ref)))


def test_soles_and_contact_points_match_mujoco(biped_model: RobotModel) -> None:
    m = biped_model
    data = mujoco.MjData(m.mj_model)
    rng = np.random.default_rng(2)
    from robots.sole import sole_pose_world

    base = np.r_[0.01, -0.02, 0.25, 0.1, -0.2, 0.3]
    q = rng.uniform(*m.joint_limits_rad())
    data.qpos[:] = m.mujoco_qpos(base, q)
    mujoco.mj_kinematics(m.mj_model, data)
    feet = np.asarray(m.fk(base[:3], base[3:], q)[0])
    rots = np.asarray(m.soles(base[:3], base[3:], q))
    for f, leg in enumerate(m.robot.legs):
        centre, rot = sole_pose_world(m.mj_model, data, leg)
        np.testing.assert_allclose(feet[:, f], centre, atol=1e-12)
        np.testing.assert_allclose(rots[:, 3 * f : 3 * f + 3], rot, atol=1e-12)
    tilt = sole_tilt_rad(m, base[None, :], q[None, :])
    assert tilt.shape == (1, 2) and np.all(tilt >= 0)


def _swing_clearance_m(planner: Any) -> float:
    """The planner's swing clearance h [m] (a fixed option, or its law in the leg length)."""
    fixed = planner.options.swing_clearance_m
    if fixed is not None:
        return float(fixed)
    return float(planner.options.swing_clearance_for(planner.robot.leg_length_m))


@pytest.mark.slow
def test_biped_plans_keep_the_soles_flat_and_inside_the_cone() -> None:
    """N = 12 stand and slow walk: stance soles level (< 1°), no yaw slip, swing soles clear of
    the ground at all four corners, every wrench inside the CWC."""
    from planner.nlp.spacetime import GaitPlanner
    from planner.nlp.variables import swing_height_profile
    from robots import ContactSchedule

    robot = robots.load(BIPED)
    planner = GaitPlanner(robot, n_knots=12)
    model, feet = planner.model, robot.foot_names
    cases = {
        "stand": (ContactSchedule(1.0, feet, (0.0, 0.0), (1.0, 1.0)), 0.0),
        "walk": (ContactSchedule(1.0, feet, (0.0, 0.5), (0.75, 0.75)), 0.05),
    }
    weight_n = model.total_mass_kg * float(np.linalg.norm(model.gravity_m_s2))
    for label, (schedule, speed) in cases.items():
        result = planner.solve(schedule, speed, warm_start=False)
        assert result.feasible, (label, result.message)
        contact = schedule.contact_matrix(12)
        tilt = sole_tilt_rad(model, result.base_pose, result.joint_angles_rad)
        assert np.degrees(tilt[contact]).max() < 1.0, label
        moments = planner.layout.unpack_moments(result.warm_start.x) * moment_scale(model)
        clearance = swing_height_profile(schedule, 12, _swing_clearance_m(planner))
        heading = np.zeros((12, 2))
        for k in range(12):
            b, q = result.base_pose[k], result.joint_angles_rad[k]
            centres = np.asarray(model.fk(b[:3], b[3:], q)[0])
            rots = np.asarray(model.soles(b[:3], b[3:], q))
            for f, leg in enumerate(robot.legs):
                rot = rots[:, 3 * f : 3 * f + 3]
                heading[k, f] = np.arctan2(rot[1, 0], rot[0, 0])
                corners = centres[:, f] + sole_corners_local(leg) @ rot.T
                if contact[k, f]:
                    assert np.abs(corners[:, 2]).max() < 1e-5
                else:
                    assert corners[:, 2].min() >= clearance[k, f] - 1e-6
                hx, hy = leg.sole_half_extents_m
                wrench = (
                    rot.T @ result.contact_forces_n[k, f] / weight_n,
                    rot.T @ moments[k, f] / weight_n,
                )
                rows = cwc_rows(*wrench, hx, hy, planner.options.mu / np.sqrt(2.0))
                assert rows.min() > -1e-6, (label, k, f)
        held = contact & np.roll(contact, -1, axis=0)
        change = np.abs(np.angle(np.exp(1j * (np.roll(heading, -1, axis=0) - heading))))
        assert np.degrees(change[held]).max() < 1e-3, label


def test_body_clearance_spares_only_the_flat_feet_ankles(biped_model: RobotModel) -> None:
    from planner.nlp.flat_foot import body_clearance_lower_bounds

    lb = body_clearance_lower_bounds(biped_model, 3).reshape(3, biped_model.n_bodies)
    spared = {biped_model.foot_body_index(f) for f in range(2)} | {
        biped_model.body_parent(biped_model.foot_body_index(f)) for f in range(2)
    }
    assert set(np.flatnonzero(np.isinf(lb[0]))) == spared and len(spared) == 4
    assert np.all(lb[:, [b for b in range(biped_model.n_bodies) if b not in spared]] == 0.0)
    quad = RobotModel(robots.load("quad12"))
    assert np.all(body_clearance_lower_bounds(quad, 3) == 0.0)


def test_the_shrunk_sole_cone_keeps_the_centre_of_pressure_off_the_edge() -> None:
    """CoP margin (`planner.nlp.contact_margin`): a CoP at 0.7 Y is in the sole's cone but not
    in the cone of the sole shrunk to 0.6; the torsion limit shrinks by the same share."""
    from planner.nlp.contact_margin import shrunk_half_extents

    small = shrunk_half_extents((X, Y), 0.6)
    assert small == pytest.approx((0.6 * X, 0.6 * Y))
    force, near_edge = np.array([0.0, 0.0, 10.0]), np.array([0.7 * Y * 10.0, 0.0, 0.0])
    assert cwc_rows(force, near_edge, X, Y, MU).min() >= 0
    assert cwc_rows(force, near_edge, *small, MU).min() < 0
    inside = np.array([0.55 * Y * 10.0, 0.0, 0.0])
    assert cwc_rows(force, inside, *small, MU).min() >= 0
    twist = np.array([0.0, 0.0, 0.7 * MU * (X + Y) * 10.0])
    assert cwc_rows(force, twist, X, Y, MU).min() >= 0 > cwc_rows(force, twist, *small, MU).min()
    with pytest.raises(ValueError, match="sole fraction"):
        shrunk_half_extents((X, Y), 0.0)


def test_single_support_indicator_marks_knots_with_one_foot_down() -> None:
    from planner.nlp.capture_margin import single_support

    contact = ca.DM([[1, 1, 0, 0, 1], [1, 0, 0, 1, 0], [1, 0, 1, 0, 0]])
    assert np.asarray(single_support(contact, 0)).ravel().tolist() == [0, 1, 0, 0, 1]
    assert np.asarray(single_support(contact, 1)).ravel().tolist() == [0, 0, 0, 1, 0]


def test_capture_point_is_the_com_plus_its_velocity_over_omega(biped_model: RobotModel) -> None:
    """ξ = c + ċ/ω₀, ω₀ = √(g/c_z) (Koolen et al. 2012 eq 9), ċ by cyclic central differences
    of the knots plus the commanded speed, against the same formula in numpy."""
    from planner.nlp.capture_margin import capture_point_xy
    from planner.nlp.variables import Layout, make_symbols, parameter_vector
    from planner.templates import make_schedule

    model, n, speed = biped_model, 8, 0.12
    layout = Layout(n, model.n_joints, model.n_feet, len(model.flat_feet))
    sym = make_symbols(layout)
    fn = ca.Function("xi", [sym.x, sym.p], [capture_point_xy(model, sym, n)])
    rng = np.random.default_rng(3)
    stance = np.asarray(model.robot.nominal_stance_rad)
    base = np.zeros((n, 6))
    base[:, 0] = 0.01 * np.sin(2 * np.pi * np.arange(n) / n)
    base[:, 1] = 0.02 * np.cos(2 * np.pi * np.arange(n) / n)
    base[:, 2] = model.robot.stance_base_height_m
    q = stance + 0.05 * rng.standard_normal((n, model.n_joints))
    x = layout.pack(base, q, np.zeros((n, model.n_feet, 3)))
    schedule = make_schedule(model.robot, "biped_walk")
    p = parameter_vector(schedule, n, speed, 0.03)
    xi = np.asarray(fn(x, p))
    com = np.array([np.asarray(model.fk(b[:3], b[3:], qk)[2]).ravel()
                    for b, qk in zip(base, q, strict=True)])
    h = schedule.period_s / n
    vel = (np.roll(com, -1, axis=0) - np.roll(com, 1, axis=0)) / (2 * h)
    vel[:, 0] += speed
    expected = com[:, :2] + vel[:, :2] * np.sqrt(com[:, 2:3] / 9.81)
    np.testing.assert_allclose(xi.T, expected, atol=1e-9)


def test_margins_are_off_by_default_and_add_their_rows_when_asked(biped_model: RobotModel) -> None:
    """Default options: the flat-foot groups of main (no capture or footprint rows, the CWC of
    the whole sole); the options add the capture rows (±y per flat foot and knot, labelled) and
    the mean-footprint rows."""
    from planner.nlp.config import PlannerOptions
    from planner.nlp.constraints import Group
    from planner.nlp.flat_foot import flat_foot_groups, flat_foot_labels
    from planner.nlp.variables import Layout, make_symbols

    model, n = biped_model, 8
    sym = make_symbols(Layout(n, model.n_joints, model.n_feet, len(model.flat_feet)))
    stick = ca.DM.ones(model.n_feet, n)
    default = flat_foot_groups(model, sym, n, PlannerOptions(), stick, Group)
    assert [g.name for g in default] == [
        "sole level", "sole yaw hold", "sole clearance", "contact wrench cone"
    ]
    asked = PlannerOptions(capture_sole_fraction=0.8, flat_mean_footprint_leg_lengths=0.05)
    groups = {g.name: g for g in flat_foot_groups(model, sym, n, asked, stick, Group)}
    assert groups["capture margin"].expr.shape[0] == 2 * 2 * n
    assert len(flat_foot_labels(model, n)["capture margin"]) == 2 * 2 * n
    assert groups["mean footprint"].expr.shape[0] == 2 * model.n_feet
    with pytest.raises(Exception, match="capture_sole_fraction"):
        PlannerOptions(capture_sole_fraction=1.5)

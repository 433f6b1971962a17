"""Velocity commands (vx, vy, yaw rate) in the spacetime NLP (`planner.nlp.command`).

The planar motion against hand computations and finite differences, the NLP's wrap-around rows
against a numpy computation of "knot k+1 seen from the command frame of knot k", the identity
with the treadmill NLP at vy = W = 0, and one slow turn: planned yaw advances by W·T per cycle
and the stance feet stand still in the world across the wrap.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.command import (
    VelocityCommand,
    compose,
    motion_parameters,
    planar_displacement,
    world_base_poses,
)
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import initial_guess, parameter_vector
from planner.templates import make_schedule

FIXTURES = Path(__file__).parents[1] / "fixtures"


def test_planar_displacement_by_hand() -> None:
    # straight: d = t·(vx, vy)
    assert planar_displacement(VelocityCommand(0.3, -0.1, 0.0), 2.0) == pytest.approx(
        (0.6, -0.2, 0.0))
    # a quarter of the unit circle: forward at 1 m/s turning left at 1 rad/s → (1, 1)
    assert planar_displacement(VelocityCommand(1.0, 0.0, 1.0), math.pi / 2) == pytest.approx(
        (1.0, 1.0, math.pi / 2))
    # moving left at 1 m/s turning left: the velocity turns from +y to −x → (−1, 1)
    assert planar_displacement(VelocityCommand(0.0, 1.0, 1.0), math.pi / 2) == pytest.approx(
        (-1.0, 1.0, math.pi / 2))
    # turn in place: no translation
    assert planar_displacement(VelocityCommand(0.0, 0.0, 0.6), 0.5) == pytest.approx(
        (0.0, 0.0, 0.3))


def test_planar_displacement_is_the_integral_of_the_body_velocity() -> None:
    cmd = VelocityCommand(0.2, 0.07, -0.8)
    t, eps = 0.7, 1e-6
    d = np.array(planar_displacement(cmd, t + eps)) - np.array(planar_displacement(cmd, t - eps))
    rate = d / (2 * eps)
    psi = cmd.yaw_rate_rad_s * t  # d/dt d(t) = R(W·t)·(vx, vy)
    c, s = math.cos(psi), math.sin(psi)
    expected = (c * cmd.vx_m_s - s * cmd.vy_m_s, s * cmd.vx_m_s + c * cmd.vy_m_s, -0.8)
    assert rate == pytest.approx(expected, abs=1e-7)
    # the small-angle series (|W·t| < 1e-6) and the closed form both match the first-order arc
    # d ≈ t·(vx, vy) + W·t²/2·(−vy, vx) on either side of the switch
    for w in (1e-7, 1e-5):
        d = planar_displacement(VelocityCommand(0.2, 0.07, w), 0.7)
        first_order = (0.2 * 0.7 - 0.07 * w * 0.49 / 2, 0.07 * 0.7 + 0.2 * w * 0.49 / 2)
        assert d[:2] == pytest.approx(first_order, abs=1e-10)  # 1 − cos θ: ε/θ rounding


def test_motions_compose_and_invert() -> None:
    cmd = VelocityCommand(0.15, -0.05, 0.9)
    a, b = 0.3, 0.45
    pose_b = np.r_[planar_displacement(cmd, b)[:2], 0.0, 0.0, 0.0, planar_displacement(cmd, b)[2]]
    ab = compose(planar_displacement(cmd, a), pose_b)
    assert ab[[0, 1, 5]] == pytest.approx(planar_displacement(cmd, a + b))
    # Δ(−h) is the inverse of Δ(+h) (the "previous knot" transform of the NLP)
    p = motion_parameters(cmd, 0.5, 10)
    h = 0.05
    fwd = np.r_[p[4], p[5], 0.0, 0.0, 0.0, cmd.yaw_rate_rad_s * h]
    back = compose((p[6], p[7], -cmd.yaw_rate_rad_s * h), fwd)
    assert back == pytest.approx(np.zeros(6), abs=1e-15)
    assert p[2:4] == pytest.approx((math.cos(0.9 * h), math.sin(0.9 * h)))


def _rows(planner: GaitPlanner, x: np.ndarray, p: np.ndarray, name: str) -> np.ndarray:
    g = np.asarray(planner._evaluate(x / planner._x_scale, p)[0]).ravel()
    return g[dict(planner._slices)[name]]


@pytest.fixture(scope="module")
def quad_planner_n12() -> GaitPlanner:
    return GaitPlanner(robots.load("quad12"), n_knots=12)


@pytest.mark.parametrize("command", [(0.1, 0.0, 0.5), (0.0, 0.08, 0.0), (-0.05, 0.03, -0.7),
                                     (0.25, 0.0, 0.0)])
def test_wrap_around_rows_by_hand(quad_planner_n12: GaitPlanner,
                                  command: tuple[float, float, float]) -> None:
    """Finite differences and stance no-slip rows = knot k±1 moved into knot k's command frame,
    the wrap N−1 → 0 included (numpy, independent of the CasADi expressions)."""
    planner = quad_planner_n12
    vx, vy, w = command
    n, nj = planner.n_knots, planner.model.n_joints
    schedule = make_schedule(planner.robot, "trot")
    h = schedule.period_s / n
    p = parameter_vector(schedule, n, vx, planner.swing_clearance_m, vy, w)
    rng = np.random.default_rng(7)
    x = initial_guess(planner.layout, planner.model, schedule)
    x = x + 0.03 * rng.normal(size=x.size)
    base, q, _ = planner.layout.unpack(x)
    cmd = VelocityCommand(vx, vy, w)
    pose = np.hstack([base, q])  # N × (6+J)
    nxt = np.array([compose(planar_displacement(cmd, h), pose[(k + 1) % n]) for k in range(n)])
    prv = np.array([compose(planar_displacement(cmd, -h), pose[k - 1]) for k in range(n)])
    nb = planner.layout.n_rates
    vel, acc = planner.layout.view(x, "vel"), planner.layout.view(x, "acc")
    command_rate = np.r_[vx, vy, 0.0, 0.0, 0.0, w, np.zeros(nj)]
    expected_vel = vel - ((nxt - prv) / (2 * h) - command_rate)
    expected_acc = acc - (nxt - 2 * pose + prv) / h**2
    fd = _rows(planner, x, p, "finite differences")
    assert fd[:nb] == pytest.approx(expected_vel.ravel(), abs=1e-9)
    assert fd[nb:] == pytest.approx(expected_acc.ravel(), abs=1e-7)
    # stance no-slip: the foot of knot k+1 in knot k's frame is where it was at k
    feet = np.array([np.asarray(planner.model.fk(b[:3], b[3:], qk)[0])
                     for b, qk in zip(base, q, strict=True)])  # N × 3 × F
    c = schedule.contact_matrix(n).astype(float)  # N × F
    stick = c + np.roll(c, -1, axis=0) - c * np.roll(c, -1, axis=0)
    dx, dy, dpsi = planar_displacement(cmd, h)
    cs, sn = math.cos(dpsi), math.sin(dpsi)
    fx1, fy1 = np.roll(feet[:, 0, :], -1, axis=0), np.roll(feet[:, 1, :], -1, axis=0)
    slip_x = stick * (dx + cs * fx1 - sn * fy1 - feet[:, 0, :])
    slip_y = stick * (dy + sn * fx1 + cs * fy1 - feet[:, 1, :])
    rows = _rows(planner, x, p, "stance no-slip")
    assert rows == pytest.approx(np.r_[slip_x.ravel(), slip_y.ravel()], abs=1e-9)


def test_zero_command_rows_are_the_treadmill_rows(quad_planner_n12: GaitPlanner) -> None:
    """vy = W = 0: every row of g equals the treadmill NLP's (base x shifted by ±v·h)."""
    planner = quad_planner_n12
    n = planner.n_knots
    schedule = make_schedule(planner.robot, "trot")
    h, v = schedule.period_s / n, 0.25
    p = parameter_vector(schedule, n, v, planner.swing_clearance_m)
    assert p[-8:] == pytest.approx([0, 0, 1, 0, v * h, 0, -v * h, 0], abs=1e-15)
    x = initial_guess(planner.layout, planner.model, schedule)
    x = x + 0.03 * np.random.default_rng(1).normal(size=x.size)
    base, q, _ = planner.layout.unpack(x)
    pose = np.hstack([base, q])
    nb = planner.layout.n_rates
    vel, acc = planner.layout.view(x, "vel"), planner.layout.view(x, "acc")
    treadmill_vel = (np.roll(pose, -1, axis=0) - np.roll(pose, 1, axis=0)) / (2 * h)
    treadmill_acc = (np.roll(pose, -1, axis=0) - 2 * pose + np.roll(pose, 1, axis=0)) / h**2
    fd = _rows(planner, x, p, "finite differences")
    assert fd[:nb] == pytest.approx((vel - treadmill_vel).ravel(), abs=1e-9)
    assert fd[nb:] == pytest.approx((acc - treadmill_acc).ravel(), abs=1e-7)


@pytest.mark.slow
def test_zero_command_optimum_is_the_treadmill_optimum(quad_planner_n12: GaitPlanner) -> None:
    """quad12 trot N=12 at 0.25 m/s: the optimum of main's treadmill NLP (before velocity
    commands, commit 76a2b10) to 1e-6, with the rows in the form that NLP had
    (`compact_rows=()`). The default NLP gives the torque envelope as ranged rows (session 31:
    the same set and barrier problem, other rounding): the same optimum to IPOPT's tolerance,
    1e-5 (measured 5.6e-6). The default swing wrench by bounds (session 42) reaches the same
    optimum by another path: cost 8e-8 relative below, the poses and forces within 4e-5 of the
    reference, a lifted variable 1.5e-3 off (a direction the cost hardly sees); the default's
    servo goals are variables of their own since session 43 (`servo_goal_form`, appended after
    every other block), the reference's blocks compared on its own entries. Regenerate the
    fixture only for a deliberate change of the NLP."""
    reference = np.load(FIXTURES / "quad12_trot_n12_main_optimum.npy")
    schedule = make_schedule(quad_planner_n12.robot, "trot")
    rows = GaitPlanner(quad_planner_n12.robot, n_knots=12,
                       options=PlannerOptions(compact_rows=(), swing_wrench="rows",
                                              servo_goal_form="direct"))
    exact = rows.solve(schedule, 0.25, warm_start=False)
    assert exact.feasible
    assert np.max(np.abs(exact.warm_start.x - reference)) < 1e-6
    ranged = GaitPlanner(quad_planner_n12.robot, n_knots=12,
                         options=PlannerOptions(swing_wrench="rows", servo_goal_form="direct"))
    result = ranged.solve(schedule, 0.25, warm_start=False)
    assert result.feasible
    assert np.max(np.abs(result.warm_start.x - reference)) < 1e-5
    default = quad_planner_n12.solve(schedule, 0.25, warm_start=False)
    assert default.feasible and default.stats["swing_wrench"] == "bounds"
    assert default.cost == pytest.approx(exact.cost, rel=1e-6)
    off = np.abs(default.warm_start.x[: reference.size] - reference)
    layout = quad_planner_n12.layout
    for block in ("base", "q", "forces"):
        assert off[layout.block(block)].max() < 1e-4, block


@pytest.mark.slow
def test_planned_turn_advances_by_w_t_with_feet_still_in_the_world() -> None:
    bot = robots.load("quad12")
    planner = GaitPlanner(bot, n_knots=16)
    schedule = make_schedule(bot, "trot")
    cmd = VelocityCommand(0.1, 0.0, 0.5)
    result = planner.solve(schedule, cmd.vx_m_s, warm_start=False,
                           yaw_rate_rad_s=cmd.yaw_rate_rad_s)
    assert result.feasible, result.message
    n, period = planner.n_knots, schedule.period_s
    world = world_base_poses(result.base_pose, cmd, period, cycles=2)
    assert world[n, 5] - world[0, 5] == pytest.approx(0.5 * period, abs=1e-12)
    assert world[2 * n, 5] - world[n, 5] == pytest.approx(0.5 * period, abs=1e-12)
    # the base's own yaw in the command frame stays small and periodic: the turn is the frame's
    assert np.max(np.abs(result.base_pose[:, 5])) < 0.5 * period
    # every stance foot stays put in the world, across the wrap N−1 → 0 too (two cycles)
    contact = schedule.contact_matrix(n)
    for f in range(planner.model.n_feet):
        for k in range(2 * n - 1):
            if contact[k % n, f] and contact[(k + 1) % n, f]:
                a, b = (np.asarray(planner.model.fk(world[i, :3], world[i, 3:],
                                                    result.joint_angles_rad[i % n])[0])[:2, f]
                        for i in (k, k + 1))
                assert a == pytest.approx(b, abs=1e-6)
    gait = planner.to_gait(result, "trot")
    assert (gait.velocity.vx_m_s, gait.velocity.vy_m_s, gait.velocity.yaw_rate_rad_s) == (
        0.1, 0.0, 0.5)


def test_bad_commands_are_config_errors(quad_planner_n12: GaitPlanner) -> None:
    schedule = make_schedule(quad_planner_n12.robot, "trot")
    for vy, w in ((math.nan, 0.0), (11.0, 0.0), (0.0, math.inf), (0.0, 4.0 / schedule.period_s)):
        with pytest.raises(PlannerConfigError):
            quad_planner_n12.solve(schedule, 0.1, vy_m_s=vy, yaw_rate_rad_s=w)


@pytest.mark.slow
def test_static_margin_and_mean_footprint_rows_by_hand() -> None:
    """The commanded walk's rows (`PlannerOptions.static_margin_leg_lengths`,
    `mean_footprint_leg_lengths`) against numpy: the CoM's distance inside each active edge of
    the stance polygon minus the margin, times the edge length; the mean base-frame foot x, y."""
    import mujoco

    from planner.nlp.config import PlannerOptions
    from planner.search.support import polygon_edges
    from planner.templates import stance_foot_positions_m

    bot = robots.load("quad12")
    options = PlannerOptions(static_margin_leg_lengths=0.08, mean_footprint_leg_lengths=0.05)
    planner = GaitPlanner(bot, n_knots=12, options=options)
    schedule = make_schedule(bot, "walk", duty_factor=0.85)
    n = planner.n_knots
    p = parameter_vector(schedule, n, 0.0, planner.swing_clearance_m, 0.05, 0.3)
    x = initial_guess(planner.layout, planner.model, schedule)
    x = x + 0.02 * np.random.default_rng(3).normal(size=x.size)
    base, q, _ = planner.layout.unpack(x)
    mj = planner.model.mj_model
    data = mujoco.MjData(mj)
    root = int(mj.jnt_bodyid[0])
    edges = polygon_edges(stance_foot_positions_m(bot)[:, :2])
    contact = schedule.contact_matrix(n)
    margin_m = 0.08 * bot.leg_length_m
    expected = np.zeros((len(edges), n))
    for k in range(n):
        data.qpos[:] = planner.model.mujoco_qpos(base[k], q[k])
        mujoco.mj_kinematics(mj, data)
        mujoco.mj_comPos(mj, data)
        com = data.subtree_com[root][:2]
        feet = np.asarray(planner.model.fk(base[k, :3], base[k, 3:], q[k])[0])[:2].T
        for e_index, e in enumerate(edges):
            if e.active(contact[k]):
                u, v = feet[e.j] - feet[e.i], com - feet[e.i]
                expected[e_index, k] = u[0] * v[1] - u[1] * v[0] - margin_m * np.hypot(*u)
    assert np.count_nonzero(expected) >= 3 * n  # three or four edges at every knot
    assert _rows(planner, x, p, "static margin") == pytest.approx(expected.ravel(), abs=1e-9)
    body = np.array([np.asarray(planner.model.fk(np.zeros(3), np.zeros(3), qk)[0])[:2].T
                     for qk in q])  # N × F × 2, base frame
    mean = body.mean(axis=0)
    assert _rows(planner, x, p, "mean footprint") == pytest.approx(
        np.r_[mean[:, 0], mean[:, 1]], abs=1e-12)

"""Spacetime planner: solves on both robots, checked independently from the written gait file."""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import InfeasibleGaitError, PlannerConfigError
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule
from tests.planner.gait_check import check_gait


def _solve_and_check(planner: GaitPlanner, gait: str, speed: float, tmp_path: Path) -> None:
    schedule = make_schedule(planner.robot, gait)
    result = planner.solve(schedule, speed, warm_start=False)
    assert result.feasible, result.message
    path = tmp_path / f"{gait}.json"
    robots.gait.save(planner.to_gait(result, gait), path)
    loaded = robots.gait.load(path, planner.robot)
    o = planner.options
    c = check_gait(loaded, planner.robot, o.mu, o.torque_margin)
    weight = planner.model.total_mass_kg * 9.81
    assert c.stance_height_err_m < 1e-4
    assert (
        c.stance_slip_m < 1e-4
    )  # stance feet stay put in the ground frame (move at −v on the treadmill)
    assert c.min_swing_height_m > -1e-4
    assert c.max_swing_apex_m > 0.9 * planner.swing_clearance_m
    assert c.friction_excess < 1e-3 * weight
    assert c.min_normal_force_n > -1e-3 * weight
    assert c.max_swing_force_n < 1e-3 * weight
    assert c.base_residual_n < 0.05 * weight  # O(h²) finite-difference mismatch only
    assert c.torque_err_over_stall < 0.02
    assert c.envelope_excess < 0.02
    # feet set down and lift off vertically (PlannerOptions.vertical_contact_transitions)
    assert o.vertical_contact_transitions and c.transition_slip_m < 1e-4
    # the samples are servo goals: the simulator's servo law at the achieved motion gives the
    # inverse-dynamics torque, without saturating (goal limits are checked by Gait loading)
    assert loaded.planner["joint_angles"] == "servo_goal"
    assert c.servo_torque_err_over_stall < 0.02
    assert c.servo_drive_over_stall < 1.0
    achieved = np.asarray(loaded.expected_joint_angles_rad)
    assert np.max(np.abs(loaded.knots_rad - achieved)) > 0.01  # goals ≠ angles: sag is real
    # the streamed goal spline stays below the player's speed limit (its pre-flight samples it)
    t = np.arange(16 * loaded.n_knots) * loaded.period_s / (16 * loaded.n_knots)
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in planner.robot.joints])
    assert np.max(np.abs(loaded.joint_velocities(t)) / omega0) <= o.speed_margin
    assert loaded.planner["n_knots"] == planner.n_knots and "casadi" in loaded.planner["versions"]
    assert 0.35 < loaded.period_s < 1.05


def test_quad12_trot_solves_and_file_checks_out(quad_planner: GaitPlanner, tmp_path: Path) -> None:
    _solve_and_check(quad_planner, "trot", 0.25, tmp_path)


def test_hex18_tripod_solves_and_file_checks_out(hex_planner: GaitPlanner, tmp_path: Path) -> None:
    _solve_and_check(hex_planner, "tripod", 0.15, tmp_path)


def test_warm_start_reuses_the_last_solution(quad_planner: GaitPlanner) -> None:
    schedule = make_schedule(quad_planner.robot, "trot")
    first = quad_planner.solve(schedule, 0.25)
    again = quad_planner.solve(schedule.with_period(schedule.period_s * 1.02), 0.25)
    assert first.feasible and again.feasible
    assert again.iterations < 40
    assert abs(again.cost - first.cost) < 0.2 * first.cost


def test_infeasible_request_raises_typed_error(quad_planner: GaitPlanner) -> None:
    schedule = make_schedule(quad_planner.robot, "trot")
    result = quad_planner.solve(schedule, 2.0, warm_start=False)
    assert not result.feasible
    assert "binding limits" in result.message
    names = {name for name, _ in result.binding}
    assert names & {"joint speed", "torque envelope", "joint limits", "friction", "tilt"}
    with pytest.raises(InfeasibleGaitError) as info:
        quad_planner.to_gait(result, "trot")
    assert info.value.binding == result.binding


def test_bad_requests_are_config_errors(quad_planner: GaitPlanner) -> None:
    schedule = make_schedule(quad_planner.robot, "trot")
    with pytest.raises(PlannerConfigError):
        quad_planner.solve(schedule, -11.0)  # |vx| ≤ 10 m/s (backwards allowed)
    other = robots.ContactSchedule(0.5, ("a", "b", "c", "d"), (0, 0, 0, 0), (0.5,) * 4)
    with pytest.raises(PlannerConfigError):
        quad_planner.solve(other, 0.2)


def test_constraint_jacobian_matches_finite_differences(quad_planner: GaitPlanner) -> None:
    nlp = quad_planner._nlp
    g = ca.Function("g", [nlp["x"], nlp["p"]], [nlp["g"]])
    jac = ca.Function("jac_g_x", [nlp["x"], nlp["p"]], [ca.jacobian(nlp["g"], nlp["x"])])
    rng = np.random.default_rng(3)
    from planner.nlp.variables import initial_guess, parameter_vector

    schedule = make_schedule(quad_planner.robot, "trot")
    x = initial_guess(quad_planner.layout, quad_planner.model, schedule)
    x = x + 0.05 * rng.normal(size=x.size)
    p = parameter_vector(schedule, quad_planner.n_knots, 0.25, 0.025)
    jx = jac(x, p).sparse()
    eps = 1e-6
    for _ in range(5):
        d = rng.normal(size=x.size)
        fd = (np.asarray(g(x + eps * d, p)) - np.asarray(g(x - eps * d, p))).ravel() / (2 * eps)
        np.testing.assert_allclose(jx @ d, fd, rtol=1e-5, atol=1e-5 * max(1.0, np.abs(fd).max()))

"""Servo goals: the planner inverts the simulator's servo position loop exactly."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.servo_loop import factory_servo_loops, servo_goals_rad
from sim.servo import servo_params


def test_goals_make_the_sim_servo_produce_the_planned_torque() -> None:
    robot = robots.load("quad12")
    loops = factory_servo_loops(robot)
    rng = np.random.default_rng(0)
    q = rng.uniform(-1.0, 1.0, (5, robot.dof))
    qd = rng.uniform(-3.0, 3.0, (5, robot.dof))
    tau = rng.uniform(-0.5, 0.5, (5, robot.dof))
    goal = servo_goals_rad(q, qd, tau, loops)
    for j, joint in enumerate(robot.joints):
        sp = servo_params(joint.servo)
        assert loops[j].kp_nm_per_rad == sp.kp_nm_per_rad  # one source of truth: sim.servo
        np.testing.assert_allclose(sp.torque_nm(goal[:, j], q[:, j], qd[:, j]), tau[:, j])
    # STS3215 factory loop: ≈ 10 N·m/rad, i.e. a 0.5 N·m load sags the joint ≈ 2.8°
    assert 9.0 < loops[0].kp_nm_per_rad < 11.5


def test_ideal_servo_option_keeps_the_planned_angles() -> None:
    assert PlannerOptions().servo_goals and PlannerOptions().vertical_contact_transitions
    assert not PlannerOptions(servo_goals=False).servo_goals


def test_planner_and_sim_see_the_same_servo_loop() -> None:
    for name in ("quad12", "hex18"):
        robot = robots.load(name)
        for joint, loop in zip(robot.joints, factory_servo_loops(robot), strict=True):
            sp = servo_params(joint.servo)
            assert loop.kp_nm_per_rad == pytest.approx(sp.kp_nm_per_rad)
            assert loop.damping_nm_s_per_rad == pytest.approx(
                sp.kd_nm_s_per_rad + sp.back_emf_nm_s_per_rad
            )

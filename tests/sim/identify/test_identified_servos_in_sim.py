"""`sim` and the planner's servo goals read identified servos (`robots.servo_params`)."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.nlp.servo_loop import advance_by_latency, factory_servo_loops, servo_loops
from robots.servo_params import ServoSetting
from sim.model import SimConditions, build_sim_model
from sim.servo import held_targets


def test_identified_settings_scale_the_actuators_and_add_latency() -> None:
    quad = robots.load("quad12")
    settings = [ServoSetting()] * quad.dof
    settings[2] = ServoSetting(gain_scale=1.5, latency_ms=8.0, strength=0.5)
    base = build_sim_model(quad)
    ident = build_sim_model(quad, SimConditions(strength=0.9), servo_settings=settings)
    kp0, kp1 = base.model.actuator_gainprm[2, 0], ident.model.actuator_gainprm[2, 0]
    assert kp1 == pytest.approx(kp0 * 1.5 * 0.5 * 0.9)
    assert ident.model.actuator_forcerange[2, 1] == pytest.approx(
        base.model.actuator_forcerange[2, 1] * 0.5 * 0.9
    )
    assert ident.servo_latency_s[2] == pytest.approx(0.008)
    assert ident.servo_latency_s[0] == 0.0
    assert ident.model.actuator_gainprm[0, 0] == pytest.approx(kp0 * 0.9)


def test_held_targets_delay_each_joint_by_its_own_latency() -> None:
    stream = np.repeat(np.arange(10.0)[:, None], 2, axis=1)  # sample k = k
    out = held_targets(
        stream, rate_hz=100.0, latency_s=np.array([0.0, 0.02]), dt_s=0.005, n_steps=20,
        initial_rad=np.array([-1.0, -1.0]),
    )  # fmt: skip
    t = np.arange(20) * 0.005
    assert np.array_equal(out[:, 0], np.floor(t * 100 + 1e-6))
    expected = np.floor((t - 0.02) * 100 + 1e-6)
    assert np.array_equal(out[:, 1], np.where(expected < 0, -1.0, expected))


def test_planner_servo_loops_follow_the_identified_servo() -> None:
    quad = robots.load("quad12")
    settings = tuple(ServoSetting(1.2, 10.0, 0.8) for _ in quad.joints)
    f, s = factory_servo_loops(quad)[0], servo_loops(quad, settings)[0]
    assert s.kp_nm_per_rad == pytest.approx(f.kp_nm_per_rad * 1.2 * 0.8)
    servo = quad.joints[0].servo
    emf = servo.stall_torque_nm / servo.no_load_speed_rad_s
    assert s.damping_nm_s_per_rad - 0.8 * emf == pytest.approx(
        1.2 * 0.8 * (f.damping_nm_s_per_rad - emf)
    )
    # goals sent a latency early: a sampled sine comes back phase-advanced by 2π·L/T
    period_s, n = 1.0, 64
    phase = np.arange(n) / n
    goals = np.tile(np.sin(2 * np.pi * phase)[:, None], (1, quad.dof))
    early = advance_by_latency(goals, period_s, servo_loops(quad, settings))
    assert np.allclose(early[:, 0], np.sin(2 * np.pi * (phase + 0.010)), atol=1e-4)
    assert np.array_equal(advance_by_latency(goals, period_s, factory_servo_loops(quad)), goals)

"""Servo model: gains from the catalogue, the torque–speed envelope, zero-order hold, latency."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from robots.robot import Robot
from robots.servo import servo_model
from sim.errors import SimConfigError
from sim.model import SimConditions, build_sim_model
from sim.servo import ServoParams, default_gains, held_targets, servo_params


def test_gains_from_the_manuals() -> None:
    xl430 = servo_params(servo_model("XL430_W250"))
    # e-Manual: KPP = 800/128 PWM-units per tick, 885 = 100 % → 4.60 duty/rad → 6.45 N·m/rad
    assert xl430.duty_per_rad == pytest.approx(800 / 128 * 4096 / (2 * math.pi) / 885)
    assert xl430.kp_nm_per_rad == pytest.approx(6.445, rel=1e-3)
    assert math.degrees(xl430.saturation_error_rad) == pytest.approx(12.4, abs=0.1)
    sts = servo_params(servo_model("STS3215_7V4"))
    assert sts.duty_per_rad == pytest.approx(32 * 0.166)
    assert sts.back_emf_nm_s_per_rad == pytest.approx(1.912 / 4.717)
    assert default_gains(servo_model("AX_12A"))[0] == pytest.approx(1228.8 / (2 * math.pi) / 32)


def test_torque_speed_envelope_clipping() -> None:
    sp = ServoParams("t", stall_torque_nm=2.0, no_load_speed_rad_s=5.0, duty_per_rad=5.0)
    z = np.array(0.0)
    big = np.array(10.0)  # error far beyond saturation: full duty
    for frac in (0.0, 0.25, 0.5, 0.9, 1.0):
        qd = frac * 5.0
        # motoring: at full duty the torque follows the line τ_s (1 − q̇/ω₀)
        assert sp.torque_nm(big, z, qd) == pytest.approx(2.0 * (1 - frac))
        assert sp.torque_nm(-big, z, -qd) == pytest.approx(-2.0 * (1 - frac))
        # braking (documented choice): the DC-motor band gives τ_s (1 + |q̇|/ω₀)
        assert sp.torque_nm(-big, z, qd) == pytest.approx(-2.0 * (1 + frac))
    assert sp.torque_nm(big, z, 6.0) < 0  # beyond no-load speed the motor cannot drive
    lo, hi = sp.envelope_nm(np.array([0.0, 2.5]))
    np.testing.assert_allclose(hi, [2.0, 1.0])
    np.testing.assert_allclose(lo, [-2.0, -3.0])
    # small errors: linear P loop
    assert sp.torque_nm(np.array(0.01), z, z) == pytest.approx(2.0 * 5.0 * 0.01)
    weak = sp.with_strength(0.5)
    assert weak.torque_nm(big, z, 2.5) == pytest.approx(0.5 * 2.0 * 0.5)


def test_mujoco_actuator_reproduces_the_servo_law(quad: Robot) -> None:
    sim = build_sim_model(quad)
    m, d = sim.model, mujoco.MjData(sim.model)
    rng = np.random.default_rng(0)
    d.qpos[:] = m.qpos0
    d.qpos[sim.qpos_adr] = quad.nominal_stance_rad
    omega = np.array([s.no_load_speed_rad_s for s in sim.servos])
    qd = rng.uniform(-0.9, 0.9, sim.n_joints) * omega
    d.qvel[sim.dof_adr] = qd
    target = d.qpos[sim.qpos_adr] + rng.uniform(-0.6, 0.6, sim.n_joints)
    d.ctrl[:] = target
    mujoco.mj_forward(m, d)
    q = d.qpos[sim.qpos_adr]
    expected = np.array(
        [sp.torque_nm(t, qi, v) for sp, t, qi, v in zip(sim.servos, target, q, qd, strict=True)]
    )
    got = d.actuator_force - sim.back_emf_nm_s_per_rad * qd
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)
    # the back-EMF is in the joint damping, on top of the MJCF's gearbox damping
    base = mujoco.MjModel.from_xml_path(str(quad.mjcf_path))
    np.testing.assert_allclose(
        m.dof_damping[sim.dof_adr] - base.dof_damping[sim.dof_adr], sim.back_emf_nm_s_per_rad
    )
    assert np.all(np.abs(d.actuator_force) <= sim.stall_torque_nm + 1e-12)


def test_zero_order_hold_at_100hz() -> None:
    stream = np.arange(20, dtype=float)[:, None]  # sample k has value k
    out = held_targets(
        stream, rate_hz=100.0, latency_s=0.0, dt_s=0.002, n_steps=50, initial_rad=np.array([-1.0])
    )[:, 0]
    # 5 physics steps of 2 ms per 10 ms tick, value constant within a tick
    np.testing.assert_array_equal(out, np.repeat(np.arange(10.0), 5))
    chunk = held_targets(
        stream,
        rate_hz=100.0,
        latency_s=0.0,
        dt_s=0.002,
        n_steps=10,
        initial_rad=np.array([-1.0]),
        first_step=20,
    )[:, 0]
    np.testing.assert_array_equal(chunk, out[20:30])


def test_latency_delays_the_stream() -> None:
    stream = np.arange(20, dtype=float)[:, None]
    out = held_targets(
        stream, rate_hz=100.0, latency_s=0.03, dt_s=0.002, n_steps=50, initial_rad=np.array([-1.0])
    )[:, 0]
    assert np.all(out[:15] == -1.0)  # nothing arrives for 30 ms
    np.testing.assert_array_equal(out[15:], np.repeat(np.arange(7.0), 5))
    with pytest.raises(SimConfigError):
        held_targets(
            stream, rate_hz=0.0, latency_s=0.0, dt_s=0.002, n_steps=5, initial_rad=np.zeros(1)
        )
    with pytest.raises(SimConfigError):
        held_targets(
            stream, rate_hz=100.0, latency_s=-0.01, dt_s=0.002, n_steps=5, initial_rad=np.zeros(1)
        )


def _first_move_s(quad: Robot, latency_s: float) -> float:
    """Robot floating without gravity; one joint's goal steps at t = 0.1 s: when does it move?"""
    sim = build_sim_model(quad, SimConditions())
    m = sim.model
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    d.qpos[2] = 1.0  # in the air
    stance = np.asarray(quad.nominal_stance_rad)
    d.qpos[sim.qpos_adr] = stance
    stream = np.tile(stance, (40, 1))
    stream[10:, 1] += 0.3  # joint 1's goal steps at tick 10 (0.1 s)
    ctrl = held_targets(
        stream,
        rate_hz=100.0,
        latency_s=latency_s,
        dt_s=m.opt.timestep,
        n_steps=200,
        initial_rad=stance,
    )
    for i in range(200):
        d.ctrl[:] = ctrl[i]
        mujoco.mj_step(m, d)
        if abs(d.qpos[sim.qpos_adr[1]] - stance[1]) > 1e-4:
            return float(d.time)
    raise AssertionError("joint never moved")


def test_latency_delays_the_response(quad: Robot) -> None:
    t0 = _first_move_s(quad, 0.0)
    t1 = _first_move_s(quad, 0.025)
    assert 0.1 <= t0 <= 0.106
    assert t1 - t0 == pytest.approx(0.025, abs=0.0021)


def test_bad_servo_params() -> None:
    with pytest.raises(SimConfigError):
        ServoParams("x", stall_torque_nm=0.0, no_load_speed_rad_s=1.0, duty_per_rad=1.0)
    with pytest.raises(SimConfigError):
        SimConditions(strength=0.0)
    with pytest.raises(SimConfigError):
        SimConditions(friction=-1.0)

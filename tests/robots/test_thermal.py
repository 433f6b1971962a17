"""Thermal model of the servos (robots.thermal) and the voltage-scaled envelope (robots.voltage)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import robots
from robots.errors import RobotConfigError
from robots.servo import load_catalogue, servo_model
from robots.thermal import (
    ELECTRICAL,
    REFERENCE,
    joint_heating,
    thermal_model,
)
from robots.voltage import (
    robot_at_voltage,
    servo_at_voltage,
    voltage_margin,
    voltage_range_v,
    voltage_scale,
)


def test_every_electrical_entry_is_a_catalogue_servo() -> None:
    catalogue = load_catalogue()
    for e in ELECTRICAL:
        assert e.servo in catalogue, e.servo
        assert e.stall_current_a > e.no_load_current_a >= 0.0
        thermal_model(catalogue[e.servo])  # builds


def test_reference_test_is_reproduced() -> None:
    """robonine: an STS3215 C018 at 12 V holding 1 kg at 15 cm settles at 48 °C (25 °C room)."""
    m = thermal_model(servo_model("STS3215_12V"))
    torque = 1.0 * 9.80665 * 0.15
    p = float(m.power_w(torque))
    assert 25.0 + m.steady_rise_k(p) == pytest.approx(48.0, abs=0.05)
    assert m.rise_k(p, 600.0) >= 0.95 * m.steady_rise_k(p)  # "stable after 10 minutes"
    # the 7.4 V STS3215 shares the housing: same R_th and τ_th, its own winding
    low = thermal_model(servo_model("STS3215_7V4"))
    assert (low.r_th_k_per_w, low.tau_th_s) == (m.r_th_k_per_w, m.tau_th_s)
    assert low.winding_resistance_ohm == pytest.approx(7.4 / 2.7)


def test_power_follows_current_squared() -> None:
    m = thermal_model(servo_model("XL430_W250"))
    assert float(m.power_w(m.stall_torque_nm)) == pytest.approx(11.1 * 1.3)  # V·I at stall
    assert float(m.power_w(0.5 * m.stall_torque_nm)) == pytest.approx(11.1 * 1.3 / 4)
    assert float(m.power_w(-0.5 * m.stall_torque_nm)) == float(m.power_w(0.5 * m.stall_torque_nm))


def test_mass_scaling_bigger_servo_sheds_heat_better_but_slower() -> None:
    small, big = thermal_model(servo_model("XL_320")), thermal_model(servo_model("MX_64_P2"))
    assert small.r_th_k_per_w > REFERENCE.r_th_k_per_w > big.r_th_k_per_w
    assert small.tau_th_s < REFERENCE.tau_th_s < big.tau_th_s
    assert "estimated" in big.source


def test_servo_without_published_current_is_one_line_error() -> None:
    with pytest.raises(RobotConfigError, match=r"MG996R.*no published stall current"):
        thermal_model(servo_model("MG996R"))


def test_rise_series_matches_closed_form_and_time_to_limit() -> None:
    m = thermal_model(servo_model("STS3215_7V4"))
    p = 30.0  # 58 K steady: over the 70 °C limit from 25 °C
    series = m.rise_series_k(np.full(6000, p), 0.1)
    assert series[-1] == pytest.approx(float(m.rise_k(p, 600.0)), rel=1e-9)
    t = m.time_to_limit_s(p, 25.0)
    assert t is not None
    assert 25.0 + float(m.rise_k(p, t)) == pytest.approx(m.max_temperature_c, abs=1e-6)
    assert m.time_to_limit_s(1.0, 25.0) is None  # 1 W never reaches 70 °C
    assert m.time_to_limit_s(p, 25.0, start_c=80.0) == 0.0
    assert m.heating_rate_k_per_s(p, 0.0) == pytest.approx(p * m.r_th_k_per_w / m.tau_th_s)


def test_joint_heating_of_a_square_wave() -> None:
    m = thermal_model(servo_model("STS3215_7V4"))
    tau = np.r_[np.full(50, 1.0), np.zeros(50)]
    h = joint_heating("knee", m, tau, bout_s=600.0, ambient_c=25.0)
    assert h.mean_power_w == pytest.approx(0.5 * float(m.power_w(1.0)))
    assert h.temperature_after_bout_c == pytest.approx(25.0 + h.rise_after_bout_k)
    assert h.minutes_to_limit is None or h.minutes_to_limit > 0
    assert h.to_dict()["joint"] == "knee"


def test_envelope_scales_with_voltage() -> None:
    s = servo_model("STS3215_7V4")
    low = servo_at_voltage(s, 7.0)
    assert low.stall_torque_nm == pytest.approx(s.stall_torque_nm * 7.0 / 7.4)
    assert low.no_load_speed_rad_s == pytest.approx(s.no_load_speed_rad_s * 7.0 / 7.4)
    assert voltage_scale(low) == pytest.approx(7.0 / 7.4)
    assert servo_at_voltage(low, 7.0) == low  # never compounds
    assert low.torque_limit_nm(1.0) < s.torque_limit_nm(1.0)
    for bad in (5.9, 8.5, math.nan, math.inf):
        with pytest.raises(RobotConfigError, match=r"STS3215_7V4.*outside its range"):
            servo_at_voltage(s, bad)


def test_robot_at_voltage_and_margin() -> None:
    bot = robots.load("quad12")
    assert voltage_range_v(bot) == (6.0, 8.4)
    low = robot_at_voltage(bot, 7.0)
    assert low.fingerprint == bot.fingerprint
    assert robot_at_voltage(bot, None) is bot
    assert all(j.servo.stall_torque_nm < 1.912 for j in low.joints)
    tau = np.zeros((10, bot.dof))
    tau[3, 2] = -1.4
    margin = voltage_margin(low, tau, 7.0)
    w = margin.worst
    assert w.joint == bot.joint_names[2]
    assert w.fraction_at_supply == pytest.approx(1.4 / (1.912 * 7.0 / 7.4))
    assert w.fraction_at_nominal == pytest.approx(1.4 / 1.912)
    assert "at 7.00 V" in margin.summary() and "7.40 V nominal" in margin.summary()

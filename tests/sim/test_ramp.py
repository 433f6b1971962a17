"""robots.ramp: the shared min-jerk ramp-in (used by sim.validate and the hardware player)."""

from __future__ import annotations

import numpy as np
import pytest

from robots.ramp import MIN_JERK_PEAK_SPEED, MinJerkRamp, min_jerk, ramp_duration_s, ramp_to


def test_min_jerk_endpoints_and_symmetry() -> None:
    assert min_jerk(0.0) == 0.0 and min_jerk(1.0) == 1.0
    u = np.linspace(0, 1, 101)
    np.testing.assert_allclose(min_jerk(u) + min_jerk(1 - u), 1.0, atol=1e-12)
    assert np.all(np.diff(min_jerk(u)) >= 0)


def test_ramp_positions_velocities_and_hold() -> None:
    ramp = MinJerkRamp(np.array([0.0, 1.0]), np.array([1.0, -1.0]), 2.0)
    np.testing.assert_allclose(ramp.positions(0.0), [0.0, 1.0])
    np.testing.assert_allclose(ramp.positions(2.0), [1.0, -1.0])
    np.testing.assert_allclose(ramp.positions(5.0), [1.0, -1.0])  # held after T
    np.testing.assert_allclose(ramp.velocities(np.array([0.0, 2.0])), 0.0, atol=1e-12)
    t = np.linspace(0, 2, 2001)
    fd = np.gradient(ramp.positions(t), t, axis=0)
    np.testing.assert_allclose(ramp.velocities(t)[1:-1], fd[1:-1], atol=1e-4)
    assert ramp.peak_speed_rad_s == pytest.approx(MIN_JERK_PEAK_SPEED * 2.0 / 2.0)
    assert np.max(np.abs(ramp.velocities(t))) == pytest.approx(ramp.peak_speed_rad_s, rel=1e-5)


def test_duration_respects_speed_cap() -> None:
    assert ramp_duration_s(np.zeros(3), np.full(3, 0.1), 5.0) == 1.0
    d = ramp_duration_s(np.zeros(2), np.array([3.0, 0.0]), 1.0)
    assert d == pytest.approx(MIN_JERK_PEAK_SPEED * 3.0)
    assert ramp_to(np.zeros(2), np.array([3.0, 0.0]), 1.0).peak_speed_rad_s == pytest.approx(1.0)


def test_bad_inputs() -> None:
    with pytest.raises(ValueError):
        MinJerkRamp(np.zeros(2), np.zeros(3), 1.0)
    with pytest.raises(ValueError):
        MinJerkRamp(np.zeros(2), np.zeros(2), 0.0)
    with pytest.raises(ValueError):
        ramp_duration_s(np.zeros(2), np.ones(2), 0.0)

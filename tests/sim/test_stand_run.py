"""`sim.validate` at zero command and from/to the stand (issue #14).

A stand or stepping in place is judged by drift instead of a speed ratio; a run can hold the
gait's stand (its mean pose) after the ramp-in and end the way a completed player run does: the
gait blended out to the stand, then the stand held. Synthetic gaits (`sim.synthetic`), no
planner."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from robots.gait import Gait
from robots.ramp import gait_exit, gait_mean_pose
from robots.robot import Robot
from sim.errors import SimConfigError
from sim.rollout import RAMP_SPEED_FRACTION, RunSettings
from sim.synthetic import kinematic_gait, trot_schedule
from sim.validate import PassCriteria, judge, standing_command, validate


def _check(res: object, name: str) -> tuple[str, bool, str]:
    checks = res.checks  # type: ignore[attr-defined]
    return next(c for c in checks if c[0] == name)


def test_a_stand_is_judged_by_drift_not_by_a_speed_ratio(quad: Robot, quad_stand: Gait) -> None:
    cycles = math.ceil(10.0 / quad_stand.period_s)
    res = validate(quad_stand, quad, cycles)
    assert res.passed, res.reasons
    assert standing_command(res.metrics)
    names = [c[0] for c in res.checks]
    assert "speed" not in names and "drift" in names
    for kept in ("no fall", "peak torque", "heading", "tilt", "foot slip"):
        assert kept in names
    detail = _check(res, "drift")[2]
    assert f"whole {res.metrics.duration_s:.1f} s run" in detail  # the duration, not cycles
    assert res.metrics.duration_s >= 10.0


def test_drift_at_zero_command_fails_in_leg_lengths(quad: Robot, quad_stand: Gait) -> None:
    res = validate(quad_stand, quad, 4)
    leg = quad.leg_length_m
    c = PassCriteria()
    slow = replace(res.metrics, achieved_speed_m_s=0.9 * c.max_drift_leg_lengths_per_s * leg)
    assert _check_of(judge(slow, c, leg), "drift")[1]
    creeping = replace(res.metrics, achieved_speed_m_s=1.1 * c.max_drift_leg_lengths_per_s * leg)
    assert not _check_of(judge(creeping, c, leg), "drift")[1]
    lurched = replace(res.metrics, lateral_drift_m=1.1 * c.max_run_drift_leg_lengths * leg)
    ok, detail = _check_of(judge(lurched, c, leg), "drift")[1:]
    assert not ok and f"limit {c.max_run_drift_leg_lengths * leg * 1000:.0f} mm" in detail
    # the same drift on a robot with legs twice as long passes: the limits scale with L
    assert _check_of(judge(creeping, c, 2 * leg), "drift")[1]


def _check_of(checks: tuple[tuple[str, bool, str], ...], name: str) -> tuple[str, bool, str]:
    return next(c for c in checks if c[0] == name)


def test_a_walk_keeps_its_speed_check(hex18: Robot, hex_tripod: Gait) -> None:
    res = validate(hex_tripod, hex18, 4)
    assert not standing_command(res.metrics)
    assert res.checks[0][0] == "speed"


def test_stepping_in_place_passes_with_the_drift_check(hex18: Robot) -> None:
    in_place = kinematic_gait(hex18, trot_schedule(hex18, 0.5, 0.6), 0.0)
    res = validate(in_place, hex18, 8)
    assert res.passed, res.reasons
    assert "drift" in [c[0] for c in res.checks]
    assert res.metrics.stances >= 6 * 4  # it does step


def test_a_run_starts_and_ends_at_the_stand(hex18: Robot, hex_tripod: Gait) -> None:
    cycles, stand_s = 6, 0.5
    plain = validate(hex_tripod, hex18, cycles)
    res = validate(hex_tripod, hex18, cycles, stand_s=stand_s, end_at_stand=True)
    assert res.passed, res.reasons
    traj = res.trajectory
    assert traj is not None and traj.cycles_run == cycles
    speed = RAMP_SPEED_FRACTION * np.array([j.servo.no_load_speed_rad_s for j in hex18.joints])
    exit_s = gait_exit(hex_tripod, 0.0, speed).duration_s
    assert traj.gait_end_s == pytest.approx(traj.gait_start_s + cycles * hex_tripod.period_s)
    assert res.metrics.duration_s == pytest.approx(
        plain.metrics.duration_s + 2 * stand_s + exit_s, abs=2 * traj.dt_s)
    mean = gait_mean_pose(hex_tripod)
    # the stand held after the ramp and at the end
    entry = traj.ramp
    t0 = traj.gait_start_s - entry.duration_s + entry.ramp.duration_s  # the hold begins
    hold = (traj.time_s > t0 + 0.01) & (traj.time_s < t0 + stand_s - 0.01)
    np.testing.assert_allclose(traj.planned_rad[hold], np.broadcast_to(mean, (hold.sum(), 18)),
                               atol=1e-12)
    end_hold = traj.time_s > traj.gait_end_s + exit_s + 0.01
    assert end_hold.sum() > 0
    np.testing.assert_allclose(traj.planned_rad[end_hold],
                               np.broadcast_to(mean, (end_hold.sum(), 18)), atol=1e-12)
    # the blend-out starts where the gait left off (no jump in the stream)
    step = np.abs(np.diff(traj.planned_rad, axis=0)).max()
    gait_part = (traj.time_s > traj.gait_start_s) & (traj.time_s < traj.gait_end_s)
    assert step <= 1.5 * np.abs(np.diff(traj.planned_rad[gait_part], axis=0)).max()
    # the steady metrics stop at the last cycle: the same walk as without the ending
    assert res.metrics.achieved_speed_m_s == pytest.approx(plain.metrics.achieved_speed_m_s,
                                                           rel=0.05)
    # it stands still at the end, on every foot, without having turned on the way
    assert np.abs(traj.base_linvel_m_s[end_hold][-50:, :2]).max() < 0.01
    assert np.all(traj.foot_contacts[end_hold][-1] > 0)
    assert abs(res.metrics.heading_error_rad) < math.radians(2.0)
    assert res.conditions["stand_s"] == stand_s and res.conditions["end_at_stand"] == 1


@pytest.mark.parametrize("stand_s", [-1.0, float("nan"), 100.0])
def test_a_bad_stand_hold_is_refused(stand_s: float) -> None:
    with pytest.raises(SimConfigError, match="stand_s"):
        RunSettings(stand_s=stand_s)


def test_the_exit_starts_on_the_gait_and_ends_at_rest_on_the_mean_pose(hex_tripod: Gait) -> None:
    t0 = 0.37 * hex_tripod.period_s  # anywhere in the cycle
    ex = gait_exit(hex_tripod, t0, 2.0)
    assert ex.cycles >= 1 and ex.duration_s == pytest.approx(ex.cycles * hex_tripod.period_s)
    np.testing.assert_allclose(ex.positions(0.0), hex_tripod.joint_targets(t0), atol=1e-12)
    np.testing.assert_allclose(ex.positions(ex.duration_s), gait_mean_pose(hex_tripod),
                               atol=1e-12)
    np.testing.assert_allclose(ex.positions(ex.duration_s + 5.0), gait_mean_pose(hex_tripod),
                               atol=1e-12)
    h = 1e-5  # C¹ at both ends: the gait's own speed at the start, zero at the stand
    v0 = (ex.positions(h) - ex.positions(0.0)) / h
    np.testing.assert_allclose(v0, hex_tripod.joint_velocities(t0), atol=1e-2)
    v1 = (ex.positions(ex.duration_s) - ex.positions(ex.duration_s - h)) / h
    np.testing.assert_allclose(v1, 0.0, atol=1e-3)

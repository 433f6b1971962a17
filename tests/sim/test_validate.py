"""validate(): standing passes, a kinematic tripod walks at its speed, bad gaits fail for the
right reason; the result is JSON-safe and goes into the gait file."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import robots.gait as gait_io
from robots.errors import GaitFileError
from robots.gait import Gait, Velocity
from robots.robot import Robot
from robots.schedule import ContactSchedule
from sim.errors import SimConfigError
from sim.synthetic import feet_offset_pose, kinematic_gait, standing_gait, trot_schedule
from sim.validate import PassCriteria, criterion_excess, judge, validate, validate_and_annotate


def _check(result: object, name: str) -> bool:
    return next(ok for n, ok, _ in result.checks if n == name)  # type: ignore[attr-defined]


@pytest.mark.parametrize("robot_name", ["quad12", "hex18"])
def test_standing_passes(robot_name: str, request: pytest.FixtureRequest) -> None:
    robot: Robot = request.getfixturevalue("quad" if robot_name == "quad12" else "hex18")
    res = validate(standing_gait(robot), robot, cycles=6)
    assert res.passed, res.reasons
    m = res.metrics
    assert not m.fell and m.peak_torque_fraction < 0.8
    assert abs(m.achieved_speed_m_s) < 0.005
    assert m.base_height_min_m > 0.9 * robot.stance_base_height_m
    assert m.lateral_drift_per_m is None  # no distance walked → per-metre drift undefined
    assert m.stances == 0  # feet never lift: no complete stance


def test_kinematic_tripod_walks_at_commanded_speed(hex18: Robot, hex_tripod: Gait) -> None:
    progress: list[tuple[int, int]] = []
    res = validate(hex_tripod, hex18, cycles=8, progress=lambda d, t: progress.append((d, t)))
    assert res.passed, res.reasons
    m = res.metrics
    assert m.achieved_speed_m_s == pytest.approx(0.1, rel=0.1)
    assert m.distance_m == pytest.approx(m.achieved_speed_m_s * m.steady_duration_s, rel=1e-6)
    assert m.stances >= 6 * (8 - 2 - 1)  # every foot steps once per steady cycle
    assert m.cost_of_transport is not None and m.cost_of_transport > 0
    assert progress[-1][0] == progress[-1][1] and len(progress) >= 8
    assert len(res.joints) == hex18.dof


def test_feet_lifted_gait_falls(quad: Robot) -> None:
    """Joint targets that pull every foot up: the body drops to the ground → fail, 'no fall'."""
    feet = len(quad.legs)
    up = np.zeros((feet, 3))
    up[:, 2] = 0.5 * quad.stance_base_height_m
    q = feet_offset_pose(quad, up)
    sched = ContactSchedule(0.5, quad.foot_names, (0.0,) * feet, (1.0,) * feet)
    gait = Gait.create(
        robot=quad,
        knots_rad=np.tile(q, (8, 1)),
        schedule=sched,
        velocity=Velocity(),
        gait_label="lifted",
    )
    res = validate(gait, quad, cycles=10)
    assert not res.passed and res.metrics.fell
    assert not _check(res, "no fall")
    assert any(r.startswith("no fall") for r in res.reasons)
    assert res.trajectory is not None and res.trajectory.stopped_early  # no point running 10 cycles


def test_too_fast_gait_exceeds_the_torque_envelope(hex18: Robot) -> None:
    """The same tripod at 3× speed and a 0.3 s period asks more than 80 % of stall torque."""
    gait = kinematic_gait(hex18, trot_schedule(hex18, 0.3, 0.6), 0.3, lift_m=0.04)
    res = validate(gait, hex18, cycles=8)
    assert not res.passed
    assert not _check(res, "peak torque")
    assert res.metrics.peak_torque_fraction > 0.8
    assert any(r.startswith("peak torque") for r in res.reasons)


def test_weak_servos_fail_a_passing_gait(quad: Robot, quad_stand: Gait) -> None:
    res = validate(quad_stand, quad, cycles=4, payload_kg=3 * quad.mass_kg)
    assert not res.passed and not _check(res, "peak torque")


def test_result_is_json_safe_and_annotates_the_gait(
    hex18: Robot, hex_tripod: Gait, tmp_path: Path
) -> None:
    res = validate(hex_tripod, hex18, cycles=4)
    doc = res.to_dict()
    text = json.dumps(doc, allow_nan=False)
    assert json.loads(text)["passed"] == res.passed
    assert doc["conditions"]["rate_hz"] == 100.0  # type: ignore[index]
    annotated = validate_and_annotate(hex_tripod, hex18, cycles=4)
    path = tmp_path / "g.json"
    gait_io.save(annotated, path)
    back = gait_io.load(path, hex18)
    assert back.validation is not None
    assert back.validation["schema"] == "gaitsmith.validation/1"
    assert back.validation["passed"] == res.passed
    assert back.validation["metrics"]["achieved_speed_m_s"] == pytest.approx(
        res.metrics.achieved_speed_m_s
    )


def test_stricter_criteria_change_the_verdict(hex18: Robot, hex_tripod: Gait) -> None:
    res = validate(
        hex_tripod, hex18, cycles=4, criteria=PassCriteria(max_peak_torque_fraction=0.05)
    )
    assert not res.passed and [n for n, ok, _ in res.checks if not ok] == ["peak torque"]


def test_bad_settings_and_wrong_robot(quad: Robot, hex18: Robot, quad_stand: Gait) -> None:
    with pytest.raises(SimConfigError):
        validate(quad_stand, quad, cycles=2)
    with pytest.raises(SimConfigError):
        validate(quad_stand, quad, cycles=4, rate_hz=0.0)
    with pytest.raises(SimConfigError):
        validate(quad_stand, quad, cycles=4, friction=0.0)
    with pytest.raises(GaitFileError):
        validate(quad_stand, hex18, cycles=4)


def test_criterion_excess_agrees_with_every_check_of_judge(hex18: Robot, hex_tripod: Gait) -> None:
    """Each criterion's excess is ≤ 0 exactly where `judge` passes it, and measures how far past
    its limit the metric is: the tripod's own metrics and variants pushed past each limit."""
    res = validate(hex_tripod, hex18, cycles=4, keep_trajectory=False)
    c, leg = res.criteria, hex18.leg_length_m
    m0 = res.metrics
    variants = [m0,
                replace(m0, achieved_speed_m_s=m0.commanded_speed_m_s * 0.85),
                replace(m0, achieved_speed_m_s=m0.commanded_speed_m_s * 0.905),
                replace(m0, fell=True, fall_time_s=1.0, fall_reason="tilt"),
                replace(m0, peak_torque_fraction=0.81),
                replace(m0, heading_error_rad=-math.radians(5.02)),
                replace(m0, heading_error_rad=math.radians(4.9)),
                replace(m0, lateral_drift_per_m=0.30),
                replace(m0, yaw_drift_rad_per_m=0.36),
                replace(m0, tilt_max_rad=math.radians(25.0)),
                replace(m0, slip_mean_m=0.2 * leg),
                replace(m0, commanded_speed_m_s=0.0, achieved_speed_m_s=0.001),
                replace(m0, commanded_speed_m_s=0.0, achieved_speed_m_s=0.2),
                replace(m0, commanded_yaw_rate_rad_s=0.3, achieved_yaw_rate_rad_s=0.2),
                replace(m0, commanded_vy_m_s=0.05, achieved_vy_m_s=0.02)]
    for m in variants:
        checks = judge(m, c, leg)
        excess = criterion_excess(m, c, leg)
        assert [n for n, _, _ in checks] == [n for n, _ in excess]
        assert [ok for _, ok, _ in checks] == [e <= 0.0 for _, e in excess], excess
    by_name = dict(criterion_excess(variants[5], c, leg))
    assert by_name["heading"] == pytest.approx(0.02 / 5.0)  # 5.02° against 5°: 0.4 % past
    assert dict(criterion_excess(variants[1], c, leg))["speed"] == pytest.approx(0.5)
    assert dict(criterion_excess(variants[3], c, leg))["no fall"] == math.inf
    assert dict(criterion_excess(variants[4], c, leg))["peak torque"] == pytest.approx(
        0.81 / 0.80 - 1.0)

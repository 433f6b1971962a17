"""robots.attitude: the law's settings, the support filter, the clip, the map's structure."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import robots
from robots.attitude import (
    ATTITUDE_GAIN_KEY,
    DEFAULT_MAX_OFFSET_RAD,
    TWO_LEG_IMU_GAIN,
    AttitudeError,
    AttitudeLaw,
    attitude_offsets,
    check_gain,
    default_attitude_gain,
    gait_attitude_gain,
    roll_pitch,
    support_weights,
    validated_attitude_gain,
)
from robots.attitude_maps import attitude_map
from robots.errors import RobotConfigError
from robots.gait import Gait, Velocity
from robots.schedule import ContactSchedule


@pytest.mark.parametrize("bad", [-0.1, 2.5, math.nan, math.inf, True, "1"])
def test_gain_outside_its_bound_is_refused_naming_the_option(bad: object) -> None:
    with pytest.raises(AttitudeError, match="--attitude-gain"):
        check_gain("--attitude-gain", bad)


def test_law_settings_are_checked() -> None:
    assert check_gain("g", 1) == 1.0
    with pytest.raises(AttitudeError, match="max_offset_rad"):
        AttitudeLaw(0.5, max_offset_rad=0.0)
    with pytest.raises(AttitudeError, match="pivot_fraction"):
        AttitudeLaw(0.5, pivot_fraction=1.5)
    with pytest.raises(AttitudeError, match="support_ramp_phase"):
        AttitudeLaw(0.5, support_ramp_phase=0.5)


def test_roll_pitch_of_known_rotations() -> None:
    a = 0.3
    about_x = np.array([math.cos(a / 2), math.sin(a / 2), 0.0, 0.0])
    about_y = np.array([math.cos(a / 2), 0.0, math.sin(a / 2), 0.0])
    np.testing.assert_allclose(roll_pitch(about_x), [a, 0.0], atol=1e-12)
    np.testing.assert_allclose(roll_pitch(about_y), [0.0, a], atol=1e-12)
    # a turned robot still reads its own roll: yaw 1 rad, then roll a (z-y'-x'')
    yaw = np.array([math.cos(0.5), 0.0, 0.0, math.sin(0.5)])
    w1, x1, y1, z1 = yaw
    w2, x2, y2, z2 = about_x
    q = np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                  w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    np.testing.assert_allclose(roll_pitch(q), [a, 0.0], atol=1e-12)


def test_support_weights_are_zero_in_swing_and_ramp_smoothly_at_the_edges() -> None:
    sched = ContactSchedule(1.0, ("a", "b"), (0.0, 0.5), (0.6, 0.6))
    w = np.array([support_weights(sched, p, 0.05) for p in np.linspace(0, 1, 1001)])
    assert np.all((w >= 0) & (w <= 1))
    np.testing.assert_array_equal(w[700, 0], 0.0)  # phase 0.7: foot a is in swing
    assert w[300, 0] == 1.0 and w[300, 1] == 0.0  # mid-stance of a, swing of b
    assert 0.0 < w[10, 0] < 1.0  # just after touchdown: ramping in
    assert np.max(np.abs(np.diff(w, axis=0))) < 0.05  # no step at touchdown or lift-off
    stand = ContactSchedule(1.0, ("a",), (0.0,), (1.0,))
    assert support_weights(stand, 0.3, 0.05)[0] == 1.0


def test_swing_legs_get_no_offset_and_every_offset_is_clipped() -> None:
    bot = robots.load("biped")
    amap = attitude_map(bot)
    law = AttitudeLaw(1.0)
    left = list(amap.legs[0].joint_index)
    right = list(amap.legs[1].joint_index)
    off = attitude_offsets(law, amap, np.array([0.05, -0.04]), np.array([1.0, 0.0]), 1.0)
    assert np.all(off[right] == 0.0) and np.max(np.abs(off[left])) > 0.01
    big = attitude_offsets(law, amap, np.array([1.0, 1.0]), np.array([1.0, 1.0]), 1.0)
    assert np.max(np.abs(big)) == pytest.approx(DEFAULT_MAX_OFFSET_RAD)
    # nothing before the blend, nothing at gain 0, nothing without support
    assert not np.any(attitude_offsets(law, amap, np.array([0.1, 0.1]), np.ones(2), 0.0))
    assert not np.any(attitude_offsets(AttitudeLaw(0.0), amap, np.array([0.1, 0.1]),
                                       np.ones(2), 1.0))
    assert not np.any(attitude_offsets(law, amap, np.array([0.1, 0.1]), np.zeros(2), 1.0))


def test_hip_strategy_turns_the_trunk_through_the_hips() -> None:
    """At the default pivot (the base) a pitch correction on one stance leg of the biped moves
    the hip pitch most; at the support pivot (the ankle strategy) the ankle pitch does. Joints
    are told apart here only to check the map the kinematics gave, the law never reads names."""
    bot = robots.load("biped")
    amap = attitude_map(bot)
    names = bot.joint_names
    leg = amap.legs[0]
    hip, ankle = names.index("l_hip_pitch"), names.index("l_ankle_pitch")
    hip_strategy = amap.joint_offsets(np.array([0.0, 0.05]), np.array([1.0, 0.0]), 1.0)
    ankle_strategy = amap.joint_offsets(np.array([0.0, 0.05]), np.array([1.0, 0.0]), 0.0)
    in_leg = np.abs(hip_strategy[list(leg.joint_index)])
    assert abs(hip_strategy[hip]) == np.max(in_leg) and abs(hip_strategy[hip]) > 0.04
    assert abs(ankle_strategy[ankle]) > 3 * abs(ankle_strategy[hip])
    assert leg.twist_to_joints.shape == (6, 6)


def test_imu_section_is_validated(quad_copy: Path) -> None:
    toml = quad_copy / "robot.toml"
    base = toml.read_text()
    toml.write_text(base + '\n[imu]\ndescription = "torso IMU"\nattitude_gain = 0.3\n')
    bot = robots.load(str(quad_copy))
    assert bot.imu is not None and bot.imu.attitude_gain == 0.3
    assert default_attitude_gain(bot)[0] == 0.3  # an explicit gain wins on any body
    for bad, where in (("attitude_gain = 5", "[imu].attitude_gain"),
                       ("attitude_gain = nan", "[imu].attitude_gain"),
                       ("gain = 1", "[imu]")):
        toml.write_text(base + f"\n[imu]\n{bad}\n")
        with pytest.raises(RobotConfigError, match=re.escape(where)):
            robots.load(str(quad_copy))


def test_default_gain_rule_follows_legs_and_imu(quad_copy: Path) -> None:
    """A biped that declares an IMU closes the loop by default; one without, or a quadruped with
    one, stays open loop."""
    assert default_attitude_gain(robots.load("biped"))[0] == TWO_LEG_IMU_GAIN
    assert default_attitude_gain(robots.load("quad12"))[0] == 0.0
    (quad_copy / "robot.toml").write_text((quad_copy / "robot.toml").read_text() + "\n[imu]\n")
    quad = robots.load(str(quad_copy))
    assert quad.imu is not None and default_attitude_gain(quad)[0] == 0.0
    biped = robots.load("biped")
    assert default_attitude_gain(replace(biped, imu=None))[0] == 0.0
    # a run (flight phase) stays open loop; a walk of the same robot closes it
    knots = np.tile(np.asarray(biped.nominal_stance_rad), (12, 1))
    for duty, gain in ((0.42, 0.0), (0.6, TWO_LEG_IMU_GAIN)):
        sched = ContactSchedule(0.5, biped.foot_names, (0.0, 0.5), (duty, duty))
        gait = Gait.create(robot=biped, knots_rad=knots, schedule=sched, velocity=Velocity(0.3),
                           gait_label="g")
        assert default_attitude_gain(biped, gait)[0] == gain


def test_a_gait_gets_the_asked_gain_else_the_rule() -> None:
    """`gait_attitude_gain`, the one rule every MuJoCo judgement applies: an explicit gain
    (0: open loop) on any gait and body, checked; else the default rule per gait."""
    biped = robots.load("biped")
    knots = np.tile(np.asarray(biped.nominal_stance_rad), (12, 1))
    run = Gait.create(robot=biped, knots_rad=knots, velocity=Velocity(0.3), gait_label="g",
                      schedule=ContactSchedule(0.5, biped.foot_names, (0.0, 0.5), (0.42, 0.42)))
    assert gait_attitude_gain(biped, run) == default_attitude_gain(biped, run) == (
        0.0, "a run (flight phase) stays open loop")
    assert gait_attitude_gain(biped, run, 1.5) == (1.5, "asked for")
    assert gait_attitude_gain(biped, None, 0.0)[0] == 0.0
    assert gait_attitude_gain(biped)[0] == TWO_LEG_IMU_GAIN
    with pytest.raises(AttitudeError, match="attitude gain must be from 0 to 2"):
        gait_attitude_gain(biped, run, 2.5)


def test_the_validated_gain_is_read_from_the_verdict_conditions() -> None:
    assert validated_attitude_gain({"conditions": {ATTITUDE_GAIN_KEY: 0.5}}) == 0.5
    for bad in (None, {}, {"conditions": None}, {"conditions": {ATTITUDE_GAIN_KEY: True}},
                {"conditions": {ATTITUDE_GAIN_KEY: float("nan")}}):
        assert validated_attitude_gain(bad) == 0.0

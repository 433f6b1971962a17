"""The built-in biped: a documented 12-DOF flat-footed build on catalogue servos that stands."""

from __future__ import annotations

import mujoco
import numpy as np

import robots
from robots.servo import load_catalogue
from sim.stand_check import check_stand


def test_biped_is_a_built_in_robot() -> None:
    assert "biped" in robots.builtin_names()
    bot = robots.load("biped")
    assert bot.name == "biped"
    assert bot.root_dir.name == "biped" and bot.root_dir.parent.name == "robots"


def test_biped_is_a_plausible_flat_footed_servo_build() -> None:
    bot = robots.load("biped")
    assert len(bot.legs) == 2 and len(bot.joints) == 12
    assert 1.0 <= bot.mass_kg <= 3.0
    catalogue = load_catalogue()
    for joint in bot.joints:
        assert joint.servo.name in catalogue, joint.name
    for leg in bot.legs:
        assert leg.is_flat and len(leg.joints) == 6
        assert leg.sole_half_extents_m is not None
        half_length, half_width = leg.sole_half_extents_m
        assert 0.04 <= half_length <= 0.08 and 0.025 <= half_width <= 0.05
    # every body that carries a servo weighs at least that servo (masses include the servos)
    servo_kg = bot.joints[0].servo.mass_kg
    model = bot.mj_model()
    carrying = [f"{p}_{n}" for p in "lr" for n in
                ("hip_yaw_link", "hip_roll_link", "thigh", "shank", "ankle_pitch_link")]
    for body in carrying:
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
        assert model.body_mass[bid] >= servo_kg, body
    torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "torso")
    assert model.body_mass[torso] >= 2 * servo_kg  # the hip-yaw servos sit in the torso


def test_biped_is_mirror_symmetric() -> None:
    from planner.templates import mirror_permutation

    bot = robots.load("biped")
    assert mirror_permutation(bot) == (1, 0)
    left, right = bot.legs
    for a, b in zip(left.joints, right.joints, strict=True):
        ja = next(j for j in bot.joints if j.name == a)
        jb = next(j for j in bot.joints if j.name == b)
        assert ja.servo.name == jb.servo.name and ja.stance_rad == jb.stance_rad
        assert (ja.lower_rad, ja.upper_rad) == (jb.lower_rad, jb.upper_rad)


def test_biped_stands_on_its_servos() -> None:
    """`gaitsmith robots check biped`: upright, at its stance height, servos far from stall."""
    report = check_stand(robots.load("biped"), duration_s=2.0)
    assert report.stands, report.reasons
    assert report.tilt_deg < 3.0
    assert abs(report.base_height_m - report.stance_base_height_m) < 0.01
    assert report.worst.load_fraction < 0.3
    assert not report.warnings
    assert np.all([j.budget_flag is None for j in report.joints])

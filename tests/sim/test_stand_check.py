"""`sim.stand_check`: every zoo robot stands on its servos; a robot too heavy for them does not."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import robots
from sim.stand_check import check_stand
from tests.zoo.fixtures import ZOO, ZOO_ROBOTS, heavy_copy


def test_the_zoo_has_the_required_builds() -> None:
    assert {"bittle8", "humanoid20", "star5", "spotmicro", "phantomx18"} <= set(ZOO_ROBOTS)
    masses = [robots.load(ZOO / n).mass_kg for n in ZOO_ROBOTS]
    assert min(masses) < 0.35 and max(masses) > 2.0


@pytest.mark.parametrize("name", ZOO_ROBOTS)
def test_zoo_robot_stands_on_its_servos(name: str) -> None:
    robot = robots.load(ZOO / name)
    report = check_stand(robot, duration_s=2.0)
    assert report.stands, report.reasons
    assert abs(report.base_height_m - robot.stance_base_height_m) < 0.2 * robot.stance_base_height_m
    assert report.tilt_deg < 8.0
    # every servo holds with margin, and the loads are real (not zero everywhere)
    assert 0.02 < report.worst.load_fraction < 0.5
    assert len(report.joints) == robot.dof


def test_humanoid_holds_its_arms_and_head_with_servos() -> None:
    robot = robots.load(ZOO / "humanoid20")
    assert set(robot.hold_joint_names) >= {"neck_pan", "l_elbow", "r_shoulder_pitch"}
    report = check_stand(robot)
    names = {j.name for j in report.joints}
    assert "neck_tilt" in names and "l_shoulder_roll" in names
    # the legs carry the body: a knee works harder than any held joint
    load = {j.name: j.load_fraction for j in report.joints}
    assert load["l_knee"] > max(load[n] for n in robot.hold_joint_names)


def test_menagerie_style_damping_is_flagged_as_double_counted() -> None:
    report = check_stand(robots.load(ZOO / "phantomx18"))
    assert report.stands
    assert any("back-EMF" in w for w in report.warnings)
    assert all(j.budget_flag for j in report.joints)
    assert any("actuator" in n for n in report.notices) and any(
        "floor" in n for n in report.notices
    )
    # the servo model's own back-EMF for an AX-12A: τ_stall/ω₀ = 1.5/6.178
    assert math.isclose(report.joints[0].back_emf_nm_s_per_rad, 1.5 / 6.178, rel_tol=1e-3)


def test_clean_model_has_no_budget_warning() -> None:
    # the STS3215's identified rotor takes > 25 % of its stall torque at a 2 Hz swing: the
    # servo's own, not flagged
    report = check_stand(robots.load(ZOO / "star5"))
    assert report.warnings == ()
    j = report.joints[0]
    assert j.armature_share > 0.25
    # 0.05 N·m·s/rad at ½·ω₀ of an STS3215 (4.717 rad/s) against 1.912 N·m
    assert math.isclose(j.damping_share, 0.05 * 0.5 * 4.717 / 1.912, rel_tol=1e-3)


def test_a_robot_too_heavy_for_its_servos_does_not_stand(tmp_path: Path) -> None:
    report = check_stand(robots.load(heavy_copy(tmp_path, 12.0)))
    assert not report.stands
    assert report.reasons
    assert report.worst.load_fraction > 0.9


def test_duration_is_checked() -> None:
    from sim.errors import SimConfigError

    with pytest.raises(SimConfigError, match="duration"):
        check_stand(robots.load("quad12"), duration_s=0.0)

import math
import re
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

import robots
from robots import RobotConfigError


@pytest.mark.parametrize("name", ["quad12", "hex18"])
def test_builtin_robots_load(name: str) -> None:
    r = robots.load(name)
    assert r.name == name
    n_legs = {"quad12": 4, "hex18": 6}[name]
    assert len(r.legs) == n_legs and r.dof == 3 * n_legs
    assert len({j.bus_id for j in r.joints}) == r.dof
    assert all(j.lower_rad < j.stance_rad < j.upper_rad for j in r.joints)
    assert re.fullmatch(r"[0-9a-f]{16}", r.fingerprint)
    assert r.stance_base_height_m > r.foot_radius_m


def test_link_masses_include_the_servos() -> None:
    for name, lo, hi in (("quad12", 1.5, 2.5), ("hex18", 2.0, 3.0)):
        r = robots.load(name)
        servo_mass = sum(j.servo.mass_kg for j in r.joints)
        assert lo < r.mass_kg < hi
        assert r.mass_kg > servo_mass + 0.5  # servos plus frame, battery and electronics
        model = mujoco.MjModel.from_xml_path(str(r.mjcf_path))
        for j in r.joints:  # every moving link carries at least its share of a servo or bracket
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            assert model.body_mass[model.jnt_bodyid[jid]] >= 0.03


def test_load_by_path_and_fingerprint(quad_copy: Path) -> None:
    a = robots.load(quad_copy)
    assert a.fingerprint == robots.load("quad12").fingerprint
    assert robots.load(quad_copy / "robot.toml").fingerprint == a.fingerprint
    toml = quad_copy / "robot.toml"
    toml.write_text(
        toml.read_text().replace("zero_offset_ticks = 2048", "zero_offset_ticks = 2050", 1)
    )
    assert robots.load(quad_copy).fingerprint != a.fingerprint


def _edit(path: Path, old: str, new: str, count: int = 1) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, count))


@pytest.mark.parametrize(
    ("file", "old", "new", "field"),
    [
        (
            "robot.toml",
            "[joints.fl_knee]",
            '[joints.fl_ankle]\nservo = "STS3215_7V4"\nbus_id = 40\n'
            "direction = 1\nzero_offset_ticks = 2048\nstance_deg = 0.0\n\n[joints.fl_knee]",
            "fl_ankle",
        ),
        ("robot.toml", 'servo = "STS3215_7V4"', 'servo = "HS_999_NOT_A_SERVO"', "servo"),
        ("robot.toml", "bus_id = 2\n", "bus_id = 1\n", "bus_id"),
        ("robot.toml", "direction = 1", "direction = 2", "direction"),
        ("robot.toml", "stance_deg = -80.0", "stance_deg = 10.0", "stance_deg"),
        ("robot.toml", 'foot_site = "fl_foot"', 'foot_site = "fl_toe"', "foot_site"),
        (
            "robot.toml",
            'joints = ["fl_hip_roll", "fl_hip_pitch", "fl_knee"]',
            'joints = ["fl_hip_pitch", "fl_hip_roll", "fl_knee"]',
            "[legs.fl].joints",
        ),
        ("robot.toml", "foot_radius_m = 0.012", "foot_radius_m = -1", "foot_radius_m"),
        (
            "robot.toml",
            "stance_deg = 0.0\n",
            "stance_deg = 0.0\nlimits_deg = [-90, 90]\n",
            "limits_deg",
        ),
        ("robot.toml", "[robot]", "[robto]", "robto"),
        ("robot.xml", 'range="-2.6 -0.2"', 'range="-3.3 -0.2"', "fl_knee"),
        ("robot.xml", "<freejoint", "<freejoint_typo", "<mjcf>"),
    ],
)
def test_inconsistent_robot_folders_name_file_and_field(
    quad_copy: Path, file: str, old: str, new: str, field: str
) -> None:
    _edit(quad_copy / file, old, new)
    with pytest.raises(RobotConfigError) as info:
        robots.load(quad_copy)
    message = str(info.value)
    assert field in message, message
    assert str(quad_copy) in message


def test_limits_outside_the_servo_range_are_refused(quad_copy: Path) -> None:
    # knee range reaches -2.6 rad; with the zero at tick 300 that is below tick 0
    _edit(
        quad_copy / "robot.toml",
        "zero_offset_ticks = 2048\nstance_deg = -80.0",
        "zero_offset_ticks = 300\nstance_deg = -80.0",
    )
    with pytest.raises(RobotConfigError, match=r"fl_knee.*outside the STS3215_7V4 range"):
        robots.load(quad_copy)


def test_missing_files_and_unknown_names() -> None:
    with pytest.raises(RobotConfigError, match="built-in robots: biped, hex18, quad12"):
        robots.load("quad99")


def test_mjcf_joint_without_servo_mapping(quad_copy: Path) -> None:
    text = (quad_copy / "robot.toml").read_text()
    start = text.index("[joints.hr_knee]")
    end = (
        text.index("[joints", start + 1) if "[joints" in text[start + 1 :] else text.index("[legs")
    )
    (quad_copy / "robot.toml").write_text(text[:start] + text[end:])
    with pytest.raises(RobotConfigError, match="hr_knee"):
        robots.load(quad_copy)


def test_joint_ticks_follow_direction_and_offset() -> None:
    r = robots.load("quad12")
    j = r.joint("fr_knee")
    assert j.direction == -1
    assert j.angle_to_ticks(0.0) == 2048
    assert j.angle_to_ticks(math.pi / 2) == pytest.approx(2048 - 1024)
    assert np.isclose(r.joint("fl_knee").angle_to_ticks(math.pi / 2), 2048 + 1024)


def test_a_point_foot_on_a_box_sole_gets_a_notice(tmp_path: Path) -> None:
    """A hand-written folder that declares box soles as points is told to declare them flat."""
    from tests.zoo.fixtures import ZOO

    folder = tmp_path / "h"
    shutil.copytree(ZOO / "humanoid20", folder)
    toml = folder / "robot.toml"
    toml.write_text(re.sub(r'(?m)^foot = "flat".*$', "", toml.read_text()))
    notices = robots.load(folder).notices
    assert [n.split(":")[0] for n in notices] == ["[legs.l]", "[legs.r]"]
    assert all('add foot = "flat"' in n and "100 × 60 mm" in n for n in notices)
    assert robots.load(ZOO / "humanoid20").notices == ()

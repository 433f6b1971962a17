"""The servo-parameters file (`robots.servo_params`): round trip and one-line errors."""

from __future__ import annotations

from pathlib import Path

import pytest

import robots
from robots.errors import RobotConfigError
from robots.servo_params import FACTORY, ServoParamsFile, ServoSetting, load, save

GOOD = """schema = "gaitsmith.servo_params/1"
robot = "quad12"
[joints.fl_knee]
gain_scale = 1.2
latency_ms = 7.5
strength = 0.8
held_out_rms_deg = 0.03
"""


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "servo_params.toml"
    path.write_text(text)
    return path


def test_save_then_load_round_trips_and_unlisted_joints_are_factory(tmp_path: Path) -> None:
    quad = robots.load("quad12")
    params = ServoParamsFile("quad12", {"fl_knee": ServoSetting(1.25, 6.5, 0.9)})
    path = tmp_path / "p.toml"
    save(path, params, {"fl_knee": {"servo": "STS3215_7V4", "samples": 400}}, "header\nline")
    back = load(path)
    assert back.joints == params.joints
    settings = back.for_robot(quad)
    assert settings[quad.joint_names.index("fl_knee")] == ServoSetting(1.25, 6.5, 0.9)
    assert settings[0] == FACTORY
    assert load(_file(tmp_path, GOOD)).joints["fl_knee"].latency_s == pytest.approx(0.0075)


@pytest.mark.parametrize(
    ("text", "where"),
    [
        (GOOD.replace("gain_scale = 1.2", "gain_scale = -1"), "joints.fl_knee.gain_scale"),
        (GOOD.replace("latency_ms = 7.5", "latency_ms = 9000"), "joints.fl_knee.latency_ms"),
        (GOOD.replace("strength = 0.8", 'strength = "strong"'), "joints.fl_knee.strength"),
        (GOOD.replace("strength = 0.8", "strenght = 0.8"), "joints.fl_knee.strenght"),
        (GOOD.replace("servo_params/1", "servo_params/9"), "schema"),
        (GOOD.replace("[joints.fl_knee]", "[joints.fl_knee"), "<toml>"),
    ],
)
def test_bad_values_name_the_file_joint_and_field(tmp_path: Path, text: str, where: str) -> None:
    path = _file(tmp_path, text)
    with pytest.raises(RobotConfigError) as info:
        load(path)
    assert info.value.file == str(path) and info.value.field == where
    assert "\n" not in str(info.value)


def test_wrong_robot_or_joint_and_missing_file_are_refused(tmp_path: Path) -> None:
    quad = robots.load("quad12")
    with pytest.raises(RobotConfigError, match="identified on robot 'quad12', not 'hex18'"):
        load(_file(tmp_path, GOOD)).for_robot(robots.load("hex18"))
    with pytest.raises(RobotConfigError, match=r"joints\.fl_elbow: robot quad12 has no joint"):
        load(_file(tmp_path, GOOD.replace("fl_knee", "fl_elbow"))).for_robot(quad)
    with pytest.raises(RobotConfigError, match="not found"):
        load(tmp_path / "nope.toml")

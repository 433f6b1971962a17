"""Issue #14: zoo robots other than the built-ins get a template gait that walks in MuJoCo.

`gaitsmith plan DIR --simulate` with no gait named (the robot's walking-pace template) at Froude
number 0.02 and a small N, then the gait file's validation block: the default pass criteria
(speed within 10 %, no fall, peak torque ≤ 80 % of stall, heading, drift, tilt, slip ≤ 0.1·L).
"""

from __future__ import annotations

from pathlib import Path

import pytest

import robots
from gaitsmith import cli
from planner.nlp.config import speed_for_froude
from tests.zoo.fixtures import ZOO

FROUDE = 0.02
KNOTS = 16


@pytest.mark.slow
@pytest.mark.parametrize("name", ["phantomx18", "star5"])
def test_zoo_robot_template_gait_passes_mujoco(name: str, tmp_path: Path) -> None:
    robot = robots.load(ZOO / name)
    speed = round(speed_for_froude(FROUDE, robot.leg_length_m), 3)
    out = tmp_path / f"{name}.json"
    argv = ["plan", str(ZOO / name), "--speed", str(speed), "--knots", str(KNOTS), "-o", str(out),
            "--simulate"]
    assert cli.main(argv) == 0
    gait = robots.gait.load(out, robot)
    assert gait.validation is not None
    assert gait.validation["passed"], gait.validation["reasons"]

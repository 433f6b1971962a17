"""Half-cycle mirror symmetry (`planner.nlp.mirror`, `PlannerOptions.half_cycle_mirror`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.mirror import check_schedule, joint_mirror
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule, mirror_permutation

ZOO = Path(__file__).resolve().parents[2] / "zoo"


@pytest.mark.parametrize("name", ["quad12", "hex18", "biped", str(ZOO / "star5")])
def test_joint_images_are_an_involution_that_keeps_pitch_and_flips_roll_and_yaw(name: str) -> None:
    robot = robots.load(name)
    mirror = joint_mirror(robot)
    for a, (b, sign) in enumerate(zip(mirror.image, mirror.sign, strict=True)):
        assert mirror.image[b] == a and mirror.sign[b] == sign
        joint = robot.joints[a].name
        if "pitch" in joint or "knee" in joint or "femur" in joint or "tibia" in joint:
            assert sign == 1.0, joint
        if "roll" in joint or "yaw" in joint or "coxa" in joint:
            assert sign == -1.0, joint


def test_the_schedule_check_refuses_what_cannot_be_mirrored() -> None:
    robot = robots.load("quad12")
    feet = mirror_permutation(robot)
    check_schedule(make_schedule(robot, "trot"), feet, 12, 0.0, 0.0)  # symmetric: no error
    with pytest.raises(PlannerConfigError, match="not half-cycle mirror symmetric"):
        check_schedule(make_schedule(robot, "bound"), feet, 12, 0.0, 0.0)
    with pytest.raises(PlannerConfigError, match="straight gaits only"):
        check_schedule(make_schedule(robot, "trot"), feet, 12, 0.0, 0.2)
    with pytest.raises(PlannerConfigError, match="not left–right symmetric"):
        check_schedule(make_schedule(robot, "trot"), None, 12, 0.0, 0.0)


def test_a_mirrored_trot_is_symmetric_and_costs_no_less_than_the_free_one() -> None:
    robot = robots.load("quad12")
    schedule = make_schedule(robot, "trot")
    n = 8
    free = GaitPlanner(robot, n).solve(schedule, 0.2)
    mirrored_planner = GaitPlanner(robot, n, PlannerOptions(half_cycle_mirror=True))
    res = mirrored_planner.solve(schedule, 0.2)
    assert free.feasible and res.feasible
    mirror = joint_mirror(robot)
    q, base = res.joint_angles_rad, res.base_pose
    for k in range(n // 2):
        np.testing.assert_allclose(
            q[k + n // 2], np.array(mirror.sign) * q[k, list(mirror.image)], atol=1e-6
        )
        np.testing.assert_allclose(
            base[k + n // 2], base[k] * np.array([1, -1, 1, -1, 1, -1]), atol=1e-6
        )
    assert res.cost >= free.cost - 1e-6 * abs(free.cost)  # a constraint never lowers the optimum

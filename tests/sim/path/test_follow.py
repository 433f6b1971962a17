"""The closed-loop MuJoCo follow through a gait library, and its metrics."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from robots.errors import LibraryFileError
from robots.robot import Robot
from sim.errors import SimConfigError
from sim.path.follow import FollowSettings, follow
from sim.path.metrics import DriveCriteria, judge
from sim.path.spec import parse_path
from tests.sim.path.kinematic_library import kinematic_library
from tests.zoo.fixtures import ZOO


@pytest.fixture(scope="module")
def hex18() -> Robot:
    return robots.load("hex18")


@pytest.mark.slow
def test_a_zoo_hexapod_follows_a_short_curve_on_a_kinematic_library() -> None:
    bot = robots.load(ZOO / "phantomx18")  # not a built-in: 18 × AX-12A, Protocol 1.0
    lib = kinematic_library(bot, (0.0, 0.05, 0.1), (-0.4, 0.0, 0.4))
    path = parse_path("0,0;0.6,0;1.0,0.3", bot.leg_length_m)
    seen: list[float] = []
    _sim, log = follow(lib, bot, path, progress=lambda t, s, total: seen.append(s / total))
    assert seen and seen[-1] > 0.9
    lo, hi = lib.command_bounds()
    assert np.all(log.requested[:, 0] >= lo.vx_m_s) and np.all(log.requested[:, 0] <= hi.vx_m_s)
    assert np.all(np.abs(log.requested[:, 2]) <= hi.yaw_rate_rad_s + 1e-12)
    assert log.standing[0] and log.standing[-1]  # stand at the start and at the end
    assert not log.driving[0] and not log.driving[-1]
    result = judge(log, bot.joint_names, 0.5)
    m = result.metrics
    assert result.passed, result.reasons
    # measured: mean 0.5 cm, max 1.2 cm, arrived after 15.2 s, peak 70 % of stall
    assert m.cross_track_mean_m < 0.02 and m.cross_track_max_m < 0.04
    assert abs(m.distance_m - m.planned_distance_m) < 0.1
    assert m.footprints > 50
    assert 0 < m.peak_torque_fraction < 0.8
    end = log.base_pos_m[-1, :2]
    assert np.linalg.norm(end - path.point_at(path.length_m)) < 0.1
    # a tight limit fails the verdict with a reason naming the check
    strict = judge(log, bot.joint_names, 0.5, DriveCriteria(max_mean_cross_track_m=1e-4))
    assert not strict.passed and strict.reasons[0].startswith("cross-track: mean")


def test_refuses_a_library_of_another_build(hex18: Robot) -> None:
    quad = robots.load("quad12")
    lib = kinematic_library(hex18, (0.0, 0.1), (-0.4, 0.4))
    with pytest.raises(LibraryFileError, match="fingerprint"):
        follow(lib, quad, parse_path("circle:1", quad.leg_length_m))


def test_settings_are_checked() -> None:
    with pytest.raises(SimConfigError, match="control rate"):
        FollowSettings(rate_hz=0.0)
    with pytest.raises(SimConfigError, match="latency"):
        FollowSettings(latency_s=2.0)

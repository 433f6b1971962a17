"""`gaitsmith sweep`: each speed's gait is validated with the controller it will be played with."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import robots
from gaitsmith.sweep_cmd import _sim_validator
from robots.attitude import TWO_LEG_IMU_GAIN
from robots.gait import Gait

BIPED_WALK = Path(__file__).parents[1] / "sim" / "fixtures" / "biped_walk_0222.json"


def _result(gait: Gait, robot: robots.Robot) -> SimpleNamespace:
    """What `_sim_validator` reads of a `GaitSearchResult`: the robot and the winner's gait."""
    planner = SimpleNamespace(to_gait=lambda best, label: gait)
    return SimpleNamespace(planner=planner, best=None, label=gait.gait_label, robot=robot)


def test_a_biped_walk_row_is_judged_closed_loop_by_the_rule() -> None:
    """Issue #14: the built-in biped's walk (no flight phase; an [imu], 2 legs) is validated
    at the rule's G 0.5 (the sweep's row says so), or open loop with `--attitude-gain 0`."""
    gait = robots.gait.load(BIPED_WALK)
    biped = robots.load("biped")
    closed = _sim_validator(4)(_result(gait, biped))  # type: ignore[arg-type]
    assert closed.attitude_gain == TWO_LEG_IMU_GAIN
    opened = _sim_validator(4, attitude_gain=0.0)(_result(gait, biped))  # type: ignore[arg-type]
    assert opened.attitude_gain == 0.0
    assert math.isfinite(closed.speed_m_s) and closed.speed_m_s != opened.speed_m_s


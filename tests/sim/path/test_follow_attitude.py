"""Closed-loop attitude feedback in the path following of `gaitsmith drive-sim`: the built-in
biped's walk library (tests/hardware/play/fixtures/biped_walk_lib.json: 0.222 m/s, yaw rate
−0.6 / 0 / +0.6 rad/s, each validated closed loop at gain 0.5) drives a straight then a left
turn; open loop it falls (docs/results/attitude_feedback.md, session 30), closed loop it
arrives, with every offset inside the law's clip; the drive-sim command takes the rule's
default gain and reports it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import robots
from gaitsmith.cli import main
from robots.attitude import DEFAULT_MAX_OFFSET_RAD, AttitudeLaw
from robots.library import load
from sim.attitude_loop import AttitudeSettings
from sim.path.follow import FollowSettings, follow
from sim.path.spec import parse_path

LIBRARY = Path(__file__).parents[2] / "hardware" / "play" / "fixtures" / "biped_walk_lib.json"
PATH = "0,0;1.5,0;2.5,1;2.5,2.5"


@pytest.mark.slow
def test_the_biped_falls_open_loop_and_arrives_closed_loop() -> None:
    bot = robots.load("biped")
    lib = load(LIBRARY, bot)
    path = parse_path(PATH, bot.leg_length_m)
    _, open_log = follow(lib, bot, path, FollowSettings())
    assert open_log.fell and open_log.attitude_gain == 0.0
    closed = FollowSettings(attitude=AttitudeSettings(AttitudeLaw(0.5)))
    _, log = follow(lib, bot, path, closed)
    assert not log.fell and log.arrived_s is not None, log.fall_reason
    assert log.attitude_gain == 0.5
    assert 0.02 < log.attitude_offset_max_rad <= DEFAULT_MAX_OFFSET_RAD
    # the targets sent stay inside the joint limits (clipped there, as the player's gate does)
    lo = np.array([j.lower_rad for j in bot.joints])
    hi = np.array([j.upper_rad for j in bot.joints])
    assert np.all(log.targets_rad >= lo - 1e-12) and np.all(log.targets_rad <= hi + 1e-12)


def test_drive_sim_closes_the_loop_by_the_rule_and_reports_the_gain(tmp_path: Path) -> None:
    out = tmp_path / "run.json"
    code = main(["drive-sim", str(LIBRARY), "--path", "0,0;1.0,0;1.5,0.5", "--json", str(out)])
    assert code == 0
    doc = json.loads(out.read_text())
    assert doc["attitude"]["gain"] == 0.5 and doc["conditions"]["attitude_gain"] == 0.5
    assert 0.0 < doc["attitude"]["offset_max_rad"] <= DEFAULT_MAX_OFFSET_RAD
    assert doc["passed"] and not doc["metrics"]["fell"]

"""`sim.acceptance`: the MuJoCo check a gait search can use to reject gaits that do not walk."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path

import numpy as np

import robots
from robots import ContactSchedule, Gait, Robot
from robots.attitude import ATTITUDE_GAIN_KEY, TWO_LEG_IMU_GAIN
from robots.gait import Velocity
from sim.acceptance import GaitCheck, SimAcceptance, validate_as_played
from sim.validate import PassCriteria

BIPED_WALK = Path(__file__).parent / "fixtures" / "biped_walk_0222.json"


def test_factory_pickles_and_builds_a_check_for_its_robot(hex18: Robot) -> None:
    factory = SimAcceptance(str(hex18.root_dir), cycles=4)
    assert pickle.loads(pickle.dumps(factory)) == factory
    check = factory()
    assert isinstance(check, GaitCheck) and check.robot.name == "hex18" and check.cycles == 4


def test_a_walking_gait_passes_and_a_mislabelled_one_fails(hex18: Robot, hex_tripod: Gait) -> None:
    check = GaitCheck(hex18, cycles=6)
    ok = check(hex_tripod)
    assert ok.passed and ok.badness == 0.0 and ok.reasons == () and ok.excess == ()
    assert abs(ok.achieved_speed_m_s - 0.1) < 0.02
    # the same motion claiming three times the speed: walks, but misses the speed criterion
    fast = dataclasses.replace(hex_tripod, velocity=Velocity(vx_m_s=0.3))
    bad = check(fast)
    assert not bad.passed and bad.badness >= 1 and any("speed" in r for r in bad.reasons)
    # by how much: |0.1 − 0.3| m/s against a ±0.03 m/s tolerance, about 5.7× past it
    excess = dict(bad.excess)
    assert len(bad.excess) == bad.badness and 4.0 < excess["speed"] < 7.0


def _in_place(robot: Robot, duty: float) -> Gait:
    """The stance held under a two-group schedule of duty `duty` (< 0.5 on two feet: a flight
    phase, a run by the attitude rule; ≥ 0.5: a walk)."""
    feet = robot.foot_names
    sched = ContactSchedule(0.5, feet, tuple(i / len(feet) for i in range(len(feet))),
                            tuple(duty for _ in feet))
    knots = np.tile(np.asarray(robot.nominal_stance_rad), (12, 1))
    return Gait.create(robot=robot, knots_rad=knots, schedule=sched, velocity=Velocity(0.1),
                       gait_label="in place")


def test_the_acceptance_judges_a_biped_walk_closed_loop_and_a_run_open(quad: Robot) -> None:
    """Issue #14, one gait one controller: on the built-in biped (2 legs, an [imu]) a walk
    sample is judged closed loop at the rule's G 0.5 and a run sample (flight phase) open
    loop; a quadruped with an IMU stays open loop; an explicit gain applies to every gait."""
    biped = robots.load("biped")
    walk, run = _in_place(biped, 0.6), _in_place(biped, 0.42)
    check = GaitCheck(biped, cycles=3)
    assert check(walk).attitude_gain == TWO_LEG_IMU_GAIN
    assert check(run).attitude_gain == 0.0
    assert biped.imu is not None
    quad_imu = dataclasses.replace(quad, imu=biped.imu)
    assert GaitCheck(quad_imu, cycles=3)(_in_place(quad_imu, 0.75)).attitude_gain == 0.0
    assert GaitCheck(biped, cycles=3, attitude_gain=0.0)(walk).attitude_gain == 0.0
    assert GaitCheck(biped, cycles=3, attitude_gain=1.0)(run).attitude_gain == 1.0


def test_a_biped_walk_that_turns_open_loop_is_accepted_closed_loop() -> None:
    """The built-in biped's 0.222 m/s template walk fails open loop (it turns) and passes at
    the rule's gain: the final acceptance (the default criteria, 20 cycles) now says what
    `plan --simulate` says, and its verdict records the gain as `plan` does."""
    gait = robots.gait.load(BIPED_WALK)
    biped = robots.load("biped")
    closed = GaitCheck(biped, 20, PassCriteria())(gait)
    assert closed.passed and closed.attitude_gain == TWO_LEG_IMU_GAIN, closed.reasons
    opened = GaitCheck(biped, 20, PassCriteria(), attitude_gain=0.0)(gait)
    assert not opened.passed and opened.attitude_gain == 0.0
    assert any("heading" in r for r in opened.reasons)
    result = validate_as_played(gait, biped, 3, keep_trajectory=False)
    assert result.conditions[ATTITUDE_GAIN_KEY] == TWO_LEG_IMU_GAIN
    assert ATTITUDE_GAIN_KEY not in validate_as_played(gait, biped, 3, 0.0).conditions


def test_the_factory_keeps_its_gain_through_a_pickle() -> None:
    """The process executor pickles the factory into each worker: the gain (or the rule, None)
    must survive the round trip and reach the check."""
    root = str(robots.load("biped").root_dir)
    for gain in (None, 0.0, 0.25):
        factory = SimAcceptance(root, cycles=4, attitude_gain=gain)
        back = pickle.loads(pickle.dumps(factory))
        assert back == factory
        check = back()
        assert check.attitude_gain == gain and check.robot.name == "biped"

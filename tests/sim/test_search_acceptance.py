"""`sim.acceptance`: the MuJoCo check a gait search can use to reject gaits that do not walk."""

from __future__ import annotations

import dataclasses
import pickle

from robots import Gait, Robot
from robots.gait import Velocity
from sim.acceptance import GaitCheck, SimAcceptance


def test_factory_pickles_and_builds_a_check_for_its_robot(hex18: Robot) -> None:
    factory = SimAcceptance(str(hex18.root_dir), cycles=4)
    assert pickle.loads(pickle.dumps(factory)) == factory
    check = factory()
    assert isinstance(check, GaitCheck) and check.robot.name == "hex18" and check.cycles == 4


def test_a_walking_gait_passes_and_a_mislabelled_one_fails(hex18: Robot, hex_tripod: Gait) -> None:
    check = GaitCheck(hex18, cycles=6)
    ok = check(hex_tripod)
    assert ok.passed and ok.badness == 0.0 and ok.reasons == ()
    assert abs(ok.achieved_speed_m_s - 0.1) < 0.02
    # the same motion claiming three times the speed: walks, but misses the speed criterion
    fast = dataclasses.replace(hex_tripod, velocity=Velocity(vx_m_s=0.3))
    bad = check(fast)
    assert not bad.passed and bad.badness >= 1 and any("speed" in r for r in bad.reasons)

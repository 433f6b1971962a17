"""The ramp-in does not turn the robot (issue #12), on a planned trot of a robot built here.

The robot is quad12 modified in a tmp dir (longer body with the hips moved off-centre, heavier
torso with its centre of mass 15 mm forward, 10 mm longer shanks), so the check cannot pass by
being tuned to a built-in. Ramping straight to the trot's phase-0 pose turned that robot 13° before
its first step (it stood on one diagonal while the two feet moved apart in different directions);
the entry through the gait's mean pose keeps the yaw within RAMP_YAW_TOL_DEG.

Tolerance: the yaw from rest to the start of the gait proper (ramp + blend), measured over
20-cycle runs after the fix: trot 0.25 m/s −0.0° (quad12), −0.5° (the modified quad, 30 knots),
+0.1° (this test's 20-knot plan); hex18 tripod +0.3°; walk 0.15 m/s −0.7° (quad12), +0.3°
(modified quad); hex18 ripple 0.2 m/s −2.3°. Before the fix the same gaits turned 7–18°.
3° is above everything measured and leaves 2° of the ±5° heading budget of a run
(`PassCriteria.max_heading_error_rad`) for the walking itself.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest

import robots
import sim.rollout
from robots.gait import Gait
from robots.ramp import MinJerkRamp, ramp_to
from robots.robot import Robot
from sim.validate import validate

RAMP_YAW_TOL_DEG = 3.0
_EDITS = (
    ('model="quad12"', 'model="quad_long"'),
    ('pos="0.11 0.055 0"', 'pos="0.13 0.06 0"'),
    ('pos="0.11 -0.055 0"', 'pos="0.13 -0.06 0"'),
    ('pos="-0.11 0.055 0"', 'pos="-0.095 0.06 0"'),
    ('pos="-0.11 -0.055 0"', 'pos="-0.095 -0.06 0"'),
    ('<inertial pos="0 0 0" mass="1.0000"', '<inertial pos="0.015 0 0" mass="1.2000"'),
    ('fromto="0 0 0 0 0 -0.12"', 'fromto="0 0 0 0 0 -0.13"'),
    ('pos="0 0 -0.12"', 'pos="0 0 -0.13"'),
)


@pytest.fixture(scope="module")
def long_quad(tmp_path_factory: pytest.TempPathFactory) -> Robot:
    src = Path(robots.load("quad12").mjcf_path).parent
    dst = tmp_path_factory.mktemp("quad_long")
    xml = (src / "robot.xml").read_text()
    for old, new in _EDITS:
        assert old in xml, old
        xml = xml.replace(old, new)
    (dst / "robot.xml").write_text(xml)
    shutil.copy(src / "robot.toml", dst / "robot.toml")
    toml = (dst / "robot.toml").read_text().replace('name = "quad12"', 'name = "quad_long"')
    (dst / "robot.toml").write_text(toml)
    return robots.load(dst)


@pytest.fixture(scope="module")
def long_quad_trot(long_quad: Robot) -> Gait:
    from planner.nlp.spacetime import GaitPlanner
    from planner.templates import make_schedule

    planner = GaitPlanner(long_quad, n_knots=20)
    result = planner.solve(make_schedule(long_quad, "trot"), 0.25)
    assert result.feasible, result.message
    return planner.to_gait(result, "trot")


@pytest.mark.slow
def test_ramp_in_keeps_the_heading(long_quad: Robot, long_quad_trot: Gait) -> None:
    res = validate(long_quad_trot, long_quad, cycles=4)
    m = res.metrics
    assert not m.fell
    assert abs(math.degrees(m.ramp_yaw_rad)) < RAMP_YAW_TOL_DEG, m.ramp_yaw_rad
    assert abs(math.degrees(m.heading_error_rad)) < 5.0
    assert res.trajectory is not None and res.trajectory.ramp.cycles >= 1


@pytest.mark.slow
def test_a_straight_ramp_to_phase_zero_turns_the_same_robot(
    long_quad: Robot, long_quad_trot: Gait, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cause, kept as a regression check on the test itself: the old ramp-in turns it."""

    class PhaseZeroEntry:  # the old ramp-in, shaped like a GaitEntry
        def __init__(self, ramp: MinJerkRamp) -> None:
            self.ramp, self.duration_s, self.positions = ramp, ramp.duration_s, ramp.positions

    def phase_zero_ramp(gait: Gait, present, speed, min_s):  # type: ignore[no-untyped-def]
        return PhaseZeroEntry(ramp_to(present, gait.joint_targets(0.0), speed, min_s))

    monkeypatch.setattr(sim.rollout, "gait_entry", phase_zero_ramp)
    m = validate(long_quad_trot, long_quad, cycles=3).metrics
    assert abs(math.degrees(m.ramp_yaw_rad)) > 5.0

"""Acceptance (issue 6): planner gaits validated in MuJoCo with the servo model.

hex18 tripod at 0.15 m/s and quad12 trot at 0.25 m/s (template defaults) must pass: speed within
10 %, no fall over 20 cycles, peak torque ≤ 80 % of stall. quad12 trot used to reach only
≈ 0.15 m/s: the planner assumed perfect position tracking, but the STS3215's factory P loop
(≈ 10 N·m/rad) sagged the body ≈ 1 cm and lagged, and the optimiser landed the hind feet still
moving forward and lifted the front feet while swinging — the hind feet dragged through ≈ 45 %
of their swing. The planner now writes servo goals that invert the position loop and sets feet
down / lifts them off vertically (`planner.nlp.servo_loop`, `PlannerOptions`).
"""

from __future__ import annotations

import pytest

from robots.robot import Robot
from sim.validate import validate

pytestmark = pytest.mark.slow


def _plan(robot: Robot, gait: str, speed_m_s: float):  # type: ignore[no-untyped-def]
    from planner import templates
    from planner.nlp.spacetime import GaitPlanner

    planner = GaitPlanner(robot, n_knots=30)
    result = planner.solve(templates.make_schedule(robot, gait), speed_m_s)
    assert result.feasible, result.message
    return planner.to_gait(result, gait)


def test_hex18_tripod_planner_gait_passes(hex18: Robot) -> None:
    gait = _plan(hex18, "tripod", 0.15)
    res = validate(gait, hex18, cycles=20)
    assert res.passed, res.reasons
    m = res.metrics
    assert abs(m.achieved_speed_m_s - 0.15) <= 0.015
    assert not m.fell and m.cycles_run == 20
    assert m.peak_torque_fraction <= 0.8


def test_quad12_trot_planner_gait_passes(quad: Robot) -> None:
    gait = _plan(quad, "trot", 0.25)
    assert gait.planner["joint_angles"] == "servo_goal"
    res = validate(gait, quad, cycles=20)
    assert res.passed, res.reasons
    m = res.metrics
    assert abs(m.achieved_speed_m_s - 0.25) <= 0.025
    assert not m.fell and m.cycles_run == 20
    assert m.peak_torque_fraction <= 0.8

"""Acceptance (issue 6): planner gaits validated in MuJoCo with the servo model.

hex18 tripod at 0.15 m/s must pass: speed within 10 %, no fall over 20 cycles, peak torque ≤ 80 %
of stall. quad12 trot at 0.25 m/s currently does not (xfail, see the reason): the planner assumes
perfect position tracking, but the STS3215's factory P loop (≈ 10 N·m/rad) sags ≈ 1 cm and lags
3-5°, so the hind feet barely clear the ground (≈ 2 mm of the planned 25 mm) and drag through
≈ 45 % of their swing.
"""

from __future__ import annotations

import pytest

from robots.robot import Robot
from sim.validate import validate

pytest.importorskip("casadi")
pytestmark = pytest.mark.slow


def _plan(robot: Robot, gait: str, speed_m_s: float):  # type: ignore[no-untyped-def]
    from planner import templates
    from planner.spacetime import GaitPlanner

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


@pytest.mark.xfail(
    reason="planner/servo mismatch: factory P-gain compliance sags the body and the hind feet "
    "drag in swing (achieved ≈ 0.15 of 0.25 m/s); see the module docstring",
    strict=False,
)
def test_quad12_trot_planner_gait_passes(quad: Robot) -> None:
    gait = _plan(quad, "trot", 0.25)
    res = validate(gait, quad, cycles=20)
    assert res.passed, res.reasons

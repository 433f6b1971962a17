"""GaitBlender: interpolation at equal phase, phase continuity, limits, stand ↔ walk."""

from dataclasses import replace

import numpy as np
import pytest

import robots
from robots import Velocity
from robots.blend import BlendError, BlendLimits, GaitBlender
from robots.spline import PeriodicSpline
from tests.robots.library_fixture import N_KNOTS, expected_targets, make_library, period_s_for

DT = 0.01


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


@pytest.fixture(scope="module")
def limits(quad: robots.Robot) -> BlendLimits:
    return BlendLimits.for_robot(quad, accel_m_s2=0.5, yaw_accel_rad_s2=2.0)


def _expected(quad: robots.Robot, c: Velocity, phase: float) -> np.ndarray:
    """The spline through the fixture's knots at command `c`: what blending must reproduce."""
    knots = expected_targets(quad, c, np.arange(N_KNOTS) / N_KNOTS)
    return np.asarray(PeriodicSpline(knots)(phase))


def _run(b: GaitBlender, c: Velocity, seconds: float) -> np.ndarray:
    return np.array([b.step(c, DT) for _ in range(round(seconds / DT))])


def _walking(quad: robots.Robot, limits: BlendLimits, c: Velocity) -> GaitBlender:
    b = GaitBlender(make_library(quad), limits)
    _run(b, c, 8.0)
    assert b.state == "gait" and b.blend_weight == 1.0 and b.command == c
    return b


@pytest.mark.parametrize(
    "c", [Velocity(0.1, 0.0, 0.0), Velocity(0.05, 0.0, 0.25), Velocity(0.17, 0.0, -0.4)]
)
def test_targets_interpolate_the_grid_at_equal_phase(
    quad: robots.Robot, limits: BlendLimits, c: Velocity
) -> None:
    b = _walking(quad, limits, c)
    for _ in range(37):
        q = b.step(c, DT)
        np.testing.assert_allclose(q, _expected(quad, c, b.phase), atol=1e-12)
    assert b.period_s() == pytest.approx(period_s_for(c.vx_m_s))


def test_phase_is_continuous_when_the_command_jumps(
    quad: robots.Robot, limits: BlendLimits
) -> None:
    b = _walking(quad, limits, Velocity(0.0, 0.0, -0.5))
    prev_q, prev_phase = b.targets_rad, b.phase
    for k in range(300):
        q = b.step(Velocity(0.2, 0.0, 0.5) if k < 150 else Velocity(0.02, 0.0, 0.0), DT)
        advance = (b.phase - prev_phase) % 1.0
        # φ advances by dt / T(command in use) every tick: never a jump
        assert advance == pytest.approx(DT / period_s_for(b.command.vx_m_s), rel=1e-9)
        assert np.all(np.abs(q - prev_q) <= limits.joint_speed_rad_s * DT + 1e-12)
        prev_q, prev_phase = q, b.phase


def test_command_acceleration_is_limited(quad: robots.Robot, limits: BlendLimits) -> None:
    b = _walking(quad, limits, Velocity(0.01, 0.0, 0.0))
    prev = b.command
    cmds = []
    for _ in range(100):
        b.step(Velocity(0.2, 0.0, -0.5), DT)
        c = b.command
        assert abs(c.vx_m_s - prev.vx_m_s) <= limits.accel_m_s2 * DT + 1e-12
        assert abs(c.yaw_rate_rad_s - prev.yaw_rate_rad_s) <= limits.yaw_accel_rad_s2 * DT + 1e-12
        cmds.append(c)
        prev = c
    assert cmds[0].vx_m_s == pytest.approx(0.01 + 0.5 * DT)  # moving at the limit, not slower
    assert cmds[-1] == Velocity(0.2, 0.0, -0.5)  # 0.38 s at 0.5 m/s² reaches it


def test_commands_outside_the_grid_are_clipped(quad: robots.Robot, limits: BlendLimits) -> None:
    b = GaitBlender(make_library(quad), limits)
    _run(b, Velocity(1.0, 0.3, 2.0), 8.0)
    assert b.command == Velocity(0.2, 0.0, 0.5) and b.command_clipped
    b.step(Velocity(0.1, 0.0, 0.1), DT)
    assert not b.command_clipped
    np.testing.assert_allclose(_run(b, Velocity(-1.0, 0.0, 0.0), 2.0)[-1],
                               _expected(quad, Velocity(0.0, 0.0, 0.0), b.phase), atol=1e-12)
    assert b.command == Velocity(0.0, 0.0, 0.0) and b.state == "gait"  # marching in place


def test_joint_speed_clip_holds_every_tick(quad: robots.Robot) -> None:
    slow = BlendLimits.for_robot(quad, 0.5, 2.0, speed_fraction=0.05)
    b = GaitBlender(make_library(quad), slow, start_rad=np.asarray(quad.nominal_stance_rad) + 0.3)
    q = np.array([b.targets_rad] + [b.step(Velocity(0.2, 0, 0.5), DT) for _ in range(800)])
    speed = np.abs(np.diff(q, axis=0)) / DT
    assert np.all(speed <= slow.joint_speed_rad_s + 1e-9)
    assert np.max(speed / slow.joint_speed_rad_s) > 0.999  # the clip did act
    lo = np.array([j.lower_rad for j in quad.joints])
    hi = np.array([j.upper_rad for j in quad.joints])
    assert np.all((q[1:] >= lo) & (q[1:] <= hi))


def test_stand_walk_stand_needs_no_clipping(quad: robots.Robot, limits: BlendLimits) -> None:
    """The transitions themselves stay within the speed limit: an unclipped blender gives the
    same targets, so the clip never had to cut a jump."""
    unclipped = replace(limits, joint_speed_rad_s=1e6 * limits.joint_speed_rad_s)
    script = [Velocity()] * 30 + [Velocity(0.15, 0.0, 0.3)] * 500 + [Velocity()] * 700
    outs = []
    for lim in (limits, unclipped):
        b = GaitBlender(make_library(quad), lim)
        assert b.standing
        states = []
        q = [b.targets_rad]
        for c in script:
            q.append(b.step(c, DT))
            states.append(b.state)
        outs.append(np.array(q))
        assert states[29] == "standing" and "entry_ramp" in states and "gait" in states
        assert b.standing and b.command == Velocity() and b.phase == 0.0
        np.testing.assert_allclose(q[-1], quad.nominal_stance_rad, atol=1e-12)
    np.testing.assert_allclose(outs[0], outs[1], atol=1e-12)
    speed = np.abs(np.diff(outs[0], axis=0)) / DT
    assert np.all(speed <= limits.ramp_speed_fraction * limits.joint_speed_rad_s + 0.05)


def test_stop_request_during_exit_reverses_smoothly(
    quad: robots.Robot, limits: BlendLimits
) -> None:
    b = _walking(quad, limits, Velocity(0.1, 0.0, 0.0))
    _run(b, Velocity(), 0.4)  # decelerate to rest, then start blending out
    assert b.state == "gait" and 0.0 < b.blend_weight < 1.0
    w = b.blend_weight
    q = _run(b, Velocity(0.1, 0.0, 0.0), 3.0)
    assert b.blend_weight == 1.0 and w < 1.0
    assert np.max(np.abs(np.diff(q, axis=0))) / DT < 0.6 * np.min(limits.joint_speed_rad_s)


def test_start_pose_ramps_to_the_stand(quad: robots.Robot, limits: BlendLimits) -> None:
    start = np.asarray(quad.nominal_stance_rad) + 0.2
    b = GaitBlender(make_library(quad), limits, start_rad=start)
    assert not b.standing and b.state == "stand_ramp"
    q = _run(b, Velocity(), 3.0)
    assert b.standing
    np.testing.assert_allclose(q[-1], quad.nominal_stance_rad, atol=1e-12)


def test_missing_grid_entry_is_interpolated_from_its_neighbours(
    quad: robots.Robot, limits: BlendLimits
) -> None:
    hole = Velocity(0.1, 0.0, 0.5)
    b = GaitBlender(make_library(quad, skip=(hole,)), limits)
    _run(b, hole, 8.0)
    assert b.command == hole
    q = b.step(hole, DT)
    # the cell's other corners, equal weights: the fixture is linear, so their mean is exact
    corners = [Velocity(0.0, 0.0, 0.5), Velocity(0.2, 0.0, 0.5)]
    expected = np.mean([_expected(quad, c, b.phase) for c in corners], axis=0)
    np.testing.assert_allclose(q, expected, atol=1e-12)


def test_bad_inputs(quad: robots.Robot, limits: BlendLimits) -> None:
    lib = make_library(quad)
    with pytest.raises(BlendError, match="joint_speed_rad_s has 3 values"):
        GaitBlender(lib, BlendLimits(0.5, 2.0, np.ones(3)))
    with pytest.raises(BlendError, match="lower_rad must be 3"):
        replace(limits, joint_speed_rad_s=np.ones(3))
    with pytest.raises(BlendError, match="accel_m_s2"):
        BlendLimits(0.0, 1.0, np.ones(12))
    b = GaitBlender(lib, limits)
    with pytest.raises(BlendError, match="not finite"):
        b.step(Velocity(float("nan")), DT)
    with pytest.raises(BlendError, match="dt_s"):
        b.step(Velocity(0.1), 0.0)
    with pytest.raises(BlendError, match="start_rad"):
        GaitBlender(lib, limits, start_rad=np.zeros(5))


def test_library_and_blend_stay_light() -> None:
    """hardware (the drive mode) imports these: numpy only, no mujoco, casadi or sim."""
    import subprocess
    import sys

    code = ("import sys, robots.blend, robots.library; "
            "print(sorted(m for m in ('mujoco', 'casadi', 'sim', 'planner') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


@pytest.mark.parametrize(("share", "clipped"), [(None, True), (0.95, False)])
def test_fast_command_changes_stay_in_the_joint_speed_budget(
    quad: robots.Robot, share: float | None, clipped: bool
) -> None:
    """At 5 m/s² and 20 rad/s² the command alone would move the targets faster than the servos
    allow (the clip cuts them); with the speed budget the command slows down instead."""
    limits = replace(BlendLimits.for_robot(quad, 5.0, 20.0, speed_fraction=0.3),
                     command_speed_share=share)
    b = GaitBlender(make_library(quad), limits)
    script = ([Velocity(0.01)] * 600 + [Velocity(0.2, 0.0, 0.5)] * 100
              + [Velocity(0.0, 0.0, -0.5)] * 100)
    cut = 0
    for c in script:
        b.step(c, DT)
        cut += b.speed_clipped
    assert (cut > 0) == clipped, cut
    assert b.command == Velocity(0.0, 0.0, -0.5)  # it still gets there
    with pytest.raises(BlendError, match="command_speed_share"):
        replace(limits, command_speed_share=1.5)

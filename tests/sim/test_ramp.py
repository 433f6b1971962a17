"""robots.ramp: the shared min-jerk ramp and gait entry (used by sim.validate and the player)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from robots.gait import Gait, Velocity
from robots.ramp import (
    ENTRY_CYCLES_KEY,
    MIN_JERK_PEAK_SPEED,
    RUN_ENTRY_ACCEL_G,
    STANDARD_GRAVITY_M_S2,
    GaitEntry,
    MinJerkRamp,
    blend_cycles,
    gait_entry,
    gait_exit,
    gait_mean_pose,
    has_flight,
    min_jerk,
    ramp_duration_s,
    ramp_to,
    requested_cycles,
    run_speed_up_cycles,
)
from robots.robot import Robot
from robots.schedule import ContactSchedule


def test_min_jerk_endpoints_and_symmetry() -> None:
    assert min_jerk(0.0) == 0.0 and min_jerk(1.0) == 1.0
    u = np.linspace(0, 1, 101)
    np.testing.assert_allclose(min_jerk(u) + min_jerk(1 - u), 1.0, atol=1e-12)
    assert np.all(np.diff(min_jerk(u)) >= 0)


def test_ramp_positions_velocities_and_hold() -> None:
    ramp = MinJerkRamp(np.array([0.0, 1.0]), np.array([1.0, -1.0]), 2.0)
    np.testing.assert_allclose(ramp.positions(0.0), [0.0, 1.0])
    np.testing.assert_allclose(ramp.positions(2.0), [1.0, -1.0])
    np.testing.assert_allclose(ramp.positions(5.0), [1.0, -1.0])  # held after T
    np.testing.assert_allclose(ramp.velocities(np.array([0.0, 2.0])), 0.0, atol=1e-12)
    t = np.linspace(0, 2, 2001)
    fd = np.gradient(ramp.positions(t), t, axis=0)
    np.testing.assert_allclose(ramp.velocities(t)[1:-1], fd[1:-1], atol=1e-4)
    assert ramp.peak_speed_rad_s == pytest.approx(MIN_JERK_PEAK_SPEED * 2.0 / 2.0)
    assert np.max(np.abs(ramp.velocities(t))) == pytest.approx(ramp.peak_speed_rad_s, rel=1e-5)


def test_duration_respects_speed_cap() -> None:
    assert ramp_duration_s(np.zeros(3), np.full(3, 0.1), 5.0) == 1.0
    d = ramp_duration_s(np.zeros(2), np.array([3.0, 0.0]), 1.0)
    assert d == pytest.approx(MIN_JERK_PEAK_SPEED * 3.0)
    assert ramp_to(np.zeros(2), np.array([3.0, 0.0]), 1.0).peak_speed_rad_s == pytest.approx(1.0)


def test_bad_inputs() -> None:
    with pytest.raises(ValueError):
        MinJerkRamp(np.zeros(2), np.zeros(3), 1.0)
    with pytest.raises(ValueError):
        MinJerkRamp(np.zeros(2), np.zeros(2), 0.0)
    with pytest.raises(ValueError):
        ramp_duration_s(np.zeros(2), np.ones(2), 0.0)


# -- gait_entry: ramp to the mean pose, then blend the gait in (issue #12) ----------------------


def test_gait_mean_pose_is_the_cycle_average(hex_tripod: Gait) -> None:
    phase = np.linspace(0.0, 1.0, 4001)[:-1]
    average = hex_tripod.joint_targets(phase * hex_tripod.period_s).mean(axis=0)
    np.testing.assert_allclose(gait_mean_pose(hex_tripod), average, atol=1e-9)


def test_gait_entry_starts_at_rest_and_ends_in_the_gait(hex18: Robot, hex_tripod: Gait) -> None:
    gait = hex_tripod
    present = np.asarray(hex18.nominal_stance_rad) + 0.05
    entry = gait_entry(gait, present, 2.0, 0.8)
    assert entry.cycles >= 1 and entry.ramp.duration_s >= 0.8
    assert entry.duration_s == pytest.approx(entry.ramp.duration_s + entry.cycles * gait.period_s)
    np.testing.assert_allclose(entry.positions(0.0), present)
    np.testing.assert_allclose(entry.positions(entry.ramp.duration_s), gait_mean_pose(gait))
    np.testing.assert_allclose(entry.positions(entry.duration_s), gait.joint_targets(0.0))
    # C¹ into the gait: the entry's speed at its end is the gait's speed at phase 0
    h = 1e-5
    end_speed = (entry.positions(entry.duration_s) - entry.positions(entry.duration_s - h)) / h
    gait_speed = (gait.joint_targets(0.0) - gait.joint_targets(-h)) / h
    np.testing.assert_allclose(end_speed, gait_speed, atol=1e-3)
    # the stream is continuous throughout (no step between ramp, blend and gait)
    t = np.linspace(0.0, entry.duration_s, 20001)
    assert np.max(np.abs(np.diff(entry.positions(t), axis=0))) < 1e-3
    assert entry.blend_weight(0.0) == 0.0 and entry.blend_weight(entry.duration_s) == 1.0


def test_blend_cycles_respect_the_speed_cap(hex_tripod: Gait) -> None:
    gait = hex_tripod
    amplitude = np.max(np.abs(gait.knots_rad - gait_mean_pose(gait)))
    cap = MIN_JERK_PEAK_SPEED * amplitude / (2.5 * gait.period_s)  # needs 2.5 → 3 cycles
    assert blend_cycles(gait, cap) == 3
    assert blend_cycles(gait, cap, time_scale=0.5) == 2  # played at half speed: slower per cycle
    assert blend_cycles(gait, 100.0) == 1 and blend_cycles(gait, 100.0, min_cycles=2) == 2
    entry = gait_entry(gait, gait_mean_pose(gait), cap)
    t = np.linspace(entry.ramp.duration_s, entry.duration_s, 4001)
    blend_term = np.gradient(entry.blend_weight(t), t)[:, None] * (
        gait.joint_targets(t - entry.ramp.duration_s) - gait_mean_pose(gait)
    )
    assert np.max(np.abs(blend_term)) <= cap * 1.001
    with pytest.raises(ValueError):
        blend_cycles(gait, 0.0)
    with pytest.raises(ValueError):
        GaitEntry(entry.ramp, gait, 0)


def _as_run(gait: Gait, duty: float, speed_m_s: float) -> Gait:
    """`gait` with its two tripods on `duty` (< 0.5: a flight phase) at `speed_m_s`."""
    s = gait.schedule
    sched = ContactSchedule(s.period_s, s.feet, s.touchdown_phase, (duty,) * s.n_feet)
    return replace(gait, schedule=sched, velocity=Velocity(vx_m_s=speed_m_s))


def test_a_run_blends_in_over_enough_cycles_to_reach_its_speed(hex_tripod: Gait) -> None:
    """Issue #14: a gait with flight gets k ≥ v/(a·T) blend cycles, in and out; a walk keeps
    the speed-cap k (quad12/hex18 walks and trots have no flight: their entry is unchanged)."""
    walk_k = blend_cycles(hex_tripod, 5.0)
    assert not has_flight(hex_tripod) and run_speed_up_cycles(hex_tripod) == 1
    run = _as_run(hex_tripod, 0.4, 0.5)
    assert has_flight(run)
    need = math.ceil(0.5 / (RUN_ENTRY_ACCEL_G * STANDARD_GRAVITY_M_S2 * run.period_s))
    assert need > walk_k and run_speed_up_cycles(run) == need
    assert blend_cycles(run, 5.0) == need
    entry = gait_entry(run, gait_mean_pose(run), 5.0)
    assert entry.cycles == need and gait_exit(run, 0.0, 5.0).cycles == need
    # the same schedule without flight (duty 0.5: one tripod lands as the other lifts) or at rest
    assert not has_flight(_as_run(hex_tripod, 0.5, 0.5))
    assert run_speed_up_cycles(_as_run(hex_tripod, 0.4, 0.0)) == 1


def test_a_gait_file_can_ask_for_a_longer_entry(hex_tripod: Gait) -> None:
    """`plan --entry-cycles K` writes planner["entry_blend_cycles"] = K: the entry and the exit
    blend over at least K cycles (player and simulator alike); a shorter request changes
    nothing, a malformed one is refused."""
    walk_k = blend_cycles(hex_tripod, 5.0)
    assert requested_cycles(hex_tripod) == 1
    asks = replace(hex_tripod, planner={**hex_tripod.planner, ENTRY_CYCLES_KEY: walk_k + 2})
    assert requested_cycles(asks) == walk_k + 2 and blend_cycles(asks, 5.0) == walk_k + 2
    assert gait_entry(asks, gait_mean_pose(asks), 5.0).cycles == walk_k + 2
    assert gait_exit(asks, 0.0, 5.0).cycles == walk_k + 2
    short = replace(hex_tripod, planner={**hex_tripod.planner, ENTRY_CYCLES_KEY: 1})
    assert blend_cycles(short, 5.0) == walk_k
    for bad in (0, 21, 2.5, True, "3"):
        with pytest.raises(ValueError, match="entry_blend_cycles"):
            blend_cycles(replace(hex_tripod, planner={ENTRY_CYCLES_KEY: bad}), 5.0)


def test_acceptance_judges_with_the_requested_entry(hex_tripod: Gait) -> None:
    """`sim.acceptance.with_entry_cycles`: the search's MuJoCo checks judge each gait with the
    entry blend the written file will ask for (`plan --search --entry-cycles K`); 1 leaves it."""
    from sim.acceptance import SimAcceptance, with_entry_cycles

    assert with_entry_cycles(hex_tripod, 1) is hex_tripod
    asked = with_entry_cycles(hex_tripod, 3)
    assert requested_cycles(asked) == 3 and asked.planner[ENTRY_CYCLES_KEY] == 3
    assert ENTRY_CYCLES_KEY not in hex_tripod.planner  # the original is unchanged
    assert SimAcceptance("hex18", entry_cycles=3).entry_cycles == 3

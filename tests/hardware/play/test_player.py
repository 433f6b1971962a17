"""The player on the virtual bus: ramp-in, streaming, deadlines, dry run, pre-flight refusals."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import robots
from hardware.bus.virtual import FaultPlan
from hardware.play.clock import MonotonicClock, VirtualClock
from hardware.play.errors import PreflightError, SpeedScaleError
from hardware.play.player import Player, PlayerConfig, RestPose
from hardware.play.watchdog import StopReason
from robots.ramp import gait_mean_pose
from tests.hardware.play.player_rig import (
    FAST_BUS,
    assert_wire_safe,
    make_rig,
    torque_all_off,
)

CONFIG = PlayerConfig(cycles=2, ramp_s=0.5, force=True)


def test_nominal_run_tracks_the_gait_and_ends_torque_off(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    result, player = rig.play(CONFIG)
    assert result.stop.reason is StopReason.COMPLETED and result.exit_code == 0
    n_gait = round(2 * rig.gait.period_s * 100) + 1
    assert result.ticks_by_phase["gait"] == n_gait
    assert result.overruns == 0 and result.misses == 0
    goals = assert_wire_safe(rig, player.gate.max_step_ticks)
    assert torque_all_off(rig)
    tel = rig.telemetry()
    gait_rows = np.array([p == "gait" for p in tel.phase])
    # the streamed targets are the gait's spline, sampled on the tick grid
    t_gait = np.arange(n_gait) / 100.0
    np.testing.assert_allclose(tel.target_rad[gait_rows], rig.gait.joint_targets(t_gait), atol=2e-3)
    # the virtual servos follow (no-load speed model): small tracking error
    assert np.nanmax(np.abs(tel.target_rad - tel.present_rad)[gait_rows]) < 0.05
    # goals decoded on the wire are the ticks the telemetry says were sent
    np.testing.assert_array_equal(goals, tel.target_ticks)


def test_ramp_from_far_away_is_smooth_and_step_limited_on_the_wire(tmp_path: Path) -> None:
    robot = robots.load("quad12")
    lo = np.array([j.lower_rad for j in robot.joints])
    hi = np.array([j.upper_rad for j in robot.joints])
    far = lo + 0.02 + 0.9 * (hi - lo) * (np.arange(12) % 2)  # alternate: near lower / upper
    rig = make_rig(tmp_path, start_pose_rad=far)
    result, player = rig.play(replace(CONFIG, cycles=1, ramp_s=0.2))
    assert result.stop.reason is StopReason.COMPLETED
    goals = assert_wire_safe(rig, player.gate.max_step_ticks)
    ramp = goals[: result.ticks_by_phase["ramp_in"]]
    # the ramp is longer than asked (speed-capped) and never step-clipped: smooth by itself
    assert result.ticks_by_phase["ramp_in"] > 20
    assert result.step_clips == 0
    steps = np.abs(np.diff(np.vstack([rig.start_ticks, ramp]), axis=0))
    allowed = player.allowed_speed_rad_s * CONFIG.ramp_speed_fraction
    tpr = np.array([j.servo.ticks_per_rad for j in robot.joints])
    assert np.all(steps <= allowed * tpr / 100.0 + 1.0)  # peak speed cap (+1 tick rounding)
    # min-jerk: starts and ends at rest (first and last steps tiny), peak near the middle
    assert steps[0].max() <= 1 and steps[-1].max() <= 1
    biggest = int(np.argmax(steps.max(axis=1)))
    assert 0.3 < biggest / len(steps) < 0.7
    # and it ends on the gait's mean pose, where the blend into the gait starts (robots.ramp)
    end = gait_mean_pose(rig.gait)
    assert np.all(np.abs(player.gate.ticks_to_rad(ramp[-1]) - end) <= 1.0 / tpr)


def test_gate_clips_a_target_outside_the_limits(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    _, player = rig.play(replace(CONFIG, cycles=1))
    gate = player.gate
    gate.seed(gate.last_ticks)
    wild = np.full(12, 10.0)
    for _ in range(200):
        cmd = gate.command(wild)
    assert cmd.limit_clipped == 12
    upper = np.array([j.upper_rad for j in rig.robot.joints])
    assert np.all(cmd.target_rad <= upper + 1e-12)
    assert_wire_safe(rig, gate.max_step_ticks)


def test_deadlines_do_not_drift_and_overruns_are_counted(tmp_path: Path) -> None:
    robot = robots.load("quad12")
    from hardware.play.virtual_rig import bringup_gait

    clock = VirtualClock(1000.0)
    slow = {400: 0.025}  # one tick takes 25 ms: 2 deadlines missed

    def on_tick(tick: int, t_s: float) -> None:
        clock.advance(slow.get(tick, 0.004))  # every tick's work takes 4 ms of the 10 ms

    cfg = PlayerConfig(cycles=75, ramp_s=0.5, force=True, dry_run=True)  # 60 s of gait
    player = Player(robot, bringup_gait(robot), bus=None, config=cfg, clock=clock, on_tick=on_tick)
    result = player.run()
    assert result.stop.reason is StopReason.COMPLETED
    # tick 400 ran 25 ms: deadline 401 skipped, 402 ran 5 ms late, then back on the grid
    assert (result.overruns, result.skipped) == (1, 1)
    assert result.ticks > 6000
    assert result.jitter_max_s == pytest.approx(0.005, abs=1e-6)
    jitter = np.array(player._jitter)
    assert np.count_nonzero(jitter > 1e-9) == 1  # every other tick started on its deadline
    assert result.achieved_rate_hz == pytest.approx(100.0, rel=1e-3)


def test_dry_run_sends_nothing(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    result, _ = rig.play(replace(CONFIG, dry_run=True))
    assert result.stop.reason is StopReason.COMPLETED and result.dry_run
    assert rig.wire.writes == []  # no goal, no torque write on the wire
    assert result.ticks > 0 and len(rig.telemetry().tick) == result.ticks


def test_rest_present_stays_where_it_stopped(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)

    def on_tick(tick: int, t_s: float) -> None:
        if tick == 100:
            rig.vbus.faults = FaultPlan(overheat=frozenset({1}))

    result, player = rig.play(replace(CONFIG, rest=RestPose.PRESENT), on_tick)
    assert result.stop.reason is StopReason.OVER_TEMPERATURE
    goals = assert_wire_safe(rig, player.gate.max_step_ticks)
    out = goals[-result.ticks_by_phase["ramp_out"] :]
    assert np.abs(out[-1] - out[0]).max() <= 3 * player.gate.max_step_ticks.max()


def test_speed_scale_too_fast_is_refused_before_anything_moves(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    with pytest.raises(SpeedScaleError, match="speed-scale"):
        rig.play(replace(CONFIG, speed_scale=20.0))
    assert rig.wire.writes == []


def test_slower_speed_scale_stretches_the_gait(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    result, _ = rig.play(replace(CONFIG, cycles=1, speed_scale=0.5))
    assert result.ticks_by_phase["gait"] == round(rig.gait.period_s / 0.5 * 100) + 1


@pytest.mark.parametrize(
    ("problem", "match"),
    [
        ("vanished", r"servo 5 \(fr_hip_pitch\): does not answer ping"),
        ("overheat", r"servo 3 \(fl_knee\): hardware error flags: overheat"),
        ("sag", r"servo 1 \(fl_hip_roll\): .*voltage"),
        ("not_validated", r"gait validation: gait has no sim validation"),
        ("failed_validation", r"FAILED sim validation"),
        ("pose", r"joint fl_knee \(servo 3\): present angle"),
        ("fingerprint", r"gait: .*robot_fingerprint"),
    ],
)
def test_preflight_refusals_name_the_culprit(tmp_path: Path, problem: str, match: str) -> None:
    rig = make_rig(tmp_path)
    config = CONFIG
    if problem == "vanished":
        rig.vbus.vanish(5)
    elif problem == "overheat":
        rig.vbus.faults = FaultPlan(overheat=frozenset({3}))
    elif problem == "sag":
        rig.vbus.faults = FaultPlan(voltage_sag_v=2.0)
    elif problem == "not_validated":
        config = replace(CONFIG, force=False)
    elif problem == "failed_validation":
        rig.gait = rig.gait.with_validation({"passed": False, "reasons": ["fell"]})
        config = replace(CONFIG, force=False)
    elif problem == "pose":
        from hardware.play.virtual_rig import place_servos

        pose = np.array(rig.robot.nominal_stance_rad)
        pose[2] = 0.3  # knee limits are [-2.6, -0.2]
        place_servos(rig.vbus, rig.robot, pose)
    elif problem == "fingerprint":
        rig.gait = replace(rig.gait, robot_fingerprint="0" * 16)
    with pytest.raises(PreflightError, match=match):
        rig.play(config)
    assert rig.wire.writes == []  # refused: nothing was written
    assert torque_all_off(rig)


def test_validated_gait_plays_without_force(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    rig.gait = rig.gait.with_validation({"passed": True})
    result, _ = rig.play(replace(CONFIG, force=False, cycles=1))
    assert result.stop.reason is StopReason.COMPLETED and result.warnings == ()


def test_wrong_model_number_is_refused(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    servo = rig.vbus.servo(7)
    servo._set("model_number", 1060)  # an XL430 where an STS3215 should be
    with pytest.raises(PreflightError, match=r"servo 7 \(hl_hip_roll\): model number 1060"):
        rig.play(CONFIG)


def test_real_time_run_keeps_its_rate(tmp_path: Path) -> None:
    """A short run on the wall clock (about 1.3 s): rate, deadlines and jitter."""
    robot = robots.load("quad12")
    from hardware.play.virtual_rig import bringup_gait, virtual_robot_bus

    clock = MonotonicClock()
    vbus = virtual_robot_bus(robot, clock=clock)
    bus = vbus.connect(FAST_BUS)
    cfg = PlayerConfig(cycles=1, ramp_s=0.3, stop_ramp_s=0.2, force=True)
    result = Player(robot, bringup_gait(robot), bus=bus, config=cfg, clock=clock).run()
    assert result.stop.reason is StopReason.COMPLETED
    assert result.achieved_rate_hz == pytest.approx(100.0, rel=0.03)
    assert result.jitter_p50_s < 0.002
    assert result.overruns <= result.ticks // 10
    assert not any(s.torque_enabled for s in vbus.servos)

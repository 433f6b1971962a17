"""The player starts a run from the gait's stand and ends it there (issue #14): ramp-in to the
mean pose, hold it `stand_s`, blend in; on normal completion blend *out* to the stand and hold it
instead of ramping in joint space to rest. Faults and signals keep the safe-stop path."""

from __future__ import annotations

import signal
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import robots
from hardware.bus.virtual import FaultPlan
from hardware.cli import app
from hardware.play.player import PlayerConfig
from hardware.play.telemetry import read_telemetry
from hardware.play.virtual_rig import bringup_gait
from hardware.play.watchdog import StopReason
from robots.gait import save
from robots.ramp import gait_exit, gait_mean_pose
from tests.hardware.play.player_rig import assert_wire_safe, make_rig, torque_all_off

CONFIG = PlayerConfig(cycles=2, ramp_s=0.5, force=True, stand_s=0.3)


def _runs(phases: list[str]) -> list[tuple[str, int]]:
    """Consecutive (phase, ticks) runs of the telemetry's phase column."""
    out: list[tuple[str, int]] = []
    for p in phases:
        if out and out[-1][0] == p:
            out[-1] = (p, out[-1][1] + 1)
        else:
            out.append((p, 1))
    return out


def test_a_completed_run_holds_the_stand_then_blends_out_to_it(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    result, player = rig.play(CONFIG)
    assert result.stop.reason is StopReason.COMPLETED and result.exit_code == 0
    assert "ended at the stand" in result.stop.message
    tel = rig.telemetry()
    runs = _runs(list(tel.phase))
    assert [p for p, _ in runs] == ["ramp_in", "stand", "blend_in", "gait", "blend_out", "stand"]
    assert dict(runs)["stand"] == 30  # 0.3 s at 100 Hz, at the start and at the end
    assert runs[-1] == ("stand", 30)
    assert "ramp_out" not in result.ticks_by_phase  # no joint-space ramp to rest
    mean = gait_mean_pose(rig.gait)
    target = np.asarray(tel.target_rad)
    phase = np.asarray(tel.phase)
    stand_rows = np.flatnonzero(phase == "stand")
    one_tick = 2 * np.pi / 4096  # telemetry targets are the goals sent, in servo ticks
    np.testing.assert_allclose(target[stand_rows], np.broadcast_to(mean, target[stand_rows].shape),
                               atol=one_tick)
    # the blend-out starts where the gait left off: no jump beyond one tick's gait motion
    first_out = int(np.flatnonzero(phase == "blend_out")[0])
    step = np.abs(target[first_out] - target[first_out - 1]).max()
    gait_steps = np.abs(np.diff(target[phase == "gait"], axis=0)).max()
    assert step <= 1.5 * gait_steps
    goals = assert_wire_safe(rig, player.gate.max_step_ticks)
    assert len(goals) == result.ticks and torque_all_off(rig)


def test_the_blend_out_ends_exactly_at_the_mean_pose_and_lasts_the_entry_blend(
    tmp_path: Path,
) -> None:
    rig = make_rig(tmp_path)
    result, player = rig.play(replace(CONFIG, stand_s=0.0))
    exit_ = gait_exit(rig.gait, 0.0, player.allowed_speed_rad_s * CONFIG.ramp_speed_fraction)
    assert result.ticks_by_phase["blend_out"] == round(exit_.duration_s * 100)
    assert result.ticks_by_phase["blend_out"] == result.ticks_by_phase["blend_in"]
    assert "stand" not in result.ticks_by_phase
    tel = rig.telemetry()
    phase = np.asarray(tel.phase)
    last = np.asarray(tel.target_rad)[np.flatnonzero(phase == "blend_out")[-1]]
    # the last blend-out target is one tick short of the stand, on the min-jerk tail
    np.testing.assert_allclose(last, gait_mean_pose(rig.gait), atol=2 * np.pi / 4096)


def test_without_end_at_stand_a_completed_run_ramps_to_rest_as_before(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    result, _ = rig.play(replace(CONFIG, end_at_stand=False))
    assert result.stop.reason is StopReason.COMPLETED
    assert result.stop.message == "played 2 cycle(s)"
    assert "blend_out" not in result.ticks_by_phase and result.ticks_by_phase["ramp_out"] > 0
    assert rig.telemetry().phase[-1] == "ramp_out"


def test_a_fault_during_the_blend_out_takes_the_safe_stop_path(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    first = make_rig(tmp_path / "probe")
    probe, _ = first.play(CONFIG)
    fault_tick = probe.ticks - probe.ticks_by_phase["blend_out"] // 2 - 30  # mid blend-out

    def on_tick(tick: int, t_s: float) -> None:
        if tick == fault_tick:
            rig.vbus.faults = FaultPlan(overheat=frozenset({1}))

    result, player = rig.play(CONFIG, on_tick)
    assert result.stop.reason is StopReason.OVER_TEMPERATURE  # not a normal completion
    tel = rig.telemetry()
    assert "blend_out" in tel.phase and tel.phase[-1] == "ramp_out"
    assert_wire_safe(rig, player.gate.max_step_ticks)
    assert torque_all_off(rig)


def test_a_signal_during_the_blend_out_stops_as_that_signal(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    first = make_rig(tmp_path / "probe")
    probe, _ = first.play(CONFIG)
    signal_tick = probe.ticks - probe.ticks_by_phase["blend_out"] // 2 - 30

    def on_tick(tick: int, t_s: float) -> None:
        if tick == signal_tick:
            signal.raise_signal(signal.SIGTERM)

    result, _ = rig.play(CONFIG, on_tick)
    assert result.stop.reason is StopReason.SIGTERM and result.exit_code == 143
    assert rig.telemetry().phase[-1] == "ramp_out"
    assert torque_all_off(rig)


@pytest.mark.parametrize("stand_s", [-0.1, float("nan"), 1e6])
def test_a_bad_stand_hold_is_refused(stand_s: float) -> None:
    with pytest.raises(ValueError, match="stand_s must lie in"):
        PlayerConfig(stand_s=stand_s)


def test_the_cli_holds_the_stand_and_ends_there_or_at_rest(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))
    gait = tmp_path / "bringup.json"
    save(bringup_gait(robots.load("quad12")), gait)
    common = ["run", str(gait), "--robot", "quad12", "--virtual", "--force", "--no-realtime",
              "--ramp-s", "0.5", "--cycles", "1"]
    runner = CliRunner()
    for extra, last in ((["--stand-s", "0.2"], "stand"), (["--end-at-rest"], "ramp_out")):
        tel = tmp_path / f"{last}.csv"
        res = runner.invoke(app, [*common, *extra, "--telemetry", str(tel)])
        assert res.exit_code == 0, res.output
        phases = read_telemetry(tel).phase
        assert phases[-1] == last
        assert ("blend_out" in phases) == (last == "stand")
    res = runner.invoke(app, [*common, "--stand-s", "-1"])
    assert res.exit_code == 2 and "--stand-s -1: must be a finite number in [0, 60] s" in res.output

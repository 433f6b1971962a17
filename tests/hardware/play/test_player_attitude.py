"""The player's IMU feedback on the virtual bus: offsets before the SafetyGate, stance legs
only, a stale IMU fades the correction out, and the closed-loop pre-flight refusal."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from hardware.cli import app as play_app
from hardware.play.attitude import AttitudeCorrector, SyntheticAttitude
from hardware.play.errors import PlayerError, PreflightError
from hardware.play.player import Player, PlayerConfig
from hardware.play.telemetry import TelemetryWriter
from hardware.play.watchdog import StopReason
from robots.attitude import ATTITUDE_GAIN_KEY, AttitudeLaw
from robots.attitude_maps import attitude_map
from robots.gait import load as load_gait
from robots.gait import save as save_gait
from tests.hardware.play.player_rig import Rig, assert_wire_safe, make_rig

CONFIG = PlayerConfig(cycles=2, ramp_s=0.5, force=True)
TILT = (0.04, -0.03)  # a constant measured roll, pitch [rad]


def _play(rig: Rig, corrector: AttitudeCorrector | None, config: PlayerConfig = CONFIG
          ) -> tuple[object, Player]:
    writer = TelemetryWriter(rig.telemetry_path, rig.robot.joint_names, rig.ids)
    player = Player(rig.robot, rig.gait, bus=rig.bus, config=config, clock=rig.clock,
                    telemetry=writer, attitude=corrector)
    return player.run(), player


def _corrector(rig: Rig, gain: float = 1.0, **source_kw: int) -> AttitudeCorrector:
    source = SyntheticAttitude(lambda t: TILT, rig.clock.now_s, **source_kw)
    return AttitudeCorrector(AttitudeLaw(gain), attitude_map(rig.robot), rig.gait, source)


def _gait_targets(tmp_path: Path, corrector_gain: float | None, **source_kw: int
                  ) -> tuple[Rig, np.ndarray, np.ndarray, Player]:
    rig = make_rig(tmp_path, "biped")
    corr = None if corrector_gain is None else _corrector(rig, corrector_gain, **source_kw)
    result, player = _play(rig, corr)
    assert result.stop.reason is StopReason.COMPLETED  # type: ignore[attr-defined]
    tel = rig.telemetry()
    gait_rows = np.array([p == "gait" for p in tel.phase])
    return rig, tel.target_rad[gait_rows], tel.t_sched_s[gait_rows], player


def test_offsets_reach_the_gate_on_stance_legs_only(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    rig, open_loop, t, _ = _gait_targets(tmp_path / "a", None)
    rig_c, closed, _, player = _gait_targets(tmp_path / "b", 1.0)
    diff = closed - open_loop
    assert np.max(np.abs(diff)) > 0.01  # the correction is in the streamed targets
    assert_wire_safe(rig_c, player.gate.max_step_ticks)  # limits and step budget still hold
    sched = rig.gait.schedule
    amap = attitude_map(rig.robot)
    for f, leg in enumerate(amap.legs):
        cols = list(leg.joint_index)
        phase = (np.arange(len(t)) / 100.0 / rig.gait.period_s) % 1.0
        swing = ((phase - sched.touchdown_phase[f]) % 1.0) >= sched.duty_factor[f] + 0.02
        assert np.any(swing)
        # a swinging leg's targets are open loop's (up to the gate's rounding to ticks)
        assert np.max(np.abs(diff[swing][:, cols])) < 2e-3


def test_a_stale_imu_fades_the_correction_to_zero(tmp_path: Path) -> None:
    """The IMU stops 0.2 s into the gait: the correction then shrinks steadily (never frozen)
    and is gone after the max age plus the fade time."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    rig, open_loop, _, _ = _gait_targets(tmp_path / "a", None)
    entry_ticks = sum(p in ("ramp_in", "stand", "blend_in") for p in rig.telemetry().phase)
    probe = make_rig(tmp_path / "b", "biped")
    stall = 0.2  # [s] into the gait
    corr = _corrector(probe, 1.0, stall_after_reads=entry_ticks + 20)
    result, _ = _play(probe, corr)
    assert result.stop.reason is StopReason.COMPLETED  # type: ignore[attr-defined]
    tel = probe.telemetry()
    rows = np.array([p == "gait" for p in tel.phase])
    size = np.max(np.abs(tel.target_rad[rows] - open_loop), axis=1)
    ts = tel.t_sched_s[rows] - tel.t_sched_s[rows][0]
    assert np.max(size[ts < stall]) > 0.01
    gone = ts > stall + corr.max_age_s + corr.fade_s + 0.02
    assert np.any(gone) and np.max(size[gone]) < 2e-3
    assert corr.stale_ticks > 0 and corr.trust == 0.0


def test_closed_loop_gait_is_refused_open_loop_unless_forced(tmp_path: Path) -> None:
    rig = make_rig(tmp_path, "biped")
    validation = {"passed": True, "conditions": {ATTITUDE_GAIN_KEY: 0.5}}
    gait = rig.gait.with_validation(validation)
    strict = replace(CONFIG, force=False)
    with pytest.raises(PreflightError, match=r"closed loop.*--force"):
        Player(rig.robot, gait, bus=rig.bus, config=strict, clock=rig.clock).run()
    forced = Player(rig.robot, gait, bus=rig.bus, config=CONFIG, clock=rig.clock).run()
    assert any("open loop because of --force" in w for w in forced.warnings)
    (tmp_path / "x").mkdir()
    rig2 = make_rig(tmp_path / "x", "biped")
    closed = Player(rig2.robot, gait, bus=rig2.bus, config=strict, clock=rig2.clock,
                    attitude=_corrector(rig2, 0.5)).run()
    assert closed.stop.reason is StopReason.COMPLETED
    assert not any("attitude" in w or "closed loop" in w for w in closed.warnings)


def test_corrector_settings_are_checked(tmp_path: Path) -> None:
    rig = make_rig(tmp_path, "biped")
    source = SyntheticAttitude(lambda t: TILT, rig.clock.now_s)
    with pytest.raises(PlayerError, match="max age"):
        AttitudeCorrector(AttitudeLaw(1.0), attitude_map(rig.robot), rig.gait, source,
                          max_age_s=0.0)


def _closed_loop_gait_file(tmp_path: Path) -> Path:
    """The biped's 0.222 m/s walk (passes closed loop at G 0.5: tests/sim/test_attitude_loop.py)
    with the verdict of that run's kind: passed, attitude gain 0.5."""
    gait = load_gait(Path(__file__).parents[2] / "sim" / "fixtures" / "biped_walk_0222.json")
    path = tmp_path / "walk.json"
    save_gait(gait.with_validation({"passed": True, "conditions": {ATTITUDE_GAIN_KEY: 0.5}}),
              path)
    return path


def test_play_cli_reads_the_twins_imu_and_refuses_open_loop(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))
    path = _closed_loop_gait_file(tmp_path)
    common = ["run", str(path), "--robot", "biped", "--no-realtime", "--ramp-s", "0.5",
              "--cycles", "2"]
    res = CliRunner().invoke(play_app, [*common, "--virtual", "sim"])
    assert res.exit_code == 0, res.output
    assert "attitude feedback: gain 0.5 from the twin" in res.output and "twin:" in res.output
    res = CliRunner().invoke(play_app, [*common, "--virtual", "sim", "--attitude-gain", "0"])
    assert res.exit_code == 2 and "closed loop" in res.output, res.output
    res = CliRunner().invoke(play_app, [*common, "--virtual", "--attitude-gain", "0.5"])
    assert res.exit_code == 2 and "no IMU" in res.output, res.output
    res = CliRunner().invoke(play_app, [*common, "--virtual", "sim", "--attitude-gain", "9"])
    assert res.exit_code == 2 and "--attitude-gain" in res.output, res.output

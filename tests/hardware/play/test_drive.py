"""The drive loop on the virtual bus: scripted commands through the blender, deadman, clipping
into the grid, malformed input, pre-flight over the library — judged from the wire."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hardware.play.drive import DriveConfig, worst_heating
from hardware.play.errors import PreflightError
from hardware.play.watchdog import StopReason
from robots.gait import Velocity
from robots.library import GaitLibrary, LibraryEntry
from tests.hardware.play.drive_rig import (
    DRIVE_CONFIG,
    drive_rig,
    repeated,
    run_drive,
    script_lines,
)
from tests.hardware.play.player_rig import assert_wire_safe, torque_all_off

PERIOD_S = 1.0 / DRIVE_CONFIG.rate_hz


def test_a_scripted_drive_walks_turns_stands_and_ends_with_the_safe_stop(
    tmp_path: Path,
) -> None:
    rig, lib = drive_rig(tmp_path)
    cmds = (
        repeated(0.0, 3.0, 0.2, vx=0.15)
        + repeated(3.0, 5.0, 0.2, vx=0.1, yaw_rate=0.4)
        + [{"t": 5.0, "end": True}]
    )
    drive = DriveConfig(accel_m_s2=0.5, yaw_accel_rad_s2=1.5)
    result, driver = run_drive(rig, lib, script_lines(cmds), drive=drive)
    play = result.play
    assert play.stop.reason is StopReason.COMPLETED and result.exit_code == 0, play.stop
    assert play.stop.message == "script ended; standing"
    assert result.commands == len(cmds) and result.malformed == 0 and result.deadman_trips == 0
    phases = list(play.ticks_by_phase)
    assert phases == ["ramp_in", "drive", "stand", "ramp_out"], phases
    assert play.step_clips == 0 and play.limit_clips == 0  # the blender kept inside the gate
    assert_wire_safe(rig, driver.gate.max_step_ticks)
    assert torque_all_off(rig)

    tel = rig.telemetry()
    assert tel.stop_reason == "completed" and len(tel.tick) == play.ticks
    drive_rows = np.array([p in ("drive", "stand") for p in tel.phase])
    req = tel.extra["requested_vx_m_s"][drive_rows]
    app = tel.extra["applied_vx_m_s"][drive_rows]
    yaw = tel.extra["applied_yaw_rate_rad_s"][drive_rows]
    assert set(np.round(req, 6)) == {0.0, 0.1, 0.15}
    assert np.max(app) == pytest.approx(0.15) and np.max(yaw) == pytest.approx(0.4)
    # the applied command moves at most accel·dt per tick; requested jumps
    assert np.max(np.abs(np.diff(app))) <= drive.accel_m_s2 * PERIOD_S + 1e-9
    assert np.max(np.abs(np.diff(yaw))) <= drive.yaw_accel_rad_s2 * PERIOD_S + 1e-9
    assert np.max(np.abs(np.diff(req))) >= 0.05
    # the gait phase is continuous (wraps at 1) while walking, also when the command changes
    walking = (app != 0) | (yaw != 0)
    both = walking[1:] & walking[:-1]
    dphi = np.mod(np.diff(tel.extra["gait_phase"][drive_rows]), 1.0)[both]
    assert both.sum() > 300 and np.all(dphi < 0.05)
    assert tel.phase[-1] == "ramp_out"


def test_no_command_for_the_deadman_time_brings_the_robot_to_the_stand(tmp_path: Path) -> None:
    rig, lib = drive_rig(tmp_path)
    cmds = repeated(0.0, 2.0, 0.1, vx=0.2)  # then silence; the input stays open
    drive = DriveConfig(deadman_s=0.3, max_drive_s=8.0)
    result, _ = run_drive(rig, lib, script_lines(cmds), drive=drive, keep_open=True)
    assert result.deadman_trips == 1
    assert result.play.stop.reason is StopReason.COMPLETED, result.play.stop
    tel = rig.telemetry()
    rows = np.array([p in ("drive", "stand") for p in tel.phase])
    t = tel.t_sched_s[rows] - tel.t_sched_s[rows][0]
    req = tel.extra["requested_vx_m_s"][rows]
    last_cmd_s = 1.9
    assert np.all(req[t < last_cmd_s + 0.3] == 0.2)
    assert np.all(req[t > last_cmd_s + 0.3 + 1e-6] == 0.0)  # the deadman, to the tick
    stand = [p == "stand" for p in np.array(tel.phase)[rows]]
    assert any(stand) and tel.phase[-1] == "ramp_out"
    first_stand_s = t[stand.index(True)]
    assert last_cmd_s + 0.3 < first_stand_s < 8.0  # decelerated, blended out, standing


def test_the_end_of_the_input_stops_at_once_without_waiting_for_the_deadman(
    tmp_path: Path,
) -> None:
    rig, lib = drive_rig(tmp_path)
    cmds = repeated(0.0, 2.0, 0.1, vx=0.2)  # then EOF: no end line, the pipe closes
    result, _ = run_drive(rig, lib, script_lines(cmds), drive=DriveConfig(deadman_s=5.0))
    assert result.play.stop.reason is StopReason.COMPLETED
    assert result.play.stop.message == "script ended; standing"
    assert result.deadman_trips == 0
    tel = rig.telemetry()
    rows = np.array([p in ("drive", "stand") for p in tel.phase])
    t = tel.t_sched_s[rows] - tel.t_sched_s[rows][0]
    req = tel.extra["requested_vx_m_s"][rows]
    assert np.all(req[t < 1.9] == 0.2) and np.all(req[t > 1.9 + 1e-6] == 0.0)


def test_commands_outside_the_grid_are_clipped_into_it_and_telemetry_says_both(
    tmp_path: Path,
) -> None:
    rig, lib = drive_rig(tmp_path)
    lo, hi = lib.command_bounds()
    cmds = [*repeated(0.0, 3.0, 0.2, vx=1.0, yaw_rate=-3.0), {"t": 3.0, "end": True}]
    result, driver = run_drive(rig, lib, script_lines(cmds))
    assert result.play.stop.reason is StopReason.COMPLETED
    tel = rig.telemetry()
    assert np.nanmax(tel.extra["requested_vx_m_s"]) == 1.0
    assert np.nanmax(tel.extra["applied_vx_m_s"]) == pytest.approx(hi.vx_m_s)
    assert np.nanmin(tel.extra["applied_yaw_rate_rad_s"]) == pytest.approx(lo.yaw_rate_rad_s)
    assert_wire_safe(rig, driver.gate.max_step_ticks)


def test_malformed_lines_are_counted_and_never_stop_the_drive(tmp_path: Path) -> None:
    rig, lib = drive_rig(tmp_path)
    good = repeated(0.0, 2.0, 0.2, vx=0.1)
    bad = b'{"vx": "fast"}\nnot json\n{"vx": 1e9}\n{"vX": 0.1}\n\xff\xfe\n'
    data = script_lines(good[:5]) + bad + script_lines([*good[5:], {"t": 2, "end": True}])
    result, _ = run_drive(rig, lib, data)
    assert result.play.stop.reason is StopReason.COMPLETED, result.play.stop
    assert result.malformed == 5 and result.commands == 11
    assert "unknown key" in (result.last_problem or "") or "JSON" in (result.last_problem or "")
    tel = rig.telemetry()
    assert np.nanmax(tel.extra["malformed_lines"]) == 5
    assert "5 malformed" in result.summary()


def test_empty_input_stands_and_ends_at_once(tmp_path: Path) -> None:
    rig, lib = drive_rig(tmp_path)
    result, _ = run_drive(rig, lib, b"")
    play = result.play
    assert play.stop.reason is StopReason.COMPLETED
    assert play.ticks_by_phase.get("drive", 0) == 0 and result.walking_s == 0.0
    assert torque_all_off(rig)


def test_the_drive_works_on_an_18_servo_dynamixel_robot(tmp_path: Path) -> None:
    rig, lib = drive_rig(tmp_path, "hex18")
    cmds = [*repeated(0.0, 2.0, 0.2, vx=0.2, yaw_rate=-0.5), {"t": 2.0, "end": True}]
    result, driver = run_drive(rig, lib, script_lines(cmds))
    assert result.play.stop.reason is StopReason.COMPLETED, result.play.stop
    assert result.walking_s > 2.0
    assert_wire_safe(rig, driver.gate.max_step_ticks)
    assert torque_all_off(rig)


def _with_validation(lib: GaitLibrary, index: int, validation: dict[str, object]) -> GaitLibrary:
    entries = list(lib.entries)
    e = entries[index]
    entries[index] = LibraryEntry(e.command, e.gait.with_validation(validation), e.achieved)
    return replace(lib, entries=tuple(entries))


def test_preflight_refuses_a_library_with_an_entry_that_failed_sim(tmp_path: Path) -> None:
    rig, lib = drive_rig(tmp_path)
    bad = _with_validation(lib, 4, {"passed": False})
    with pytest.raises(PreflightError, match=r"library trot at vx 0.1, vy 0, yaw rate 0: gait "):
        run_drive(rig, bad, b"")
    assert not rig.telemetry_path.exists()  # refused before anything moved
    assert not any(s.torque_enabled for s in rig.vbus.servos)
    forced, _ = run_drive(rig, bad, b"", config=replace(DRIVE_CONFIG, force=True))
    assert any("FAILED sim validation" in w and "vx 0.1" in w for w in forced.play.warnings)


def test_preflight_refuses_a_library_validated_closed_loop(tmp_path: Path) -> None:
    """`gaitsmith library` validates a biped's walks closed loop by the attitude rule; the drive
    has no IMU feedback, so it refuses such a library (it would play a gait with another
    controller than the one its verdict was reached with) unless forced."""
    rig, lib = drive_rig(tmp_path)
    closed = _with_validation(lib, 4, {"passed": True, "conditions": {"attitude_gain": 0.5}})
    with pytest.raises(PreflightError, match=r"validated closed loop \(attitude gain 0.5\)"):
        run_drive(rig, closed, b"")
    assert not any(s.torque_enabled for s in rig.vbus.servos)
    forced, _ = run_drive(rig, closed, b"", config=replace(DRIVE_CONFIG, force=True))
    assert any("playing it open loop because of --force" in w for w in forced.play.warnings)


def test_preflight_refuses_an_entry_faster_than_the_gate_allows(tmp_path: Path) -> None:
    rig, lib = drive_rig(tmp_path)
    e = lib.entries[-1]
    fast = replace(e.gait, period_s=e.gait.period_s / 20)  # 20× the joint speeds
    entries = (*lib.entries[:-1], LibraryEntry(e.command, fast, e.achieved))
    with pytest.raises(PreflightError, match=r"library trot at vx 0.2.*would reach .* rad/s"):
        run_drive(rig, replace(lib, entries=entries), b"")


def test_the_watchdog_heating_forecast_is_the_worst_over_the_library(tmp_path: Path) -> None:
    from hardware.play.thermal_watch import predicted_heating

    rig, lib = drive_rig(tmp_path)
    n, j = lib.stand.n_knots, rig.robot.dof
    light = replace(lib.stand, joint_torques_nm=np.full((n, j), 0.2))
    torques = np.where(np.arange(j) % 2, 0.1, 0.6) * np.ones((n, 1))
    heavy = replace(lib.stand, joint_torques_nm=torques)
    heat = worst_heating(rig.robot, [light, heavy])
    lp, hp = predicted_heating(rig.robot, light), predicted_heating(rig.robot, heavy)
    assert heat and set(heat) == set(lp)
    for sid, p in heat.items():
        assert p.mean_power_w == max(lp[sid].mean_power_w, hp[sid].mean_power_w)
    assert {p.mean_power_w for p in heat.values()} - {p.mean_power_w for p in lp.values()}


def test_drive_config_bounds() -> None:
    with pytest.raises(ValueError, match="deadman_s"):
        DriveConfig(deadman_s=0.0)
    with pytest.raises(ValueError, match="accel_m_s2"):
        DriveConfig(accel_m_s2=float("inf"))
    with pytest.raises(ValueError, match="max_drive_s"):
        DriveConfig(max_drive_s=-1.0)
    assert DriveConfig().deadman_s == 0.5
    assert Velocity() == Velocity(0.0, 0.0, 0.0)

"""Fault injection on the virtual bus: the player stops safely, judged from the wire.

For every fault: no goal outside the joint limits and no step above the per-tick maximum (from
the goals the virtual bus decoded), the rest pose reached within 1 s of the fault, torque off at
the end (virtual Torque Enable registers 0), telemetry complete with the stop reason.
"""

from __future__ import annotations

import csv
import os
import signal
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest

from hardware.bus.virtual import FaultPlan, VirtualServoBus
from hardware.play.player import PlayerConfig
from hardware.play.watchdog import StopReason
from tests.hardware.play.player_rig import Rig, assert_wire_safe, make_rig, torque_all_off

RAMP_S = 0.5
T_FAULT_S = 1.0  # into the run: after the ramp-in, mid-gait
CONFIG = PlayerConfig(cycles=3, ramp_s=RAMP_S, force=True)

Inject = Callable[[VirtualServoBus], None]


def _plan(**kw: object) -> Inject:
    def inject(vbus: VirtualServoBus) -> None:
        vbus.faults = replace(vbus.faults, **kw)  # type: ignore[arg-type]

    return inject


def _kill(signum: int) -> Inject:
    return lambda vbus: os.kill(os.getpid(), signum)


FAULTS: dict[str, tuple[str, Inject, StopReason]] = {
    "drop5": ("quad12", _plan(drop_probability=0.05, seed=1), StopReason.NO_RESPONSE),
    "drop20": ("quad12", _plan(drop_probability=0.20, seed=2), StopReason.NO_RESPONSE),
    "corrupt": ("quad12", _plan(corrupt_probability=0.2, seed=3), StopReason.NO_RESPONSE),
    "vanish": ("quad12", lambda vbus: vbus.vanish(5), StopReason.NO_RESPONSE),
    "overload": ("quad12", _plan(overload=frozenset({3})), StopReason.SERVO_FAULT),
    "overheat": ("quad12", _plan(overheat=frozenset({8})), StopReason.OVER_TEMPERATURE),
    "sag": ("quad12", _plan(voltage_sag_v=1.6), StopReason.LOW_VOLTAGE),
    "status_lost": ("quad12", _plan(drop_reads_of={"present_temperature"}), StopReason.STATUS_LOST),
    "sigint": ("quad12", _kill(signal.SIGINT), StopReason.SIGINT),
    "sigterm": ("quad12", _kill(signal.SIGTERM), StopReason.SIGTERM),
    "dxl_overload": ("hex18", _plan(overload=frozenset({4})), StopReason.SERVO_FAULT),
    "dxl_vanish": ("hex18", lambda vbus: vbus.vanish(11), StopReason.NO_RESPONSE),
    "dxl_sigint": ("hex18", _kill(signal.SIGINT), StopReason.SIGINT),
    "dxl_status_lost": (
        "hex18",
        _plan(drop_reads_of={"present_temperature"}),
        StopReason.STATUS_LOST,
    ),
}


@pytest.mark.parametrize("name", sorted(FAULTS))
def test_fault_leads_to_safe_stop(tmp_path: Path, name: str) -> None:
    robot_name, inject, expected = FAULTS[name]
    rig = make_rig(tmp_path, robot_name)
    injected_at: list[float] = []

    def on_tick(tick: int, t_s: float) -> None:
        if not injected_at and t_s >= T_FAULT_S:
            injected_at.append(t_s)
            inject(rig.vbus)

    result, player = rig.play(CONFIG, on_tick)
    assert result.stop.reason is expected, result.stop
    assert injected_at
    assert result.stop.t_s >= injected_at[0]
    assert result.safe_at_s - injected_at[0] <= 1.0, (result.safe_at_s, injected_at)
    assert_wire_safe(rig, player.gate.max_step_ticks)
    assert torque_all_off(rig)
    # telemetry: one row per tick (= per goal frame on the wire), then the stop row
    tel = rig.telemetry()
    assert len(tel.tick) == result.ticks == len(rig.wire.goal_matrix(rig.ids))
    assert list(tel.tick) == list(range(result.ticks))
    assert tel.stop_reason == expected.value
    assert tel.stop_message == result.stop.message
    assert tel.phase[-1] == "ramp_out"


def test_one_percent_drops_do_not_stop_the_gait(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    rig.vbus.faults = FaultPlan(drop_probability=0.01, seed=7)
    result, player = rig.play(replace(CONFIG, cycles=6))
    assert result.stop.reason is StopReason.COMPLETED, result.stop
    assert rig.bus.stats.no_response > 10  # replies really were lost (and retried)
    assert_wire_safe(rig, player.gate.max_step_ticks)
    assert torque_all_off(rig)
    assert rig.telemetry().stop_reason == "completed"


def test_hold_keeps_torque_after_a_completed_run(tmp_path: Path) -> None:
    from hardware.play.player import OnStop

    rig = make_rig(tmp_path)
    result, _ = rig.play(replace(CONFIG, cycles=1, on_stop=OnStop.HOLD))
    assert result.stop.reason is StopReason.COMPLETED
    assert all(s.torque_enabled for s in rig.vbus.servos)


def test_hold_applies_after_a_fault_stop_too(tmp_path: Path) -> None:
    """`--on-stop hold`: once the rest pose is reached, torque stays on whatever the reason."""
    from hardware.play.player import OnStop

    rig = make_rig(tmp_path)

    def on_tick(tick: int, t_s: float) -> None:
        if tick == 120:
            rig.vbus.vanish(2)

    result, _ = rig.play(replace(CONFIG, on_stop=OnStop.HOLD), on_tick)
    assert result.stop.reason is StopReason.NO_RESPONSE
    assert all(s.torque_enabled for s in rig.vbus.servos)  # rest pose reached cleanly: hold


STATUS_EVERY = CONFIG.limits.status_every_ticks


def _lose_status_reads(rig: Rig, status_ticks: set[int]) -> Callable[[int, float], None]:
    """on_tick hook: the status reads of the ticks in `status_ticks` get no reply (on the wire:
    the virtual bus drops the replies to reads of the status registers; position reads pass)."""
    lossy = replace(rig.vbus.faults, drop_reads_of=frozenset({"present_temperature"}))
    clean = rig.vbus.faults

    def on_tick(tick: int, t_s: float) -> None:
        want = lossy if tick + 1 in status_ticks else clean  # set up before the next tick
        if rig.vbus.faults is not want:
            rig.vbus.faults = want

    return on_tick


def test_status_reads_lost_for_good_stop_safely_with_the_servos_named(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    first = 10 * STATUS_EVERY  # mid-gait
    lost = {first + k * STATUS_EVERY for k in range(100)}
    result, player = rig.play(CONFIG, _lose_status_reads(rig, lost))
    stop = result.stop
    assert stop.reason is StopReason.STATUS_LOST and result.exit_code == 8, stop
    assert stop.tick == first + 2 * STATUS_EVERY  # the 3rd failed status read in a row
    assert result.status_misses == 3 and result.misses == 0  # position reads all went through
    assert stop.servo_id == 1
    assert "servo 1 (fl_hip_roll): 3 consecutive failed status reads" in stop.message, stop
    assert "unknown for 30 ticks" in stop.message
    assert result.ticks_by_phase["ramp_out"] > 0 and result.safe_at_s - stop.t_s <= 1.0
    assert_wire_safe(rig, player.gate.max_step_ticks)
    assert torque_all_off(rig)
    tel = rig.telemetry()
    assert len(tel.tick) == result.ticks == len(rig.wire.goal_matrix(rig.ids))
    assert list(tel.tick) == list(range(result.ticks))
    assert tel.stop_reason == "status_lost" and tel.stop_message == stop.message


@pytest.mark.parametrize(
    "lost_k",
    [(10,), (10, 11), (10, 11, 13, 14), (10, 12, 14, 16, 18)],
    ids=["once", "twice", "twice-recover-twice", "every-other"],
)
def test_a_few_lost_status_reads_do_not_stop_the_gait(
    tmp_path: Path, lost_k: tuple[int, ...]
) -> None:
    rig = make_rig(tmp_path)
    lost = {k * STATUS_EVERY for k in lost_k}
    result, player = rig.play(CONFIG, _lose_status_reads(rig, lost))
    assert result.stop.reason is StopReason.COMPLETED, result.stop
    assert result.status_misses == len(lost) and result.misses == 0
    assert_wire_safe(rig, player.gate.max_step_ticks)
    assert torque_all_off(rig)
    tel = rig.telemetry()
    assert tel.stop_reason == "completed"
    # the lost status ticks carry no health data in the CSV; the status ticks around them do
    with rig.telemetry_path.open(newline="", encoding="utf-8") as fh:
        temps = [row[f"{rig.robot.joint_names[0]}_temperature_c"] for row in csv.DictReader(fh)]
    for k in sorted(lost):
        assert temps[k] == "", k
    assert temps[(lost_k[0] - 1) * STATUS_EVERY] != ""
    assert temps[(lost_k[-1] + 1) * STATUS_EVERY] != ""

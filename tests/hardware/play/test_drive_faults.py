"""Faults injected mid-drive on the virtual bus end in the same safe stop as `run`.

For every fault the same injection is made into a drive (walking, mid-command-stream) and into
a `run` of a gait: same stop reason and exit code, the ramp to rest in both when the bus still
works (none after a lost adapter), every goal inside the joint limits and the step budget (from
the goals the virtual bus decoded), torque off at the end (after a lost adapter: every servo
reported unconfirmed), telemetry complete with the stop row.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

from hardware.play.fault_spec import FaultSchedule, parse_fault
from hardware.play.player import PlayerConfig, PlayResult
from hardware.play.watchdog import StopReason
from tests.hardware.play.drive_rig import drive_rig, repeated, run_drive, script_lines
from tests.hardware.play.player_rig import Rig, assert_wire_safe, make_rig, torque_all_off

T_FAULT_S = 2.5  # run time: past the ramp-in and the stand → walk entry, walking


@dataclass(frozen=True)
class Fault:
    inject: Callable[[Rig], None]
    reason: StopReason


def _spec(text: str) -> Callable[[Rig], None]:
    def inject(rig: Rig) -> None:
        schedule = FaultSchedule([parse_fault(text, rig.ids)])
        schedule.attach(rig.vbus)
        schedule.attach_port(rig.bus)

    return inject


def _kill(signum: int) -> Callable[[Rig], None]:
    return lambda rig: os.kill(os.getpid(), signum)


def _vanish(sid: int) -> Callable[[Rig], None]:
    def inject(rig: Rig) -> None:
        rig.vbus.vanish(sid)

    return inject


FAULTS = {
    "drop": Fault(_spec("drop=0.3"), StopReason.NO_RESPONSE),
    "vanish": Fault(_vanish(5), StopReason.NO_RESPONSE),
    "overload": Fault(_spec("overload=3"), StopReason.SERVO_FAULT),
    "overheat": Fault(_spec("overheat=8"), StopReason.OVER_TEMPERATURE),
    "sag": Fault(_spec("sag=1.6"), StopReason.LOW_VOLTAGE),
    "status-lost": Fault(_spec("status-lost"), StopReason.STATUS_LOST),
    "late-replies": Fault(_spec("delay=0.01"), StopReason.NO_RESPONSE),
    "unplug": Fault(_spec("unplug"), StopReason.ADAPTER_LOST),
    "sigint": Fault(_kill(signal.SIGINT), StopReason.SIGINT),
    "sigterm": Fault(_kill(signal.SIGTERM), StopReason.SIGTERM),
}


def _hook(rig: Rig, fault: Fault, at: list[float]) -> Callable[[int, float], None]:
    def on_tick(tick: int, t_s: float) -> None:
        if not at and t_s >= T_FAULT_S:
            at.append(t_s)
            fault.inject(rig)

    return on_tick


def _assert_safe(rig: Rig, result: PlayResult, max_step: np.ndarray, reason: StopReason) -> None:
    assert_wire_safe(rig, max_step)
    if reason is StopReason.ADAPTER_LOST:  # nothing reaches the servos: reported, every one
        assert result.torque_off_failures == tuple(rig.ids)
    else:
        assert torque_all_off(rig)  # (lost replies may leave a confirmation missing)
    tel = rig.telemetry()
    assert tel.stop_reason == reason.value
    assert len(tel.tick) == result.ticks


@pytest.mark.parametrize("name", sorted(FAULTS))
def test_a_fault_mid_drive_ends_in_the_same_safe_stop_as_run(tmp_path: Path, name: str) -> None:
    fault = FAULTS[name]
    rig, lib = drive_rig(tmp_path / "drive")
    at: list[float] = []
    cmds = [*repeated(0.0, 8.0, 0.2, vx=0.15, yaw_rate=0.3), {"t": 8.0, "end": True}]
    drive, driver = run_drive(rig, lib, script_lines(cmds), on_tick=_hook(rig, fault, at))
    d = drive.play
    assert at and d.stop.reason is fault.reason, d.stop
    assert d.ticks_by_phase["drive"] > 50  # it was walking when the fault came
    _assert_safe(rig, d, driver.gate.max_step_ticks, fault.reason)

    run_rig = make_rig(tmp_path / "run")
    run_at: list[float] = []
    config = PlayerConfig(cycles=None, ramp_s=0.5, force=True)
    r, player = run_rig.play(config, _hook(run_rig, fault, run_at))
    assert r.stop.reason is d.stop.reason and r.exit_code == drive.exit_code == d.exit_code
    _assert_safe(run_rig, r, player.gate.max_step_ticks, fault.reason)

    ramped = "ramp_out" in d.ticks_by_phase
    assert ramped == ("ramp_out" in r.ticks_by_phase)
    assert ramped == (fault.reason is not StopReason.ADAPTER_LOST)
    if ramped:  # at rest within a second of the fault, as `run`
        assert d.safe_at_s - at[0] <= 1.0 and r.safe_at_s - run_at[0] <= 1.0


def test_a_second_signal_skips_the_rest_ramp_of_a_drive_never_the_torque_off(
    tmp_path: Path,
) -> None:
    rig, lib = drive_rig(tmp_path)
    cmds = [*repeated(0.0, 8.0, 0.2, vx=0.2), {"t": 8.0, "end": True}]
    sent: list[int] = []

    def on_tick(tick: int, t_s: float) -> None:
        if t_s >= T_FAULT_S and len(sent) < 2:
            if not sent or tick >= sent[0] + 3:  # a storm's second signal, mid stop ramp
                sent.append(tick)
                os.kill(os.getpid(), signal.SIGINT)

    drive, driver = run_drive(
        rig, lib, script_lines(cmds), config=replace(PlayerConfig(cycles=None), stop_ramp_s=2.0),
        on_tick=on_tick,
    )  # fmt: skip
    assert drive.play.stop.reason is StopReason.SIGINT and drive.play.signals == 2
    assert 0 < drive.play.ticks_by_phase["ramp_out"] < 200  # cut short (≥ 2 s ramp = 200 ticks)
    assert torque_all_off(rig)
    assert_wire_safe(rig, driver.gate.max_step_ticks)


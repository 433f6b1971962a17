"""The safe-stop contract under signals and a vanishing adapter, on the real CLI in a subprocess.

The player (`python -m hardware.cli run --port /dev/pts/N`) plays on a virtual quad12 served by
this process (`tests.hardware.player_process`), so the servos outlive the player: "no servo
left torqued" is read from the virtual servos' Torque Enable registers after the process ended.
Each run also checks: the exit code of the first stop reason, the telemetry stop row naming it,
no traceback. Figures (stop latency: stop requested → torque-off sent, from the stop row) are
printed; `pytest -s` shows them.
"""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest

from hardware.bus.virtual import FaultPlan
from tests.hardware.player_process import (
    EXIT_FOR_SIGNAL,
    REASON_FOR_SIGNAL,
    Outcome,
    PlayerProcess,
)

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)


def _latency(o: Outcome) -> float:
    t = o.telemetry
    return float("nan") if t is None else t.stop_done_s - t.stop_requested_s


def _report(label: str, o: Outcome) -> None:
    print(
        f"[suite] {label}: exit {o.code}, signals {o.signals_sent}, torqued {o.torqued}, "
        f"stop {o.telemetry.stop_reason if o.telemetry else None}, "
        f"stop latency {_latency(o) * 1e3:.0f} ms, exit {(o.exited_s - o.first_signal_s):.2f} s "
        "after the first signal"
    )


def _assert_safe_stop(o: Outcome, reason: str, code: int) -> None:
    assert "Traceback" not in o.stderr and "Traceback" not in o.stdout, o.stderr[-2000:]
    assert o.torqued == [], (o.torqued, o.stderr[-2000:])
    assert o.code == code, (o.code, o.stdout[-1000:], o.stderr[-2000:])
    assert o.telemetry is not None and o.telemetry.stop_reason == reason, o.stdout[-1000:]


@pytest.mark.parametrize("signum", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_every_stop_signal_ramps_to_rest_then_torques_off(tmp_path: Path, signum: int) -> None:
    p = PlayerProcess(tmp_path, "--cycles", "0").start()
    assert p.wait_phase("gait"), p.finish().stderr
    time.sleep(0.2)
    assert p.signal(signum)
    o = p.finish()
    _report(f"one {signal.Signals(signum).name} mid-gait", o)
    _assert_safe_stop(o, REASON_FOR_SIGNAL[signum], EXIT_FOR_SIGNAL[signum])
    assert o.telemetry is not None and o.telemetry.phase[-1] == "ramp_out"  # the ramp to rest ran
    assert f"stopped: {REASON_FOR_SIGNAL[signum]}" in o.stdout


PHASES = ("start-up", "ramp-in", "gait", "stop-ramp", "torque-off")


@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_storm_at_every_phase_never_leaves_a_servo_torqued(
    tmp_path: Path, phase: str, signum: int
) -> None:
    """300 signals 2 ms apart. The stop reason is the first one: the signal itself, except in
    the torque-off storm, where a watchdog stop (every reply lost) came first."""
    extra = ("--cycles", "0")
    p = PlayerProcess(tmp_path, *extra)
    reason, code = REASON_FOR_SIGNAL[signum], EXIT_FOR_SIGNAL[signum]
    if phase == "start-up":  # the CLI has latched the signals and is still loading
        p.start()
        assert p.wait_for(lambda: p.catches(signal.SIGHUP), 10.0), p.finish().stderr
    elif phase == "ramp-in":
        p.start()
        assert p.wait_phase("ramp_in"), p.finish().stderr
    elif phase == "gait":
        p.start()
        assert p.wait_phase("gait"), p.finish().stderr
    elif phase == "stop-ramp":
        # completes, then ramps to rest (--end-at-rest) with no signal
        p = PlayerProcess(tmp_path, "--cycles", "0.5", "--end-at-rest")
        p.start()
        assert p.wait_phase("ramp_out"), p.finish().stderr
        reason, code = "completed", 0
    else:  # torque-off: every reply lost → watchdog stop, ramp, then slow acknowledged writes
        p.start()
        assert p.wait_phase("gait"), p.finish().stderr
        p.vbus.faults = FaultPlan(drop_probability=1.0)
        # the broadcast torque-off (no reply needed) has reached the servos; the per-servo
        # confirmations now time out one by one (12 × 2 attempts × 50 ms)
        assert p.wait_for(lambda: not any(s.torque_enabled for s in p.vbus.servos))
        reason, code = "no_response", 3
    sent = p.storm(signum)
    o = p.finish()
    _report(f"{signal.Signals(signum).name} storm at {phase}", o)
    assert sent >= 2, "the storm did not reach the player"
    _assert_safe_stop(o, reason, code)


def test_a_signal_at_spawn_leaves_nothing_torqued(tmp_path: Path) -> None:
    """Signals from the first instant: before the CLI has loaded (a few tenths of a second)
    the default action ends the process — nothing has been sent to a servo then; from the
    latch on, the signal is the player's stop request."""
    p = PlayerProcess(tmp_path, "--cycles", "0").start()
    p.storm(signal.SIGTERM)
    o = p.finish()
    _report("SIGTERM storm from spawn", o)
    assert o.torqued == []
    if o.code == -signal.SIGTERM:  # killed while Python started, before any servo was touched
        assert o.telemetry is None
    else:
        _assert_safe_stop(o, "sigterm", 143)


def test_adapter_unplugged_mid_gait_is_one_line_and_a_stop_row(tmp_path: Path) -> None:
    p = PlayerProcess(tmp_path, "--cycles", "0").start()
    assert p.wait_phase("gait"), p.finish().stderr
    time.sleep(0.2)
    t_unplug = time.monotonic()
    p.server.stop()  # the pty master closes: the player's reads and writes fail (EIO)
    out, err = p.proc.communicate(timeout=20) if p.proc else ("", "")
    exited_after_s = time.monotonic() - t_unplug
    print(f"[suite] adapter unplugged mid-gait: exit {p.proc and p.proc.returncode}, "
          f"{exited_after_s:.2f} s after the unplug")  # fmt: skip
    assert p.proc is not None and p.proc.returncode == 9, (out, err)
    assert "Traceback" not in err and "stopped: adapter_lost — serial adapter" in out
    assert "torque-off NOT confirmed" in err  # said so: the servos could not be reached
    assert exited_after_s < 5.0  # bounded: no wait for replies that cannot come
    from hardware.play.telemetry import read_telemetry

    tel = read_telemetry(p.tel_path)
    assert tel.stop_reason == "adapter_lost"

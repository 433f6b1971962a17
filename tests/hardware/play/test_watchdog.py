"""Watchdog budgets, flag classification, health limits and signal handling."""

from __future__ import annotations

import os
import signal

import pytest

import robots
from hardware.bus.servo_bus import ServoStatus
from hardware.errors import CorruptPacket, NoResponse, ServoFault
from hardware.play.watchdog import (
    EXIT_CODES,
    StopReason,
    Watchdog,
    WatchdogLimits,
    reason_for_flags,
    stop_on_signals,
)


def _dog(**kw: int) -> Watchdog:
    robot = robots.load("quad12")
    return Watchdog(
        WatchdogLimits(**kw),  # type: ignore[arg-type]
        {j.bus_id: j.servo for j in robot.joints},
        {j.bus_id: j.name for j in robot.joints},
    )


def _status(
    sid: int, volts: float = 7.4, temp: float = 30.0, flags: tuple[str, ...] = ()
) -> ServoStatus:
    return ServoStatus(sid, 0.0, volts, temp, flags, 1 if flags else 0)


def test_consecutive_miss_budget() -> None:
    dog = _dog(max_consecutive_misses=3)
    miss = NoResponse(4)
    for tick in range(3):
        assert dog.read_missed(miss, tick, tick * 0.01) is None
    stop = dog.read_missed(miss, 3, 0.03)
    assert stop is not None and stop.reason is StopReason.NO_RESPONSE
    assert "servo 4 (fr_hip_roll)" in stop.message and "4 consecutive" in stop.message
    assert stop.servo_id == 4


def test_windowed_miss_budget_and_recovery() -> None:
    dog = _dog(max_consecutive_misses=3, window_ticks=50, max_misses_in_window=5)
    miss = NoResponse(1)
    tick = 0
    for _ in range(5):  # 5 isolated misses in 50 ticks: within budget
        assert dog.read_missed(miss, tick, 0.0) is None
        for _ in range(9):
            tick += 1
            dog.read_ok()
        tick += 1
    assert dog.stop is None
    for _ in range(45):  # the old misses leave the window
        dog.read_ok()
    for _ in range(5):
        assert dog.read_missed(miss, tick, 0.0) is None
        dog.read_ok()
    stop = dog.read_missed(miss, tick, 0.0)
    assert stop is not None and "6 missed reads in the last 50 ticks" in stop.message


def test_first_stop_wins_and_a_second_signal_is_urgent() -> None:
    dog = _dog()
    dog.fault(ServoFault(3, ("overload",)), 10, 0.1)
    dog.request(StopReason.SIGINT, "ctrl-c", 11, 0.11)
    assert dog.stop is not None and dog.stop.reason is StopReason.SERVO_FAULT
    assert dog.urgent


@pytest.mark.parametrize(
    ("flags", "reason"),
    [
        (("overheat",), StopReason.OVER_TEMPERATURE),
        (("overheating", "overload"), StopReason.OVER_TEMPERATURE),
        (("input_voltage",), StopReason.LOW_VOLTAGE),
        (("voltage",), StopReason.LOW_VOLTAGE),
        (("overload",), StopReason.SERVO_FAULT),
        (("alert",), StopReason.SERVO_FAULT),
    ],
)
def test_flag_classification(flags: tuple[str, ...], reason: StopReason) -> None:
    assert reason_for_flags(flags) is reason


def test_status_limits() -> None:
    dog = _dog()
    assert dog.status({1: _status(1), 2: _status(2)}, 0, 0.0) is None
    hot = _dog().status({5: _status(5, temp=66.0)}, 1, 0.01)  # STS3215 max 70 °C, margin 5
    assert hot is not None and hot.reason is StopReason.OVER_TEMPERATURE
    assert "servo 5 (fr_hip_pitch): temperature 66" in hot.message
    low = _dog().status({7: _status(7, volts=5.9)}, 1, 0.01)
    assert low is not None and low.reason is StopReason.LOW_VOLTAGE and "5.9 V" in low.message
    flagged = _dog().status({9: _status(9, flags=("overload",))}, 1, 0.01)
    assert flagged is not None and flagged.reason is StopReason.SERVO_FAULT


def test_exit_codes_are_distinct_and_completed_is_zero() -> None:
    assert EXIT_CODES[StopReason.COMPLETED] == 0
    assert len(set(EXIT_CODES.values())) == len(StopReason)
    assert StopReason.SIGINT.exit_code == 130 and StopReason.SIGTERM.exit_code == 143


@pytest.mark.parametrize(
    ("signum", "reason"),
    [
        (signal.SIGINT, StopReason.SIGINT),
        (signal.SIGTERM, StopReason.SIGTERM),
        (signal.SIGHUP, StopReason.SIGHUP),
        (signal.SIGQUIT, StopReason.SIGQUIT),
    ],
)
def test_signals_become_stop_requests_and_handlers_are_restored(
    signum: int, reason: StopReason
) -> None:
    dog = _dog()
    before = signal.getsignal(signum)
    with stop_on_signals(dog, lambda: (42, 0.42)):
        os.kill(os.getpid(), signum)
        assert dog.stop is not None and dog.stop.reason is reason and dog.stop.tick == 42
        os.kill(os.getpid(), signum)  # a second signal: skip the ramp to rest
        assert dog.urgent
    assert signal.getsignal(signum) is before


def test_status_read_budget_stops_at_the_limit_and_names_the_servos() -> None:
    dog = _dog(max_consecutive_status_misses=3, status_every_ticks=10)
    assert dog.status_missed(NoResponse(4), 10, 0.1) is None
    assert dog.status_missed(CorruptPacket("bad CRC", None), 20, 0.2) is None
    stop = dog.status_missed(NoResponse(4), 30, 0.3)
    assert stop is not None and stop.reason is StopReason.STATUS_LOST and stop.tick == 30
    assert stop.message.startswith("servo 4 (fr_hip_roll), bus: 3 consecutive failed status reads")
    assert "unknown for 30 ticks" in stop.message and stop.servo_id == 4
    assert StopReason.STATUS_LOST.exit_code == 8
    assert dog.consecutive_misses == 0 and dog.misses == 0  # not a missed position read


def test_a_status_read_that_arrives_resets_the_count() -> None:
    dog = _dog(max_consecutive_status_misses=3)
    for tick in range(0, 200, 30):
        assert dog.status_missed(NoResponse(1), tick, 0.0) is None
        assert dog.status_missed(NoResponse(2), tick + 10, 0.0) is None
        assert dog.status({1: _status(1)}, tick + 20, 0.0) is None
    assert dog.stop is None and dog.status_misses == 14
    stop = _dog(max_consecutive_status_misses=1).status_missed(NoResponse(2), 0, 0.0)
    assert stop is not None and stop.reason is StopReason.STATUS_LOST


def test_status_budget_must_be_at_least_one() -> None:
    with pytest.raises(ValueError, match="max_consecutive_status_misses"):
        WatchdogLimits(max_consecutive_status_misses=0)


def test_exit_codes_of_the_new_stop_reasons() -> None:
    assert StopReason.SIGHUP.exit_code == 129 and StopReason.SIGQUIT.exit_code == 131
    assert StopReason.ADAPTER_LOST.exit_code == 9


def test_a_signal_storm_keeps_the_first_reason_and_only_escalates() -> None:
    dog = _dog()
    dog.request(StopReason.NO_RESPONSE, "servo 3: 4 consecutive missed reads", 10, 0.1)
    with stop_on_signals(dog, lambda: (11, 0.11)):
        for signum in [signal.SIGTERM, signal.SIGINT, signal.SIGHUP] * 100:
            os.kill(os.getpid(), signum)
    assert dog.stop is not None and dog.stop.reason is StopReason.NO_RESPONSE
    assert dog.urgent and dog.signals == 300


def test_signals_latched_before_the_player_become_its_stop_request() -> None:
    import hardware.play.watchdog as wd

    saved = {s: signal.getsignal(s) for s in wd.STOP_SIGNALS}
    try:
        wd.latch_stop_signals()
        os.kill(os.getpid(), signal.SIGHUP)  # while the CLI loads: remembered, not fatal
        os.kill(os.getpid(), signal.SIGINT)  # no KeyboardInterrupt either
        assert [s for s, _ in wd.latched_signals()] == [signal.SIGHUP, signal.SIGINT]
        dog = _dog()
        with stop_on_signals(dog, lambda: (0, -0.5)):
            assert dog.stop is not None and dog.stop.reason is StopReason.SIGHUP and dog.urgent
        assert wd.latched_signals() == ()
        assert signal.getsignal(signal.SIGTERM) is wd._latch  # back to the latch, not default
    finally:
        for s, h in saved.items():
            signal.signal(s, h)

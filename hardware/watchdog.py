"""Why and when the player stops: `StopReason`, exit codes, and the bus `Watchdog`.

The watchdog is fed once per tick by the player (position read ok / missed / fault, and every
`status_every_ticks` ticks the servos' load, voltage, temperature and error flags) and by the
signal handlers. The first stop request wins; it is kept as a `StopEvent` (reason, one-line
message, tick, time, servo id). Budgets:

- missed position reads: more than `max_consecutive_misses` in a row, or more than
  `max_misses_in_window` among the last `window_ticks` ticks (a sync-read that failed after the
  bus's retries counts as one miss);
- hardware-error flags (`ServoFault` or flags in a status read): overheat → OVER_TEMPERATURE,
  voltage → LOW_VOLTAGE, anything else → SERVO_FAULT;
- temperature ≥ the servo's max_temperature_c − `temperature_margin_c`;
- voltage < the servo's voltage_min_v + `voltage_margin_v`;
- failed status reads (no reply / corrupt after the bus's retries): the
  `max_consecutive_status_misses`-th in a row → STATUS_LOST. Position reads alone keep the gait
  going but say nothing about heat or supply, so a servo whose health cannot be read must not
  run on unwatched; one successful status read resets the count.

Exit codes (`EXIT_CODES`, also the CLI's): 0 completed, 2 refused to start, 3 no response,
4 servo fault, 5 over-temperature, 6 low voltage, 7 bus error, 8 status lost, 9 adapter lost
(the serial adapter itself failed: unplugged, EIO), 129 SIGHUP (the terminal closed),
130 SIGINT (Ctrl-C), 131 SIGQUIT (Ctrl-\\), 143 SIGTERM.

Signals (`stop_on_signals`): SIGINT, SIGTERM, SIGHUP and SIGQUIT all mean the same thing: stop
safely (ramp to rest, then torque off). The first one is the stop reason (unless the run had
already stopped for another reason, which is then kept); every later one only makes the stop
urgent (skip what is left of the ramp to rest, straight to torque off). The handlers never
raise, so no signal, however many and however close together, can cut the torque-off short;
they stay installed until the player has written the torque-off and its telemetry stop row.
"""

from __future__ import annotations

import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from enum import Enum
from types import FrameType

from hardware.bus import ServoStatus
from hardware.errors import BusError, ServoFault
from robots.servo import ServoModel


class StopReason(str, Enum):
    """Why a run ended (the telemetry's last row and the exit code say the same)."""

    COMPLETED = "completed"
    SIGINT = "sigint"
    SIGTERM = "sigterm"
    SIGHUP = "sighup"
    SIGQUIT = "sigquit"
    NO_RESPONSE = "no_response"
    SERVO_FAULT = "servo_fault"
    OVER_TEMPERATURE = "over_temperature"
    LOW_VOLTAGE = "low_voltage"
    BUS_ERROR = "bus_error"
    STATUS_LOST = "status_lost"
    ADAPTER_LOST = "adapter_lost"

    @property
    def exit_code(self) -> int:
        return EXIT_CODES[self]


EXIT_CODES: Mapping[StopReason, int] = {
    StopReason.COMPLETED: 0,
    StopReason.NO_RESPONSE: 3,
    StopReason.SERVO_FAULT: 4,
    StopReason.OVER_TEMPERATURE: 5,
    StopReason.LOW_VOLTAGE: 6,
    StopReason.BUS_ERROR: 7,
    StopReason.STATUS_LOST: 8,
    StopReason.ADAPTER_LOST: 9,
    StopReason.SIGHUP: 129,  # 128 + SIGHUP (1), the shell convention
    StopReason.SIGINT: 130,  # 128 + SIGINT (2)
    StopReason.SIGQUIT: 131,  # 128 + SIGQUIT (3)
    StopReason.SIGTERM: 143,  # 128 + SIGTERM (15)
}
# every signal that would end the process: what it is called in the stop message
STOP_SIGNALS: Mapping[int, tuple[StopReason, str]] = {
    signal.SIGINT: (StopReason.SIGINT, "Ctrl-C (SIGINT)"),
    signal.SIGTERM: (StopReason.SIGTERM, "SIGTERM"),
    signal.SIGHUP: (StopReason.SIGHUP, "SIGHUP (terminal closed)"),
    signal.SIGQUIT: (StopReason.SIGQUIT, "SIGQUIT"),
}
SIGNAL_REASONS = frozenset(r for r, _ in STOP_SIGNALS.values())
EXIT_PREFLIGHT = 2  # refused to start (also used for bad arguments / files)

_OVERHEAT_FLAGS = frozenset({"overheat", "overheating"})
_VOLTAGE_FLAGS = frozenset({"voltage", "input_voltage"})


@dataclass(frozen=True)
class StopEvent:
    """A stop request: reason, one-line message, tick and time [s] it was raised at."""

    reason: StopReason
    message: str
    tick: int
    t_s: float
    servo_id: int | None = None


@dataclass(frozen=True)
class WatchdogLimits:
    """Budgets of the watchdog (see the module docstring)."""

    max_consecutive_misses: int = 3
    window_ticks: int = 50
    max_misses_in_window: int = 5
    temperature_margin_c: float = 5.0
    voltage_margin_v: float = 0.0
    status_every_ticks: int = 10
    # Unlike max_consecutive_misses (misses tolerated), this many failed status reads in a row
    # stop the run: 3 at status_every_ticks = 10 and 100 Hz → health unknown for 0.3 s at most.
    max_consecutive_status_misses: int = 3

    def __post_init__(self) -> None:
        if self.max_consecutive_misses < 1 or self.max_misses_in_window < 1:
            raise ValueError("miss budgets must be >= 1")
        if self.max_consecutive_status_misses < 1:
            raise ValueError("max_consecutive_status_misses must be >= 1")
        if self.window_ticks < self.max_misses_in_window:
            raise ValueError("window_ticks must be >= max_misses_in_window")
        if self.status_every_ticks < 1:
            raise ValueError("status_every_ticks must be >= 1")


def reason_for_flags(flags: tuple[str, ...]) -> StopReason:
    if _OVERHEAT_FLAGS.intersection(flags):
        return StopReason.OVER_TEMPERATURE
    if _VOLTAGE_FLAGS.intersection(flags):
        return StopReason.LOW_VOLTAGE
    return StopReason.SERVO_FAULT


class Watchdog:
    """Counts misses, checks health, and holds the first stop request."""

    def __init__(
        self, limits: WatchdogLimits, servos: Mapping[int, ServoModel], joint_of: Mapping[int, str]
    ) -> None:
        self.limits = limits
        self.servos = dict(servos)
        self.joint_of = dict(joint_of)
        self._window: deque[bool] = deque(maxlen=limits.window_ticks)
        self._lock = threading.Lock()
        self.consecutive_misses = 0
        self.max_consecutive_misses = 0
        self.misses = 0
        self.consecutive_status_misses = 0
        self.status_misses = 0
        self._status_missed_by: list[int | None] = []  # servo ids blamed in the current streak
        self.stop: StopEvent | None = None
        self.urgent = False  # a later signal: skip the ramp to rest
        self.signals = 0  # stop signals received

    def _who(self, servo_id: int | None) -> str:
        if servo_id is None or servo_id < 0:
            return "bus"
        joint = self.joint_of.get(servo_id)
        return f"servo {servo_id} ({joint})" if joint else f"servo {servo_id}"

    def request(
        self, reason: StopReason, message: str, tick: int, t_s: float, servo_id: int | None = None
    ) -> StopEvent:
        """Record a stop request (the first one wins); returns the one in force."""
        with self._lock:
            if self.stop is None:
                self.stop = StopEvent(reason, message, tick, t_s, servo_id)
            elif reason in SIGNAL_REASONS:
                self.urgent = True
            return self.stop

    def on_signal(self, signum: int, tick: int, t_s: float) -> None:
        """A stop signal (called from the signal handler: takes no lock, never raises). The
        first stop request is kept; a signal after it makes the stop urgent."""
        reason, name = STOP_SIGNALS[signum]
        self.signals += 1
        if self.stop is None:
            self.stop = StopEvent(reason, f"{name} received: stopping safely", tick, t_s)
        else:
            self.urgent = True

    # -- per-tick feeds ---------------------------------------------------------------------
    def read_ok(self) -> None:
        self.consecutive_misses = 0
        self._window.append(False)

    def read_missed(self, error: BusError, tick: int, t_s: float) -> StopEvent | None:
        self.misses += 1
        self.consecutive_misses += 1
        self.max_consecutive_misses = max(self.max_consecutive_misses, self.consecutive_misses)
        self._window.append(True)
        lim = self.limits
        in_window = sum(self._window)
        servo_id = getattr(error, "servo_id", None)
        if self.consecutive_misses > lim.max_consecutive_misses:
            why = (
                f"{self.consecutive_misses} consecutive missed reads "
                f"(budget {lim.max_consecutive_misses})"
            )
        elif in_window > lim.max_misses_in_window:
            why = (
                f"{in_window} missed reads in the last {len(self._window)} ticks "
                f"(budget {lim.max_misses_in_window})"
            )
        else:
            return None
        return self.request(
            StopReason.NO_RESPONSE,
            f"{self._who(servo_id)}: {why}; last: {error}",
            tick,
            t_s,
            servo_id,
        )

    def fault(self, fault: ServoFault, tick: int, t_s: float) -> StopEvent:
        self._window.append(False)
        self.consecutive_misses = 0
        reason = reason_for_flags(fault.flags)
        flags = ", ".join(fault.flags) or f"raw 0x{fault.raw:02X}"
        return self.request(
            reason,
            f"{self._who(fault.servo_id)}: hardware error flags: {flags}",
            tick,
            t_s,
            fault.servo_id,
        )

    def status_missed(self, error: BusError, tick: int, t_s: float) -> StopEvent | None:
        """A status read failed (after the bus's retries); returns the stop it raised, if any.

        Not a missed position read: the gait can go on, but only while the servos' temperature,
        voltage and error flags stay known; the `max_consecutive_status_misses`-th failure in a
        row stops the run (STATUS_LOST), naming the servo(s) that did not answer."""
        self.status_misses += 1
        self.consecutive_status_misses += 1
        servo_id = getattr(error, "servo_id", None)
        if servo_id not in self._status_missed_by:
            self._status_missed_by.append(servo_id)
        lim = self.limits
        n = self.consecutive_status_misses
        if n < lim.max_consecutive_status_misses:
            return None
        who = ", ".join(self._who(s) for s in self._status_missed_by)
        return self.request(
            StopReason.STATUS_LOST,
            f"{who}: {n} consecutive failed status reads (limit "
            f"{lim.max_consecutive_status_misses}): temperature, voltage and error flags unknown "
            f"for {n * lim.status_every_ticks} ticks; last: {error}",
            tick,
            t_s,
            servo_id,
        )

    def status(
        self, statuses: Mapping[int, ServoStatus], tick: int, t_s: float
    ) -> StopEvent | None:
        """Check one status read of every servo; returns the stop it raised, if any.
        A status read that arrived resets the failed-status-read count."""
        self.consecutive_status_misses = 0
        self._status_missed_by.clear()
        lim = self.limits
        for sid, st in statuses.items():
            model = self.servos.get(sid)
            who = self._who(sid)
            if st.error_flags:
                flags = ", ".join(st.error_flags)
                return self.request(
                    reason_for_flags(st.error_flags),
                    f"{who}: hardware error flags: {flags}",
                    tick,
                    t_s,
                    sid,
                )
            if model is None:
                continue
            t_max = model.max_temperature_c - lim.temperature_margin_c
            if st.temperature_c >= t_max:
                return self.request(
                    StopReason.OVER_TEMPERATURE,
                    f"{who}: temperature {st.temperature_c:.0f} °C ≥ limit {t_max:.0f} °C",
                    tick,
                    t_s,
                    sid,
                )
            v_min = model.voltage_min_v + lim.voltage_margin_v
            if st.voltage_v < v_min:
                return self.request(
                    StopReason.LOW_VOLTAGE,
                    f"{who}: voltage {st.voltage_v:.1f} V < minimum {v_min:.1f} V",
                    tick,
                    t_s,
                    sid,
                )
        return None


_early_signals: list[tuple[int, float]] = []  # (signum, monotonic time) before a player ran


def _latch(signum: int, frame: FrameType | None) -> None:
    _early_signals.append((signum, time.monotonic()))


def latch_stop_signals() -> None:
    """Catch the stop signals process-wide from now on (the CLI calls this first thing): a
    signal that arrives while the CLI loads or the player is not running is remembered, and
    the next `stop_on_signals` starts with it as its stop request, instead of the signal
    killing the process half-way (or, for SIGINT, a KeyboardInterrupt traceback)."""
    if threading.current_thread() is not threading.main_thread():
        return
    for s in STOP_SIGNALS:
        signal.signal(s, _latch)


def latched_signals() -> tuple[tuple[int, float], ...]:
    """Signals caught by `latch_stop_signals` and not yet handed to a player."""
    return tuple(_early_signals)


@contextmanager
def stop_on_signals(watchdog: Watchdog, where: Callable[[], tuple[int, float]]) -> Iterator[None]:
    """SIGINT / SIGTERM / SIGHUP / SIGQUIT → `watchdog.on_signal` (see the module docstring).
    Signals latched before (`latch_stop_signals`) are handed over on entry. Restores the
    previous handlers on exit: callers keep the block open until torque is off. A no-op
    outside the main thread (signals cannot be caught there)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        tick, t_s = where()
        watchdog.on_signal(signum, tick, t_s)

    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    while _early_signals:
        handler(_early_signals.pop(0)[0], None)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)

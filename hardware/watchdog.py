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
4 servo fault, 5 over-temperature, 6 low voltage, 7 bus error, 8 status lost, 130 SIGINT,
143 SIGTERM.
"""

from __future__ import annotations

import signal
import threading
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
    NO_RESPONSE = "no_response"
    SERVO_FAULT = "servo_fault"
    OVER_TEMPERATURE = "over_temperature"
    LOW_VOLTAGE = "low_voltage"
    BUS_ERROR = "bus_error"
    STATUS_LOST = "status_lost"

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
    StopReason.SIGINT: 130,  # 128 + SIGINT, the shell convention
    StopReason.SIGTERM: 143,  # 128 + SIGTERM
}
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
        self.urgent = False  # a second signal: skip the ramp to rest

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
            elif reason in (StopReason.SIGINT, StopReason.SIGTERM):
                self.urgent = True
            return self.stop

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


@contextmanager
def stop_on_signals(watchdog: Watchdog, where: Callable[[], tuple[int, float]]) -> Iterator[None]:
    """SIGINT / SIGTERM → a stop request (a second one makes the stop urgent). Restores the
    previous handlers on exit; a no-op outside the main thread (signals cannot be caught there)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        tick, t_s = where()
        reason = StopReason.SIGINT if signum == signal.SIGINT else StopReason.SIGTERM
        name = "Ctrl-C (SIGINT)" if signum == signal.SIGINT else "SIGTERM"
        watchdog.request(reason, f"{name} received: stopping safely", tick, t_s)

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)

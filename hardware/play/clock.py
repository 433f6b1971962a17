"""Clocks for the player's fixed-rate loop: real (monotonic, hybrid sleep) or virtual.

The loop only needs `now_s()` and `sleep_until(t_s)`. `MonotonicClock` sleeps with the OS timer
until `spin_s` before the deadline and then spins, which keeps wake-up jitter in the tens of
microseconds on an idle Linux box. `VirtualClock` jumps straight to each deadline, so tests run
as fast as the CPU allows and are deterministic; pass the same object as `VirtualServoBus`'s
`clock` so the emulated servos move in the same (virtual) time.
"""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    """What the player's loop needs from a clock (seconds, monotonic)."""

    def now_s(self) -> float: ...

    def sleep_until(self, t_s: float) -> None: ...


class MonotonicClock:
    """Real time from `time.perf_counter` (monotonic)."""

    def __init__(self, spin_s: float = 0.0008) -> None:
        if spin_s < 0:
            raise ValueError("spin_s must be >= 0")
        self.spin_s = spin_s

    def now_s(self) -> float:
        return time.perf_counter()

    def __call__(self) -> float:
        return time.perf_counter()

    def sleep_until(self, t_s: float) -> None:
        while True:
            remaining = t_s - time.perf_counter()
            if remaining <= 0.0:
                return
            if remaining > self.spin_s:
                time.sleep(remaining - self.spin_s)


class VirtualClock:
    """A clock that only moves when told: `sleep_until` jumps to the deadline (never back)."""

    def __init__(self, start_s: float = 0.0) -> None:
        self._t = float(start_s)

    def now_s(self) -> float:
        return self._t

    def __call__(self) -> float:
        return self._t

    def sleep_until(self, t_s: float) -> None:
        self._t = max(self._t, float(t_s))

    def advance(self, dt_s: float) -> None:
        if dt_s < 0:
            raise ValueError("a clock never runs backwards")
        self._t += dt_s

"""`SafetyGate`: the one object through which the player writes goal positions.

Every command path — ramp-in, gait streaming, ramp to rest — hands the gate a joint-space target
[rad]; the gate

1. clips it to the joint limits, expressed in whole ticks *inside* the limits
   (so the ticks on the wire decode to angles within [lower_rad, upper_rad]);
2. clips the change from the previously sent goal to the joint's step budget, a token bucket
   refilled by s = ω_allowed · ticks_per_rad / rate ticks per tick (ω_allowed = margin · the
   servo's no-load speed) that carries at most one unused tick over: a single step is at most
   ⌊s + 1⌋ ticks (`max_step_ticks`) and any n consecutive steps move at most n·s + 1 ticks, so
   the speed enforced equals ω_allowed to within one tick at every rate
   (`enforced_speed_rad_s`). Flooring s to whole ticks instead would enforce
   ⌊s⌋/s of ω_allowed: 0.72 of it for an STS3215 at 1000 Hz (s = 2.76), which pre-flight
   would not know about;
3. converts to ticks through the calibration and sync-writes them (unless dry-run).

Limits are applied before the step clip: if the robot starts (within the pre-flight tolerance)
outside a limit, the goal walks back inside at the step limit instead of jumping.
The gate must be `seed`ed with the present pose before its first command.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from hardware.calibration import Calibration

GoalSink = Callable[[Mapping[int, int]], None]
CARRY_TICKS = 1.0  # unused step budget carried to the next tick, at most [ticks]


@dataclass(frozen=True)
class JointGate:
    """Per-joint limits of the gate, in ticks (inclusive) and ticks per tick."""

    name: str
    bus_id: int
    lo_tick: int
    hi_tick: int
    max_step_ticks: int  # ⌊s + 1⌋: the largest single step (see the module docstring)
    step_ticks: float  # s: the budget refill per tick


@dataclass(frozen=True, eq=False)
class GateCommand:
    """What the gate made of one requested target."""

    requested_rad: np.ndarray  # (J,) what the caller asked for
    target_rad: np.ndarray  # (J,) the angle the sent ticks stand for
    target_ticks: tuple[int, ...]  # (J,) sent (joint order)
    limit_clipped: int  # joints clipped to a joint limit
    step_clipped: int  # joints clipped to the step limit


class SafetyGate:
    """Limits + step limiter + rad→tick conversion + the only goal-position writer."""

    def __init__(
        self,
        calibration: Calibration,
        max_speed_rad_s: Sequence[float] | np.ndarray,
        rate_hz: float,
        sink: GoalSink | None,
    ) -> None:
        if not rate_hz > 0:
            raise ValueError("rate_hz must be positive")
        speeds = np.broadcast_to(np.asarray(max_speed_rad_s, float), (len(calibration.joints),))
        if np.any(speeds <= 0):
            raise ValueError("max_speed_rad_s must be positive")
        self.calibration = calibration
        self.rate_hz = float(rate_hz)
        self._sink = sink
        joints = []
        for j, w in zip(calibration.joints, speeds, strict=True):
            a = j.zero_offset_ticks + j.direction * j.lower_rad * j.ticks_per_rad
            b = j.zero_offset_ticks + j.direction * j.upper_rad * j.ticks_per_rad
            lo = max(math.ceil(min(a, b) - 1e-9), j.min_tick)
            hi = min(math.floor(max(a, b) + 1e-9), j.max_tick)
            if lo > hi:
                raise ValueError(f"joint {j.name!r}: limits map to no valid tick")
            s = float(w) * j.ticks_per_rad / self.rate_hz
            joints.append(JointGate(j.name, j.bus_id, lo, hi, math.floor(s + CARRY_TICKS), s))
        self.joints = tuple(joints)
        self._ids = [j.bus_id for j in calibration.joints]
        self._zero = np.array([j.zero_offset_ticks for j in calibration.joints], float)
        self._scale = np.array([j.direction * j.ticks_per_rad for j in calibration.joints], float)
        self._lo = np.array([g.lo_tick for g in joints], float)
        self._hi = np.array([g.hi_tick for g in joints], float)
        self._step = np.array([g.step_ticks for g in joints], float)
        self._budget = self._step.copy()
        self._last: np.ndarray | None = None
        self.commands = 0

    @property
    def max_step_ticks(self) -> np.ndarray:
        """The largest single step [ticks] per joint (⌊s + 1⌋)."""
        return np.array([g.max_step_ticks for g in self.joints], int)

    @property
    def step_ticks(self) -> np.ndarray:
        """The step budget refilled per tick [ticks] per joint (s, fractional)."""
        return self._step.copy()

    @property
    def enforced_speed_rad_s(self) -> np.ndarray:
        """The joint speed the step limit enforces [rad/s] (= the allowed speed: no flooring);
        pre-flight judges the gait against this."""
        return np.asarray(self._step * self.rate_hz / np.abs(self._scale))

    @property
    def seeded(self) -> bool:
        return self._last is not None

    @property
    def last_ticks(self) -> np.ndarray:
        if self._last is None:
            raise RuntimeError("SafetyGate used before seed()")
        return self._last.astype(int)

    @property
    def last_rad(self) -> np.ndarray:
        """The angle of the last goal sent (or of the seed)."""
        return self.ticks_to_rad(self.last_ticks)

    def ticks_to_rad(self, ticks: np.ndarray | Sequence[float]) -> np.ndarray:
        return (np.asarray(ticks, float) - self._zero) / self._scale

    def rad_to_ticks_float(self, angles_rad: np.ndarray | Sequence[float]) -> np.ndarray:
        return self._zero + self._scale * np.asarray(angles_rad, float)

    def seed(self, present_ticks: Mapping[int, int] | Sequence[int] | np.ndarray) -> None:
        """Start from the present pose: {bus id: ticks} or ticks in joint order."""
        if isinstance(present_ticks, Mapping):
            missing = [i for i in self._ids if i not in present_ticks]
            if missing:
                raise KeyError(f"no present position for bus ids {missing}")
            ticks = np.array([present_ticks[i] for i in self._ids], float)
        else:
            ticks = np.asarray(present_ticks, float).reshape(-1)
        if ticks.shape != (len(self._ids),) or not np.all(np.isfinite(ticks)):
            raise ValueError(f"seed needs {len(self._ids)} finite tick values")
        self._last = np.round(ticks)
        self._budget = self._step.copy()

    def command(self, target_rad: np.ndarray | Sequence[float]) -> GateCommand:
        """Clip, convert and send one goal pose; returns what was sent."""
        if self._last is None:
            raise RuntimeError("SafetyGate used before seed()")
        requested = np.asarray(target_rad, float).reshape(-1)
        if requested.shape != self._last.shape:
            raise ValueError(f"expected {self._last.size} joint targets, got {requested.size}")
        # a non-finite target (NaN from a broken spline) means "stay where you are"
        wanted = np.where(np.isfinite(requested), self.rad_to_ticks_float(requested), self._last)
        wanted = np.round(wanted)
        in_limits = np.clip(wanted, self._lo, self._hi)
        limit_clipped = int(np.count_nonzero(in_limits != wanted))
        allowed = np.floor(self._budget + 1e-9)
        ticks = np.clip(in_limits, self._last - allowed, self._last + allowed)
        step_clipped = int(np.count_nonzero(ticks != in_limits))
        used = np.abs(ticks - self._last)
        self._budget = np.minimum(self._budget - used, CARRY_TICKS) + self._step
        self._last = ticks  # assume delivered even if the write raises (conservative next step)
        sent = tuple(int(t) for t in ticks)
        if self._sink is not None:
            self._sink(dict(zip(self._ids, sent, strict=True)))
        self.commands += 1
        return GateCommand(requested, self.ticks_to_rad(ticks), sent, limit_clipped, step_clipped)

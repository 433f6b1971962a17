"""Attitude feedback in the player: an IMU's roll/pitch → goal offsets before the SafetyGate.

The law is the simulator's (`robots.attitude`, map from `robots.attitude_maps`): each tick the
player asks `AttitudeCorrector.offsets` for the stance legs' joint offsets and adds them to the
tick's target *before* `SafetyGate.command`, so joint limits, the per-tick speed budget and the
safe stop apply to the corrected goal exactly as to an open-loop one. `gaitsmith-play drive`
(`hardware.play.drive`) asks `AttitudeCorrector.blended_offsets` instead: the reference of the
blend its `GaitBlender` plays (`robots.attitude.blended_offsets`), the same freshness fade.

An IMU is anything that implements `AttitudeSource` (``read()`` → the newest `AttitudeReading`
— roll, pitch [rad] in the planner's z-y'-x'' convention and when it was measured, on the
player's clock — or None when there is none yet). `SyntheticAttitude` is a scripted source for
tests and the virtual bus.

Stale or missing readings: a reading older than `max_age_s` (or none at all) is not used (nor
one stamped more than `max_age_s` after the tick's clock: another clock's). The
correction then fades linearly to zero over `fade_s` from what it last was — it is never frozen
at its last value, which on a robot whose IMU has died would hold a tilt correction for a tilt
that is gone. When fresh readings return, the correction fades back in over the same time.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from hardware.play.errors import PlayerError
from robots.attitude import (
    AttitudeLaw,
    AttitudeMap,
    blended_offsets,
    gait_offsets,
)
from robots.gait import Gait

DEFAULT_MAX_AGE_S = 0.05  # five ticks at 100 Hz: older than this the reading is stale
DEFAULT_FADE_S = 0.2  # a stale IMU's correction reaches zero after this long
MAX_AGE_BOUND_S = 1.0


@dataclass(frozen=True)
class AttitudeReading:
    """One IMU sample: body roll and pitch [rad] and when it was measured [s, player clock]."""

    roll_rad: float
    pitch_rad: float
    t_s: float


class AttitudeSource(Protocol):
    """An IMU as the player sees it."""

    def read(self) -> AttitudeReading | None:
        """The newest reading (None: none yet, or the IMU is not answering)."""
        ...


class SyntheticAttitude:
    """A scripted IMU: `attitude(t)` → (roll, pitch) [rad] at clock time `clock()` (the
    player's clock); after `stall_after_reads` reads it produces no new reading (its last one
    then goes stale, like an IMU that stopped answering)."""

    def __init__(self, attitude: Callable[[float], tuple[float, float]],
                 clock: Callable[[], float], *, stall_after_reads: int | None = None) -> None:
        self.attitude, self.clock = attitude, clock
        self.stall_after_reads = stall_after_reads
        self.reads = 0
        self._last: AttitudeReading | None = None

    def read(self) -> AttitudeReading | None:
        self.reads += 1
        if self.stall_after_reads is None or self.reads <= self.stall_after_reads:
            t = self.clock()
            roll, pitch = self.attitude(t)
            self._last = AttitudeReading(float(roll), float(pitch), t)
        return self._last


class AttitudeCorrector:
    """Per-tick offsets (module docstring): the law on the source's readings, faded by the
    readings' freshness."""

    def __init__(self, law: AttitudeLaw, amap: AttitudeMap, gait: Gait | None,
                 source: AttitudeSource, *, max_age_s: float = DEFAULT_MAX_AGE_S,
                 fade_s: float = DEFAULT_FADE_S) -> None:
        """`gait`: the gait `offsets` follows (`run`); None when the reference is given each
        tick (`blended_offsets`: `drive`'s blend of a library's gaits)."""
        if not (math.isfinite(max_age_s) and 0.0 < max_age_s <= MAX_AGE_BOUND_S):
            raise PlayerError(f"IMU max age must be in (0, {MAX_AGE_BOUND_S:g}] s, got "
                              f"{max_age_s!r}")
        if not (math.isfinite(fade_s) and fade_s > 0.0):
            raise PlayerError(f"IMU fade time must be a positive number of seconds, got "
                              f"{fade_s!r}")
        self.law, self.amap, self.gait, self.source = law, amap, gait, source
        self.max_age_s, self.fade_s = max_age_s, fade_s
        self.trust = 0.0  # 0..1: how much of the law's offset is applied (freshness fade)
        self._offset = np.zeros(amap.n_joints)  # the law's last offset from a fresh reading
        self._t_last: float | None = None
        self._had_reading = False  # the first fresh reading applies at once (blend fades it in)
        self.stale_ticks = 0

    def offsets(self, now_s: float, blend: float, gait_time_s: float) -> np.ndarray:
        """(J,) offsets to add to the target of the tick at `now_s` (the player's clock, the
        one the source's readings are stamped on), with entry/exit blend
        weight `blend` ∈ [0, 1] and the gait's clock at `gait_time_s`."""
        gait = self.gait
        if gait is None:
            raise PlayerError("AttitudeCorrector.offsets needs the corrector's gait; a blend of "
                              "gaits goes through blended_offsets")
        return self._faded(now_s, lambda measured: gait_offsets(
            self.law, self.amap, gait, measured, blend, gait_time_s))

    def blended_offsets(self, now_s: float, blend: float, gaits: Sequence[Gait],
                        weights: np.ndarray, phase: float) -> np.ndarray:
        """(J,) `offsets` for a blend of gaits at one phase (`drive`): the reference roll/pitch
        and the support weights blended with the blender's weights
        (`robots.attitude.blended_offsets`), `blend` the blender's entry/exit weight α."""
        return self._faded(now_s, lambda measured: blended_offsets(
            self.law, self.amap, gaits, weights, measured, blend, phase))

    def _faded(self, now_s: float, law: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """The law's offsets on a fresh reading, faded by the readings' freshness (module
        docstring)."""
        dt = 0.0 if self._t_last is None else max(0.0, now_s - self._t_last)
        self._t_last = now_s
        reading = self.source.read()
        # |age| ≤ max age: a source that stamps its reading when read (WitmotionImu,
        # SyntheticAttitude on a real clock) stamps it just *after* `now_s`, which the player
        # read before asking; that reading is the freshest there is, not one from the future
        fresh = (reading is not None and math.isfinite(reading.roll_rad)
                 and math.isfinite(reading.pitch_rad)
                 and abs(now_s - reading.t_s) <= self.max_age_s)
        step = dt / self.fade_s
        if fresh:
            assert reading is not None
            self.trust = min(1.0, self.trust + step) if self._had_reading else 1.0
            self._offset = law(np.array([reading.roll_rad, reading.pitch_rad]))
        else:
            self.stale_ticks += 1
            self.trust = max(0.0, self.trust - step)
        self._had_reading = self._had_reading or fresh
        return np.asarray(self.trust * self._offset)


__all__ = [
    "AttitudeCorrector",
    "AttitudeReading",
    "AttitudeSource",
    "SyntheticAttitude",
]

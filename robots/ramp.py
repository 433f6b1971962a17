"""Ramp-in: move the joints smoothly from the present pose to a gait's first pose (numpy only).

The player (`hardware`) and the simulator (`sim.validate`) both start a gait this way, so the
simulator sees the same transient the servos will: a minimum-jerk joint-space move
(Flash & Hogan 1985, eq. 2: s(u) = 10u³ − 15u⁴ + 6u⁵, u = t/T) from the present pose to the gait's
pose at phase 0, then the gait starts at phase 0. Velocity and acceleration are zero at both ends
of the ramp; peak speed is 1.875·|Δq|/T (at u = ½).

`ramp_duration_s` picks T: at least `min_duration_s` (1 s by default), longer if the largest joint
move would otherwise exceed `max_speed_rad_s` at the mid-point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_JERK_PEAK_SPEED = 1.875  # max over u of ds/du for the quintic above
DEFAULT_RAMP_S = 1.0


def min_jerk(u: float | np.ndarray) -> np.ndarray:
    """Normalised minimum-jerk profile s(u) for u in [0, 1] (clipped outside)."""
    x = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    return x**3 * (10.0 + x * (-15.0 + 6.0 * x))


def min_jerk_rate(u: float | np.ndarray) -> np.ndarray:
    """ds/du of `min_jerk` (zero outside [0, 1])."""
    x = np.asarray(u, dtype=float)
    inside = (x >= 0.0) & (x <= 1.0)
    return np.where(inside, 30.0 * x**2 * (1.0 - x) ** 2, 0.0)


def ramp_duration_s(
    start_rad: np.ndarray,
    end_rad: np.ndarray,
    max_speed_rad_s: float | np.ndarray,
    min_duration_s: float = DEFAULT_RAMP_S,
) -> float:
    """Shortest ramp time ≥ `min_duration_s` whose peak joint speed stays ≤ `max_speed_rad_s`."""
    if min_duration_s <= 0:
        raise ValueError("min_duration_s must be positive")
    delta = np.abs(np.asarray(end_rad, dtype=float) - np.asarray(start_rad, dtype=float))
    speed = np.broadcast_to(np.asarray(max_speed_rad_s, dtype=float), delta.shape)
    if np.any(speed <= 0):
        raise ValueError("max_speed_rad_s must be positive")
    needed = float(np.max(MIN_JERK_PEAK_SPEED * delta / speed)) if delta.size else 0.0
    return max(float(min_duration_s), needed)


@dataclass(frozen=True, eq=False)
class MinJerkRamp:
    """Joint-space minimum-jerk move from `start_rad` to `end_rad` (J,) over `duration_s`."""

    start_rad: np.ndarray
    end_rad: np.ndarray
    duration_s: float

    def __post_init__(self) -> None:
        start = np.asarray(self.start_rad, dtype=float).reshape(-1)
        end = np.asarray(self.end_rad, dtype=float).reshape(-1)
        if start.shape != end.shape:
            raise ValueError(f"start {start.shape} and end {end.shape} poses differ in size")
        if not (np.all(np.isfinite(start)) and np.all(np.isfinite(end))):
            raise ValueError("ramp poses must be finite")
        if not self.duration_s > 0:
            raise ValueError("duration_s must be positive")
        object.__setattr__(self, "start_rad", start)
        object.__setattr__(self, "end_rad", end)

    def positions(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint targets at time(s) `t_s` since the ramp began ((J,) or (K, J)); held after T."""
        t = np.asarray(t_s, dtype=float)
        s = min_jerk(t / self.duration_s)
        out = self.start_rad + np.multiply.outer(s, self.end_rad - self.start_rad)
        return np.asarray(out)

    def velocities(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint speeds [rad/s] at time(s) `t_s` ((J,) or (K, J))."""
        t = np.asarray(t_s, dtype=float)
        ds = min_jerk_rate(t / self.duration_s) / self.duration_s
        return np.asarray(np.multiply.outer(ds, self.end_rad - self.start_rad))

    @property
    def peak_speed_rad_s(self) -> float:
        delta = np.abs(self.end_rad - self.start_rad)
        return float(MIN_JERK_PEAK_SPEED * np.max(delta) / self.duration_s) if delta.size else 0.0


def ramp_to(
    present_rad: np.ndarray,
    target_rad: np.ndarray,
    max_speed_rad_s: float | np.ndarray,
    min_duration_s: float = DEFAULT_RAMP_S,
) -> MinJerkRamp:
    """The ramp the player and the simulator use: min-jerk, ≥ `min_duration_s`, speed-capped."""
    duration = ramp_duration_s(present_rad, target_rad, max_speed_rad_s, min_duration_s)
    return MinJerkRamp(np.asarray(present_rad, float), np.asarray(target_rad, float), duration)

"""The simulated IMU and the attitude law in the rollout's stream (`robots.attitude`).

Every stream tick k (t_k = k / rate_hz) the rollout (`sim.rollout.run` with
`RunSettings.attitude`) asks `AttitudeLoop.correct` for the offsets to add to that tick's goals
before the servo model holds and delays them (`sim.servo.held_targets`), exactly where the player
adds them before its SafetyGate. The IMU reads the free joint's orientation as it was
`imu.latency_s` before the tick (the newest physics step at or before then), adds zero-mean
Gaussian noise of `imu.noise_rad` to roll and pitch (seeded: a run is reproducible), and the law
turns measured − planned roll/pitch into joint offsets on the stance legs.

Timing, as in `robots.ramp`: the gait's clock starts when the entry blend starts, so the gait
phase (which feet are down) and the plan's attitude are read at τ = t − (settle + ramp + hold)
during the blend, the cycles and the exit alike; the blend weight α (0 → 1 over the entry, 1 → 0
over the exit, 0 before and after) scales both the planned attitude and the offsets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robots.attitude import (
    AttitudeLaw,
    AttitudeMap,
    gait_offsets,
    roll_pitch,
)
from robots.gait import Gait
from robots.ramp import GaitEntry, GaitExit, min_jerk
from sim.errors import SimConfigError

MAX_IMU_LATENCY_S = 0.5
MAX_IMU_NOISE_RAD = 0.2


@dataclass(frozen=True)
class ImuSettings:
    """The simulated IMU: how old its reading is and how noisy (1σ per axis)."""

    latency_s: float = 0.0
    noise_rad: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.latency_s) and 0.0 <= self.latency_s <= MAX_IMU_LATENCY_S):
            raise SimConfigError(f"IMU latency must be in [0, {MAX_IMU_LATENCY_S}] s, got "
                                 f"{self.latency_s!r}")
        if not (math.isfinite(self.noise_rad) and 0.0 <= self.noise_rad <= MAX_IMU_NOISE_RAD):
            raise SimConfigError(f"IMU noise must be in [0, {MAX_IMU_NOISE_RAD}] rad, got "
                                 f"{self.noise_rad!r}")


@dataclass(frozen=True)
class AttitudeSettings:
    """Closed-loop attitude feedback in a run: the law and the IMU it reads."""

    law: AttitudeLaw
    imu: ImuSettings = ImuSettings()


def closed_loop(gain: float, imu: ImuSettings = ImuSettings()) -> AttitudeSettings | None:
    """The run's closed-loop settings at gain `gain` (the law's defaults otherwise; None: open
    loop, at gain 0)."""
    return AttitudeSettings(AttitudeLaw(gain), imu) if gain > 0.0 else None


@dataclass(frozen=True, eq=False)
class RunClock:
    """When the run's gait clock starts and how the blend weight goes (from `sim.rollout`)."""

    settle_s: float
    entry: GaitEntry
    gait_end_s: float
    exit: GaitExit | None

    @property
    def gait_clock_start_s(self) -> float:
        return self.settle_s + self.entry.blend_start_s

    def blend(self, t_s: float) -> float:
        """α at run time `t_s`: the entry's blend weight, then 1, then the exit's fade."""
        if t_s <= self.gait_end_s:
            return float(self.entry.blend_weight(t_s - self.settle_s))
        if self.exit is None:
            return 1.0
        return float(1.0 - min_jerk(min(1.0, (t_s - self.gait_end_s) / self.exit.duration_s)))


class SimulatedImu:
    """The simulated IMU (`ImuSettings`, module docstring): logs the base orientation as the
    physics runs and reads it `latency_s` late, plus seeded noise. Shared by the closed-loop
    rollout (`AttitudeLoop`) and the closed-loop path following of `sim.path.follow`."""

    def __init__(self, settings: ImuSettings) -> None:
        self.settings = settings
        self._rng = np.random.default_rng(settings.seed)
        self._t = [0.0]
        self._quat = [np.array([1.0, 0.0, 0.0, 0.0])]
        self._read = 0  # index of the newest entry read so far (reads come in time order)

    def record(self, time_s: np.ndarray, quat_wxyz: np.ndarray) -> None:
        """Log the base orientation after some physics steps ((n,), (n, 4))."""
        self._t.extend(float(t) for t in time_s)
        self._quat.extend(np.array(quat_wxyz, dtype=float))  # a copy: not a view of live data

    def measured(self, t_s: float) -> np.ndarray:
        """(2,) the IMU's roll/pitch at run time `t_s`: the newest logged orientation at or
        before t − latency, plus noise."""
        t_read = t_s - self.settings.latency_s + 1e-9
        while self._read + 1 < len(self._t) and self._t[self._read + 1] <= t_read:
            self._read += 1
        rp = roll_pitch(self._quat[self._read])
        if self.settings.noise_rad > 0.0:
            rp = rp + self._rng.normal(0.0, self.settings.noise_rad, 2)
        return np.asarray(rp)


class AttitudeLoop:
    """Per-tick offsets of one closed-loop run (module docstring). Keeps the IMU's history."""

    def __init__(self, settings: AttitudeSettings, amap: AttitudeMap, gait: Gait,
                 clock: RunClock) -> None:
        self.settings = settings
        self.amap = amap
        self.gait = gait
        self.clock = clock
        self.imu = SimulatedImu(settings.imu)

    def record(self, time_s: np.ndarray, quat_wxyz: np.ndarray) -> None:
        """Log the base orientation after some physics steps ((n,), (n, 4))."""
        self.imu.record(time_s, quat_wxyz)

    def measured(self, t_s: float) -> np.ndarray:
        """(2,) the IMU's roll/pitch at run time `t_s` (`SimulatedImu.measured`)."""
        return self.imu.measured(t_s)

    def correct(self, t_s: float) -> np.ndarray:
        """(J,) goal offsets for the tick sent at run time `t_s`."""
        alpha = self.clock.blend(t_s)
        if alpha <= 0.0:
            return np.zeros(self.amap.n_joints)
        return gait_offsets(self.settings.law, self.amap, self.gait, self.measured(t_s), alpha,
                            t_s - self.clock.gait_clock_start_s)


__all__ = [
    "AttitudeLoop", "AttitudeSettings", "ImuSettings", "RunClock", "SimulatedImu", "closed_loop",
]

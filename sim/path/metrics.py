"""Metrics and verdict of a drive-sim run (`FollowLog`).

- Cross-track error: the base's distance from the path at the nearest point of the
  controller's window (so a figure-8's crossing is measured against the lobe being driven),
  over the ticks the controller steered (`FollowLog.driving`: after settling, until it arrived).
  Mean of |e| and max |e|.
- Heading error: body yaw − path tangent at that point, over the same ticks (mean |·|, max |·|).
  It includes the base's yaw sway within each gait cycle.
- Time: from the first command to standing again at the end (to the end of the run if it never
  stood again). Distance: the length of the driven base path after a moving average over one
  gait period (the sway within a cycle is not distance), and the planned length.
- Peak servo torque: max over every physics step of |τ| / τ_stall, per joint and overall.
- Fall (body on the ground, base low, tipped — `sim.metrics.FallThresholds`), arrival, timeout.

Verdict (`DriveCriteria`): arrived, no fall, mean cross-track error within
`max_mean_cross_track_leg_lengths`·L (or `max_mean_cross_track_m`), peak torque within
`max_peak_torque_fraction` of stall (the validation limit).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from sim.path.follow import FollowLog
from sim.render import _moving_average
from sim.validate import PassCriteria


@dataclass(frozen=True)
class DriveCriteria:
    #: a third of a leg length: 5.9 cm for an 18 cm leg — about a foot's stride scatter
    max_mean_cross_track_leg_lengths: float = 0.3
    max_mean_cross_track_m: float | None = None  # overrides the leg-length rule when set
    max_peak_torque_fraction: float = PassCriteria().max_peak_torque_fraction

    def cross_track_limit_m(self, leg_length_m: float) -> float:
        if self.max_mean_cross_track_m is not None:
            return self.max_mean_cross_track_m
        return self.max_mean_cross_track_leg_lengths * leg_length_m


@dataclass(frozen=True)
class DriveMetrics:
    cross_track_mean_m: float
    cross_track_max_m: float
    heading_error_mean_rad: float
    heading_error_max_rad: float
    time_s: float
    distance_m: float  # driven, smoothed over one gait period
    planned_distance_m: float  # path length × laps
    progress_m: float  # how far along the path the controller got
    mean_speed_m_s: float
    peak_torque_fraction: float
    peak_torque_joint: str
    fell: bool
    fall_time_s: float | None
    fall_reason: str | None
    arrived: bool
    timed_out: bool
    footprints: int
    clipped_fraction: float  # share of driving ticks whose request the blender clipped

    def to_dict(self) -> dict[str, object]:
        out: dict[str, object] = {}
        for k, v in asdict(self).items():
            out[k] = v if not isinstance(v, float) or math.isfinite(v) else None
        return out


@dataclass(frozen=True)
class DriveResult:
    passed: bool
    checks: tuple[tuple[str, bool, str], ...]
    metrics: DriveMetrics
    joint_peak_fraction: tuple[tuple[str, float], ...]

    @property
    def reasons(self) -> tuple[str, ...]:
        return tuple(f"{name}: {detail}" for name, ok, detail in self.checks if not ok)


def compute(log: FollowLog, joint_names: tuple[str, ...], period_s: float) -> DriveMetrics:
    """Metrics of `log` (module docstring); `period_s` smooths the driven distance."""
    drv = log.driving if np.any(log.driving) else np.ones(log.n_ticks, dtype=bool)
    e = np.abs(log.cross_track_m[drv])
    h = np.abs(log.heading_error_rad[drv])
    t = log.time_s
    start = log.drive_start_s
    end = float(t[-1])
    if log.arrived_s is not None:
        after = np.flatnonzero((t >= log.arrived_s) & log.standing)
        if after.size:
            end = float(t[after[0]])
    dt = float(t[1] - t[0]) if len(t) > 1 else 1.0
    moving = (t >= start) & (t <= end)
    window = max(1, round(period_s / dt))
    xy = np.stack([_moving_average(log.base_pos_m[:, i], window) for i in (0, 1)], axis=1)
    xy = xy[moving]
    distance = float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1))) if len(xy) > 1 else 0.0
    frac = log.peak_torque_nm / log.stall_torque_nm
    worst = int(np.argmax(frac))
    duration = max(end - start, 0.0)
    n_drv = int(np.sum(log.driving))
    return DriveMetrics(
        cross_track_mean_m=float(np.mean(e)),
        cross_track_max_m=float(np.max(e)),
        heading_error_mean_rad=float(np.mean(h)),
        heading_error_max_rad=float(np.max(h)),
        time_s=duration,
        distance_m=distance,
        planned_distance_m=log.total_length_m,
        progress_m=float(log.progress_m[-1]),
        mean_speed_m_s=distance / duration if duration > 0 else 0.0,
        peak_torque_fraction=float(frac[worst]),
        peak_torque_joint=joint_names[worst],
        fell=log.fell,
        fall_time_s=log.fall_time_s,
        fall_reason=log.fall_reason,
        arrived=log.arrived_s is not None,
        timed_out=log.timed_out,
        footprints=len(log.footprints()),
        clipped_fraction=log.command_clipped_ticks / n_drv if n_drv else 0.0,
    )


def judge(log: FollowLog, joint_names: tuple[str, ...], period_s: float,
          criteria: DriveCriteria = DriveCriteria()) -> DriveResult:
    m = compute(log, joint_names, period_s)
    limit = criteria.cross_track_limit_m(log.leg_length_m)
    checks = (
        ("arrived", m.arrived,
         f"reached the end after {m.time_s:.1f} s" if m.arrived else
         f"stopped {m.planned_distance_m - m.progress_m:.2f} m short of the end"
         + (" (timeout)" if m.timed_out else "")),
        ("no fall", not m.fell,
         "stayed up" if not m.fell else f"fell at t = {m.fall_time_s:.2f} s: {m.fall_reason}"),
        ("cross-track", m.cross_track_mean_m <= limit,
         f"mean {m.cross_track_mean_m * 100:.1f} cm, max {m.cross_track_max_m * 100:.1f} cm "
         f"(limit on the mean {limit * 100:.1f} cm)"),
        ("peak torque", m.peak_torque_fraction <= criteria.max_peak_torque_fraction,
         f"peak |τ| = {m.peak_torque_fraction:.0%} of stall at {m.peak_torque_joint} "
         f"(limit {criteria.max_peak_torque_fraction:.0%})"),
    )
    frac = log.peak_torque_nm / log.stall_torque_nm
    return DriveResult(
        passed=all(ok for _, ok, _ in checks),
        checks=checks,
        metrics=m,
        joint_peak_fraction=tuple((n, float(f)) for n, f in zip(joint_names, frac, strict=True)),
    )

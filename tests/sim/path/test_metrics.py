"""Drive metrics on hand-made logs: windows, the sway-free distance, footprints, the verdict."""

from __future__ import annotations

import math

import numpy as np

from sim.path.follow import FollowLog
from sim.path.metrics import DriveCriteria, compute, judge
from sim.path.spec import parse_path

LEG_M = 0.18
JOINTS = ("a", "b")


def _log(offset_m: float = 0.01, fell: bool = False) -> FollowLog:
    """1 m along x at 0.1 m/s, `offset_m` left of the path, swaying ±1 cm at a 0.5 s period;
    standing 0.5 s before and 1 s after; two feet touching down once per period each."""
    dt = 0.01
    t = np.arange(1, 1251) * dt  # 12.5 s
    drive = (t >= 0.5) & (t < 10.5)
    x = np.clip((t - 0.5) * 0.1, 0.0, 1.0)
    y = offset_m + 0.01 * np.sin(2 * math.pi * t / 0.5) * drive
    k = len(t)
    phase = (t / 0.5) % 1.0
    down = np.stack([phase < 0.6, (phase + 0.5) % 1.0 < 0.6], axis=1)
    pos = np.stack([x, y, np.full(k, 0.2)], axis=1)
    return FollowLog(
        path=parse_path("0,0;1,0", LEG_M), laps=1, leg_length_m=LEG_M, time_s=t,
        base_pos_m=pos, yaw_rad=np.zeros(k), tilt_rad=np.zeros(k), qpos=np.zeros((k, 7)),
        requested=np.zeros((k, 3)), commanded=np.zeros((k, 3)), targets_rad=np.zeros((k, 2)),
        q_rad=np.zeros((k, 2)), progress_m=x, cross_track_m=np.where(drive, y, 0.0),
        heading_error_rad=np.where(drive, 0.02, 0.5), driving=drive,
        standing=(t < 0.5) | (t >= 11.0), foot_pos_m=np.repeat(pos[:, None, :], 2, axis=1),
        foot_down=down, tick_torque_nm=np.full((k, 2), 0.5),
        peak_torque_nm=np.array([0.5, 1.2]), stall_torque_nm=np.array([1.0, 2.0]),
        drive_start_s=0.5, arrived_s=10.5, fell=fell, fall_time_s=3.0 if fell else None,
        fall_reason="tilted" if fell else None, timed_out=False, command_clipped_ticks=100,
    )


def test_errors_over_the_driving_ticks_only() -> None:
    m = compute(_log(), JOINTS, 0.5)
    # |0.01 + 0.01 sin| averages to 1 cm; the standing ticks (heading error 0.5) are not counted
    assert abs(m.cross_track_mean_m - 0.01) < 5e-4
    assert abs(m.cross_track_max_m - 0.02) < 1e-4
    assert m.heading_error_mean_rad == 0.02 == m.heading_error_max_rad


def test_time_distance_and_speed_leave_out_the_sway() -> None:
    m = compute(_log(), JOINTS, 0.5)
    assert abs(m.time_s - 10.5) < 0.02  # first command (0.5 s) → standing again (11.0 s)
    assert abs(m.distance_m - 1.0) < 0.02  # the ±1 cm sway at 4 Hz would add ~0.16 m
    assert abs(m.mean_speed_m_s - 1.0 / 10.5) < 0.003
    assert m.planned_distance_m == 1.0
    assert m.footprints == 2 * 26  # the first stance + a touchdown per 0.5 s period, per foot
    assert m.peak_torque_fraction == 0.6 and m.peak_torque_joint == "b"
    assert m.clipped_fraction == 100 / 1000


def test_verdict() -> None:
    assert judge(_log(), JOINTS, 0.5).passed
    off = judge(_log(offset_m=0.1), JOINTS, 0.5)  # 10 cm off: over 0.3 leg lengths (5.4 cm)
    assert [name for name, ok, _ in off.checks if not ok] == ["cross-track"]
    fell = judge(_log(fell=True), JOINTS, 0.5)
    assert fell.reasons == ("no fall: fell at t = 3.00 s: tilted",)
    strict = judge(_log(), JOINTS, 0.5, DriveCriteria(max_peak_torque_fraction=0.5))
    assert strict.reasons[0].startswith("peak torque: peak |τ| = 60% of stall at b")

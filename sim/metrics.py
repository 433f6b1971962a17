"""Metrics of one run, computed from a `Trajectory` over its steady cycles.

The steady window starts `warmup_cycles` gait cycles after the ramp-in ends (the gait starts from
rest, so the first cycles are a transient) and ends with the run. Falls are looked for over the
whole run, ramp included.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from robots.gait import Gait
from sim.model import SimModel
from sim.rollout import Trajectory

GRAVITY_M_S2 = 9.81
CONTACT_FORCE_FRACTION = 0.01  # a foot is "down" when it carries ≥ 1 % of the robot's weight
MIN_DISTANCE_FOR_DRIFT_M = 0.05


@dataclass(frozen=True)
class FallThresholds:
    min_height_fraction: float = 0.5  # of the nominal stance base height
    max_tilt_rad: float = math.radians(45.0)


@dataclass(frozen=True)
class Metrics:
    """Scalar metrics of one run (SI units; None when undefined, e.g. drift per metre at v = 0)."""

    duration_s: float
    steady_duration_s: float
    cycles_run: int
    commanded_speed_m_s: float
    achieved_speed_m_s: float  # along the commanded direction (planar speed when commanded 0)
    achieved_vx_m_s: float  # body frame
    achieved_vy_m_s: float
    achieved_yaw_rate_rad_s: float
    speed_error_fraction: float | None
    distance_m: float
    lateral_drift_m: float
    lateral_drift_per_m: float | None
    yaw_drift_rad: float
    yaw_drift_rad_per_m: float | None
    fell: bool
    fall_time_s: float | None
    fall_reason: str | None
    base_height_min_m: float
    base_height_max_m: float
    tilt_max_rad: float
    roll_range_rad: float
    pitch_range_rad: float
    slip_mean_m: float  # horizontal travel of the contact point per stance, mean over stances
    slip_max_m: float
    stances: int
    peak_torque_fraction: float  # max over joints of peak |τ| / τ_stall
    rms_torque_fraction: float  # max over joints of RMS |τ| / τ_stall
    saturation_fraction: float  # share of joint-samples with the position loop at full duty
    tracking_rms_rad: float
    tracking_max_rad: float
    mechanical_power_w: float
    cost_of_transport: float | None

    def to_dict(self) -> dict[str, object]:
        return {k: _json(v) for k, v in asdict(self).items()}


@dataclass(frozen=True)
class JointMetrics:
    name: str
    peak_torque_fraction: float
    rms_torque_fraction: float
    tracking_rms_rad: float
    tracking_max_rad: float
    peak_speed_rad_s: float


def _json(v: object) -> object:
    if isinstance(v, (bool, int, str)) or v is None:
        return v
    f = float(v)  # type: ignore[arg-type]
    return f if math.isfinite(f) else None


def yaw_of(quat: np.ndarray) -> np.ndarray:
    w, x, y, z = (quat[..., i] for i in range(4))
    return np.asarray(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def roll_pitch_of(quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    w, x, y, z = (quat[..., i] for i in range(4))
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    return np.asarray(roll), np.asarray(pitch)


def tilt_of(quat: np.ndarray) -> np.ndarray:
    """Angle between the body's z axis and the world's (rad)."""
    x, y = quat[..., 1], quat[..., 2]
    return np.asarray(np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0)))


def foot_down(traj: Trajectory, sim: SimModel) -> np.ndarray:
    """(T, F) bool: the foot carries at least 1 % of the robot's weight."""
    threshold = CONTACT_FORCE_FRACTION * sim.mass_kg * GRAVITY_M_S2
    return (traj.foot_contacts > 0) & (traj.foot_force_n >= threshold)


def detect_fall(
    traj: Trajectory, sim: SimModel, th: FallThresholds = FallThresholds()
) -> tuple[float | None, str | None]:
    """First time the run counts as a fall, and why (body–ground contact, too low, tipped)."""
    body_touch = traj.robot_contacts > traj.foot_contacts.sum(axis=1) + 0.5
    low = traj.base_pos_m[:, 2] < th.min_height_fraction * sim.robot.stance_base_height_m
    tipped = tilt_of(traj.base_quat) > th.max_tilt_rad
    first: tuple[float, str] | None = None
    for mask, why in (
        (body_touch, "body touched the ground"),
        (low, f"base dropped below {th.min_height_fraction:.0%} of stance height"),
        (tipped, f"tilted beyond {math.degrees(th.max_tilt_rad):.0f}°"),
    ):
        if np.any(mask):
            i = int(np.argmax(mask))
            if first is None or traj.time_s[i] < first[0]:
                first = (float(traj.time_s[i]), why)
    return (None, None) if first is None else first


def steady_mask(traj: Trajectory, warmup_cycles: int) -> np.ndarray:
    start = traj.gait_start_s + warmup_cycles * traj.period_s
    mask = traj.time_s > start + 1e-9
    if not np.any(mask):  # run ended (fell) before the steady window: use what there is of the gait
        mask = traj.time_s > traj.gait_start_s
    if not np.any(mask):
        mask = np.ones_like(traj.time_s, dtype=bool)
    return np.asarray(mask)


def _stance_slips(slip_speed: np.ndarray, down: np.ndarray, dt: float) -> list[float]:
    """Slip distance of every complete stance (contiguous run of down samples)."""
    out: list[float] = []
    for f in range(down.shape[1]):
        d = down[:, f].astype(np.int8)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], d, [0]])))
        for a, b in zip(edges[0::2], edges[1::2], strict=True):
            if a == 0 or b == len(d):  # cut by the window: not a complete stance
                continue
            out.append(float(np.sum(slip_speed[a:b, f]) * dt))
    return out


def compute(
    traj: Trajectory,
    gait: Gait,
    sim: SimModel,
    *,
    warmup_cycles: int = 2,
    falls: FallThresholds = FallThresholds(),
) -> tuple[Metrics, tuple[JointMetrics, ...]]:
    dt = traj.dt_s
    w = steady_mask(traj, warmup_cycles)
    t = traj.time_s[w]
    span = float(t[-1] - t[0] + dt)
    yaw = np.unwrap(yaw_of(traj.base_quat))
    c, s = np.cos(yaw), np.sin(yaw)
    v = traj.base_linvel_m_s
    v_fwd = c * v[:, 0] + s * v[:, 1]
    v_lat = -s * v[:, 0] + c * v[:, 1]
    fwd, lat = float(np.sum(v_fwd[w]) * dt), float(np.sum(v_lat[w]) * dt)
    vx, vy = fwd / span, lat / span
    yaw_rate = float(yaw[w][-1] - yaw[w][0] + 0.0) / max(span - dt, dt)
    cmd = gait.velocity
    cmd_speed = math.hypot(cmd.vx_m_s, cmd.vy_m_s)
    if cmd_speed > 1e-9:
        ux, uy = cmd.vx_m_s / cmd_speed, cmd.vy_m_s / cmd_speed
        achieved = vx * ux + vy * uy
        lateral = (-uy * fwd + ux * lat) - 0.0
        along = fwd * ux + lat * uy
        speed_err: float | None = abs(achieved - cmd_speed) / cmd_speed
    else:
        achieved, lateral, along, speed_err = math.hypot(vx, vy), lat, fwd, None
    yaw_drift = float(yaw[w][-1] - yaw[w][0]) - cmd.yaw_rate_rad_s * (span - dt)
    per_m = abs(along) >= MIN_DISTANCE_FOR_DRIFT_M
    fall_t, fall_why = detect_fall(traj, sim, falls)
    roll, pitch = roll_pitch_of(traj.base_quat[w])
    down = foot_down(traj, sim)[w]
    slips = _stance_slips(traj.foot_slip_speed_m_s[w], down, dt)
    stall = sim.stall_torque_nm
    tau_frac = np.abs(traj.torque_nm[w]) / stall
    drive_lim = np.array([sp.drive_limit_nm for sp in sim.servos])
    saturated = np.abs(traj.drive_nm[w]) >= drive_lim * (1 - 1e-6)
    err = traj.q_rad[w] - traj.expected_rad[w]  # vs the motion the goals should achieve
    power = float(np.mean(np.sum(np.abs(traj.torque_nm[w] * traj.qd_rad_s[w]), axis=1)))
    cot = power / (sim.mass_kg * GRAVITY_M_S2 * abs(achieved)) if abs(achieved) > 1e-3 else None
    z = traj.base_pos_m[w, 2]
    metrics = Metrics(
        duration_s=float(traj.time_s[-1]),
        steady_duration_s=span,
        cycles_run=traj.cycles_run,
        commanded_speed_m_s=cmd_speed,
        achieved_speed_m_s=achieved,
        achieved_vx_m_s=vx,
        achieved_vy_m_s=vy,
        achieved_yaw_rate_rad_s=yaw_rate,
        speed_error_fraction=speed_err,
        distance_m=along,
        lateral_drift_m=lateral,
        lateral_drift_per_m=abs(lateral) / abs(along) if per_m else None,
        yaw_drift_rad=yaw_drift,
        yaw_drift_rad_per_m=abs(yaw_drift) / abs(along) if per_m else None,
        fell=fall_t is not None,
        fall_time_s=fall_t,
        fall_reason=fall_why,
        base_height_min_m=float(z.min()),
        base_height_max_m=float(z.max()),
        tilt_max_rad=float(tilt_of(traj.base_quat[w]).max()),
        roll_range_rad=float(np.ptp(roll)),
        pitch_range_rad=float(np.ptp(pitch)),
        slip_mean_m=float(np.mean(slips)) if slips else 0.0,
        slip_max_m=max(slips, default=0.0),
        stances=len(slips),
        peak_torque_fraction=float(tau_frac.max()),
        rms_torque_fraction=float(np.sqrt(np.mean(tau_frac**2, axis=0)).max()),
        saturation_fraction=float(np.mean(saturated)),
        tracking_rms_rad=float(np.sqrt(np.mean(err**2))),
        tracking_max_rad=float(np.abs(err).max()),
        mechanical_power_w=power,
        cost_of_transport=cot,
    )
    joints = tuple(
        JointMetrics(
            name=name,
            peak_torque_fraction=float(tau_frac[:, j].max()),
            rms_torque_fraction=float(np.sqrt(np.mean(tau_frac[:, j] ** 2))),
            tracking_rms_rad=float(np.sqrt(np.mean(err[:, j] ** 2))),
            tracking_max_rad=float(np.abs(err[:, j]).max()),
            peak_speed_rad_s=float(np.abs(traj.qd_rad_s[w, j]).max()),
        )
        for j, name in enumerate(sim.robot.joint_names)
    )
    return metrics, joints

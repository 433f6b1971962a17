"""Metrics of one run, computed from a `Trajectory`.

Two windows:

- **the whole run, in the world frame, from its first sample** (the rest pose before the hold and
  the ramp-in): heading and path. A robot that turns 15° while ramping in and then walks straight
  walks straight *on the wrong heading*; only a comparison with where it stood at the start shows
  it. The commanded velocity (vx, vy, yaw rate) is in the body frame; from the start pose
  (x₀, y₀, ψ₀) it defines the expected path: a straight line along R(ψ₀)·(vx, vy) for a zero
  yaw rate, else the circle of radius |v|/|ω| tangent to it (the path does not depend on speed,
  so a slow gait is not counted as drifting). Lateral drift is the signed distance from that path
  at the end of the run (left positive), per metre travelled along it; heading error is the yaw
  change over the run minus the turn commanded over the gait's time (ω·(t − t_gait)), averaged over
  the run's last gait period, and the yaw the gait starts on (after the hold and the ramp-in),
  the same averaged over its first period, is reported on its own (`ramp_yaw_rad`).
  `heading_change_rad` is the raw yaw change to the last sample. Averaged, because a body's yaw
  oscillates within a cycle: the built-in biped's 0.5 m/s run (26 % flight in MuJoCo) yaws
  ±12° each cycle (the torso counter-rotates while the legs scissor in flight) while its
  direction moves 1.3° over 20 cycles; its yaw at the instant the run ended read −8°. A walk's
  yaw oscillates by tenths of a degree, so for walks the two measures agree to that.
- **the steady cycles**: `warmup_cycles` gait cycles after the ramp-in ends (the gait starts from
  rest, so the first cycles are a transient) to the end of the run — speed, torque, slip, tilt,
  tracking, and the steady turning rate (`yaw_drift_rad`). Speed is measured along the commanded
  direction of the run-start frame (the heading the robot was told to walk on), so a turned robot
  walks slower along it; with a commanded yaw rate along the commanded direction at the robot's
  own heading (the yaw-rate check judges the turn).

`achieved_vx_m_s`, `achieved_vy_m_s`, `achieved_yaw_rate_rad_s` are the mean base velocity from
the gait's start to the end of the run, in the world frame rotated by the start heading ψ₀ (the
frame in which the commanded (vx, vy) point at the start; the world frame itself when the robot
starts facing +x, as `sim.validate` runs do). Falls are looked for over the whole run.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from robots.gait import Gait, Velocity
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
    # steady cycles, along the commanded direction in the run-start frame (planar speed at v = 0)
    achieved_speed_m_s: float
    # mean velocity from the gait's start to the end, run-start frame (see the module docstring)
    achieved_vx_m_s: float
    achieved_vy_m_s: float
    achieved_yaw_rate_rad_s: float
    speed_error_fraction: float | None
    distance_m: float  # steady cycles, along the commanded direction
    run_distance_m: float  # whole run, along the commanded path from the start pose
    lateral_drift_m: float  # whole run: signed distance from the commanded path at the end (left +)
    lateral_drift_per_m: float | None  # |lateral_drift_m| / run_distance_m
    heading_change_rad: float  # yaw at the end − yaw at the start of the run (world frame)
    # yaw − the start yaw − the commanded turn ω·(t − t_gait), averaged over the run's last gait
    # period (module docstring: a run's body yaws ±12° within each cycle)
    heading_error_rad: float
    ramp_yaw_rad: float  # the same, averaged over the gait's first period: the heading it starts on
    yaw_drift_rad: float  # steady cycles: yaw change − commanded turn (steady turning)
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
    # the rest of the commanded velocity (commanded_speed_m_s is |(vx, vy)|), for the verdict
    commanded_vy_m_s: float = 0.0
    commanded_yaw_rate_rad_s: float = 0.0

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
    #: closest approach of the simulated angle to the joint's nearer limit over the steady cycles
    #: (`Robot` limits: the MJCF range narrowed to the servo's); negative means past the limit
    limit_clearance_rad: float
    #: the same as a share of the joint's range
    limit_clearance_fraction: float


def _json(v: object) -> object:
    if isinstance(v, (bool, int, str)) or v is None:
        return v
    f = float(v)  # type: ignore[arg-type]
    return f if math.isfinite(f) else None


def limit_clearance_rad(
    q_rad: np.ndarray, lower_rad: np.ndarray, upper_rad: np.ndarray
) -> np.ndarray:
    """Per joint (columns of `q_rad`, samples × joints): the smallest distance of any sample to
    the nearer of the joint's two limits [rad]; negative where a sample lies past a limit."""
    q = np.asarray(q_rad, dtype=float)
    return np.asarray(np.minimum(q.min(axis=0) - lower_rad, upper_rad - q.max(axis=0)))


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
    mask = (traj.time_s > start + 1e-9) & (traj.time_s <= traj.gait_end_s + 1e-9)
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


@dataclass(frozen=True)
class RunPath:
    """Heading and path of the whole run in the world frame, against the commanded path."""

    heading_change_rad: float
    heading_error_rad: float
    ramp_yaw_rad: float
    distance_m: float  # along the commanded path (arc length of its closest point)
    lateral_m: float  # signed distance from the commanded path at the end, left positive
    gait_velocity: tuple[float, float, float]  # (vx, vy, yaw rate) from gait start, start frame


def commanded_direction(velocity: Velocity, heading_rad: float) -> np.ndarray | None:
    """Unit world-frame direction of the commanded (vx, vy) at `heading_rad`; None at v = 0."""
    speed = math.hypot(velocity.vx_m_s, velocity.vy_m_s)
    if speed <= 1e-9:
        return None
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    vx, vy = velocity.vx_m_s / speed, velocity.vy_m_s / speed
    return np.array([c * vx - s * vy, s * vx + c * vy])


def path_offset(
    velocity: Velocity, start_xy: np.ndarray, heading_rad: float, xy: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(distance along, signed lateral offset) of the track `xy` (K, 2) from the commanded path.

    The path starts at `start_xy` with heading `heading_rad`: the line along the commanded
    direction for ω = 0, else the circle of radius |v|/|ω| tangent to it there (centre on the
    left for ω > 0); the distance is the arc length to the closest point of the path, unwrapped
    along the track (so more than half a turn counts). At v = 0 there is no path: the distance is
    0 and the offset is the planar displacement.
    """
    d = np.atleast_2d(np.asarray(xy, dtype=float)) - np.asarray(start_xy, dtype=float)
    u = commanded_direction(velocity, heading_rad)
    if u is None:
        return np.zeros(len(d)), np.hypot(d[:, 0], d[:, 1])
    left = np.array([-u[1], u[0]])
    w = velocity.yaw_rate_rad_s
    speed = math.hypot(velocity.vx_m_s, velocity.vy_m_s)
    if abs(w) * 1e3 <= speed:  # radius above 1 km: a straight line to µm over metres
        return d @ u, d @ left
    radius = speed / abs(w)
    sign = math.copysign(1.0, w)
    centre = sign * radius * left  # relative to the start
    r = d - centre
    cross = -centre[0] * r[:, 1] + centre[1] * r[:, 0]  # (−centre) × r
    swept = sign * np.unwrap(np.arctan2(cross, r @ -centre))
    return radius * swept, sign * (radius - np.hypot(r[:, 0], r[:, 1]))


def _window_mean(t_s: np.ndarray, x: np.ndarray, start_s: float, end_s: float) -> float:
    """Mean of `x` over the samples with `start_s` < t ≤ `end_s` (the last sample if none)."""
    inside = (t_s > start_s) & (t_s <= end_s)
    return float(np.mean(x[inside])) if np.any(inside) else float(x[-1])


def run_path(traj: Trajectory, velocity: Velocity) -> RunPath:
    """`RunPath` of `traj`: everything measured from its first sample (the rest pose)."""
    yaw = np.unwrap(yaw_of(traj.base_quat))
    xy = traj.base_pos_m[:, :2]
    psi0 = float(yaw[0])
    g = min(int(np.searchsorted(traj.time_s, traj.gait_start_s - 1e-9)), len(yaw) - 1)
    # the gait's own velocity: to the end of its cycles (a blend-out to the stand after them
    # slows down and is judged by the path and heading over the whole run)
    e = min(int(np.searchsorted(traj.time_s, traj.gait_end_s + 1e-9)), len(yaw)) - 1
    gait_time = max(float(traj.time_s[e]) - float(traj.time_s[g]), 0.0)
    change = float(yaw[-1] - psi0)
    # yaw net of the commanded turn, averaged over one gait period (module docstring)
    t = traj.time_s
    off = yaw - psi0 - velocity.yaw_rate_rad_s * np.clip(
        t - traj.gait_start_s, 0.0, traj.gait_end_s - traj.gait_start_s)
    t_end = float(t[-1])
    heading = _window_mean(t, off, t_end - traj.period_s, t_end)
    entry = _window_mean(t, off, traj.gait_start_s, traj.gait_start_s + traj.period_s)
    along_m, lateral_m = path_offset(velocity, xy[0], psi0, xy)
    along, lateral = float(along_m[-1]), float(lateral_m[-1])
    c, s = math.cos(psi0), math.sin(psi0)
    if gait_time > 0:
        dx, dy = (xy[e] - xy[g]) / gait_time
        gait_v = (c * dx + s * dy, -s * dx + c * dy, float(yaw[e] - yaw[g]) / gait_time)
    else:
        gait_v = (0.0, 0.0, 0.0)
    return RunPath(
        heading_change_rad=change,
        heading_error_rad=heading,
        ramp_yaw_rad=entry,
        distance_m=along,
        lateral_m=lateral,
        gait_velocity=(float(gait_v[0]), float(gait_v[1]), float(gait_v[2])),
    )


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
    cmd = gait.velocity
    cmd_speed = math.hypot(cmd.vx_m_s, cmd.vy_m_s)
    path = run_path(traj, cmd)
    v = traj.base_linvel_m_s[w, :2]
    # commanded direction over the steady window: straight commands, the start heading (a turned
    # robot walks slower along it); turning commands, the robot's own heading — the yaw-rate
    # check judges the turn, and the start heading turned at the commanded rate would count
    # every yaw-rate error again, growing with the run (quad12's arc 15 % fast over 20 cycles
    # of 1.1 s: 2 rad off, 0.032 of its 0.1 m/s)
    if cmd.yaw_rate_rad_s != 0.0:
        heading_cmd = yaw[w]
    else:
        heading_cmd = np.full(len(t), float(yaw[0]))
    if cmd_speed > 1e-9:
        u = np.array([commanded_direction(cmd, float(h)) for h in heading_cmd])
        along = float(np.sum(np.einsum("ij,ij->i", v, u)) * dt)
        achieved = along / span
        speed_err: float | None = abs(achieved - cmd_speed) / cmd_speed
    else:
        disp = np.sum(v, axis=0) * dt
        along, speed_err = 0.0, None
        achieved = float(np.hypot(disp[0], disp[1])) / span
    yaw_drift = float(yaw[w][-1] - yaw[w][0]) - cmd.yaw_rate_rad_s * (span - dt)
    per_m = abs(along) >= MIN_DISTANCE_FOR_DRIFT_M
    run_per_m = abs(path.distance_m) >= MIN_DISTANCE_FOR_DRIFT_M
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
        commanded_vy_m_s=float(cmd.vy_m_s),
        commanded_yaw_rate_rad_s=float(cmd.yaw_rate_rad_s),
        achieved_speed_m_s=achieved,
        achieved_vx_m_s=path.gait_velocity[0],
        achieved_vy_m_s=path.gait_velocity[1],
        achieved_yaw_rate_rad_s=path.gait_velocity[2],
        speed_error_fraction=speed_err,
        distance_m=along,
        run_distance_m=path.distance_m,
        lateral_drift_m=path.lateral_m,
        lateral_drift_per_m=abs(path.lateral_m) / abs(path.distance_m) if run_per_m else None,
        heading_change_rad=path.heading_change_rad,
        heading_error_rad=path.heading_error_rad,
        ramp_yaw_rad=path.ramp_yaw_rad,
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
    lower = np.array([jt.lower_rad for jt in sim.robot.joints])
    upper = np.array([jt.upper_rad for jt in sim.robot.joints])
    clearance = limit_clearance_rad(traj.q_rad[w], lower, upper)
    joints = tuple(
        JointMetrics(
            name=name,
            peak_torque_fraction=float(tau_frac[:, j].max()),
            rms_torque_fraction=float(np.sqrt(np.mean(tau_frac[:, j] ** 2))),
            tracking_rms_rad=float(np.sqrt(np.mean(err[:, j] ** 2))),
            tracking_max_rad=float(np.abs(err[:, j]).max()),
            peak_speed_rad_s=float(np.abs(traj.qd_rad_s[w, j]).max()),
            limit_clearance_rad=float(clearance[j]),
            limit_clearance_fraction=float(clearance[j] / (upper[j] - lower[j])),
        )
        for j, name in enumerate(sim.robot.joint_names)
    )
    return metrics, joints

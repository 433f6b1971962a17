"""The closed-loop MuJoCo rollout of `gaitsmith drive-sim`: a path followed through a gait library.

The robot starts at rest in its nominal stance at the path's start, facing along it, on flat
ground (the `sim.model` servo model and sensors, as in validation). Every control tick (the
player's stream rate, 100 Hz by default):

1. the measured base pose (world-frame position and yaw of the root body, from the ``gs_base_*``
   sensors) goes to the controller (`sim.path.pursuit`), which picks a command inside the
   library's box — zero while settling at the start and once the end is reached;
2. `robots.blend.GaitBlender.step(command, dt)` turns it into joint targets (acceleration
   limits, stand ↔ walk transitions, per-tick joint-speed clip): exactly what the player's drive
   mode streams to the servos;
3. with `FollowSettings.attitude` (closed loop) the simulated IMU (`sim.attitude_loop`) is read
   and the attitude law's offsets for the blend are added to the targets (`_Feedback`), as
   `gaitsmith-play drive` adds them before its SafetyGate;
4. the targets reach the servos after `latency_s` plus each servo's own identified delay
   (`SimModel.servo_latency_s`; a delay line of whole ticks) and are held over the tick's
   physics steps (zero-order hold).

The run ends `end_hold_s` after the blender is back in the stand at the end, a short while after
a fall (so it shows), or at the timeout. Peak servo torque is tracked over every physics step;
the rest is logged once per tick (`FollowLog`), enough for metrics, plots and video.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from robots.attitude import AttitudeMap, blended_offsets
from robots.blend import BlendLimits, GaitBlender
from robots.gait import Velocity
from robots.library import GaitLibrary
from robots.robot import Robot
from robots.servo_params import ServoSetting
from sim.attitude_loop import AttitudeSettings, SimulatedImu
from sim.errors import SimConfigError, SimDivergedError
from sim.metrics import CONTACT_FORCE_FRACTION, GRAVITY_M_S2, FallThresholds, tilt_of, yaw_of
from sim.model import SimConditions, SimModel, build_sim_model
from sim.path.pursuit import PurePursuit, PursuitSettings
from sim.path.spec import PlannedPath
from sim.servo import DEFAULT_RATE_HZ

#: (simulated time [s], progress along the path [m], total path length to drive [m])
FollowProgress = Callable[[float, float, float], None]

#: command accelerations scale with the robot: ACCEL_LEG_LENGTHS_PER_S2 · L [m/s²], and the
#: same number in rad/s² for the yaw rate (feet about a leg length from the turning centre then
#: see the same tangential acceleration). Measured on hex18 (tripod library, 6 entries whose own
#: validation peaks at 52-59 % of stall): 1.0 L/s² put a tibia at 72-79 % of stall while the gait
#: grew in and sped up at once; 0.37 L/s² kept the walking peak at 55 %.
ACCEL_LEG_LENGTHS_PER_S2 = 0.4
#: the controller brakes for the end of the path at this share of the blender's acceleration
BRAKE_FRACTION = 0.8
FALL_SHOW_S = 1.0  # simulated time kept after a fall is first seen


@dataclass(frozen=True)
class FollowSettings:
    rate_hz: float = DEFAULT_RATE_HZ
    latency_s: float = 0.0
    settle_s: float = 0.5  # standing still at the start before the first command
    end_hold_s: float = 1.0  # standing at the end before the run stops
    laps: int = 1
    accel_m_s2: float | None = None  # None: ACCEL_LEG_LENGTHS_PER_S2 · leg length
    yaw_accel_rad_s2: float | None = None  # None: ACCEL_LEG_LENGTHS_PER_S2 rad/s²
    timeout_factor: float = 3.0  # × (path length / cruise speed) + 30 s before giving up
    pursuit: PursuitSettings = field(default_factory=PursuitSettings)
    falls: FallThresholds = field(default_factory=FallThresholds)
    #: closed-loop attitude feedback (`sim.attitude_loop`; None or gain 0: open loop)
    attitude: AttitudeSettings | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and 1.0 <= self.rate_hz <= 10_000.0):
            raise SimConfigError(f"control rate must be in [1, 10000] Hz, got {self.rate_hz!r}")
        if not (math.isfinite(self.latency_s) and 0.0 <= self.latency_s <= 1.0):
            raise SimConfigError(f"latency must be in [0, 1] s, got {self.latency_s!r}")
        for name in ("settle_s", "end_hold_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 <= v <= 60.0):
                raise SimConfigError(f"{name} must be in [0, 60] s, got {v!r}")
        for name in ("accel_m_s2", "yaw_accel_rad_s2"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise SimConfigError(f"{name} must be positive, got {v!r}")
        if not (math.isfinite(self.timeout_factor) and self.timeout_factor >= 1.0):
            raise SimConfigError("timeout_factor must be ≥ 1")


@dataclass(frozen=True, eq=False)
class FollowLog:
    """One drive-sim run, logged once per control tick (arrays have the tick count K first)."""

    path: PlannedPath
    laps: int
    leg_length_m: float
    time_s: np.ndarray  # (K,) time at the end of the tick
    base_pos_m: np.ndarray  # (K, 3) world frame
    yaw_rad: np.ndarray  # (K,) unwrapped
    tilt_rad: np.ndarray  # (K,)
    qpos: np.ndarray  # (K, nq) for rendering
    requested: np.ndarray  # (K, 3) the controller's command (vx, vy, yaw rate)
    commanded: np.ndarray  # (K, 3) the blender's command after limits (0 when not walking)
    targets_rad: np.ndarray  # (K, J) sent to the servos
    q_rad: np.ndarray  # (K, J) measured
    progress_m: np.ndarray  # (K,) arc length reached (unwrapped over laps)
    cross_track_m: np.ndarray  # (K,) signed (robot left of the path +)
    heading_error_rad: np.ndarray  # (K,)
    driving: np.ndarray  # (K,) bool: the controller was steering (after settling, before arriving)
    standing: np.ndarray  # (K,) bool: the blender at rest in the stand
    foot_pos_m: np.ndarray  # (K, F, 3)
    foot_down: np.ndarray  # (K, F) bool
    tick_torque_nm: np.ndarray  # (K, J) max |τ| over the tick's physics steps
    peak_torque_nm: np.ndarray  # (J,) max |τ| over every physics step
    stall_torque_nm: np.ndarray  # (J,)
    drive_start_s: float
    arrived_s: float | None  # when the controller reached the end (None: never)
    fell: bool
    fall_time_s: float | None
    fall_reason: str | None
    timed_out: bool
    command_clipped_ticks: int  # ticks whose request lay outside the box (clipped by the blender)
    attitude_gain: float = 0.0  # the attitude feedback's gain (0: open loop)
    attitude_offset_max_rad: float = 0.0  # the largest |offset| the feedback added to a target
    attitude_clipped_ticks: int = 0  # ticks where an offset sat at the law's clip

    @property
    def n_ticks(self) -> int:
        return len(self.time_s)

    @property
    def total_length_m(self) -> float:
        return self.path.length_m * self.laps

    def footprints(self) -> list[tuple[float, int, float, float]]:
        """(time, foot index, x, y) of every touchdown (a foot going from up to down)."""
        down = self.foot_down
        out: list[tuple[float, int, float, float]] = []
        for f in range(down.shape[1]):
            starts = np.flatnonzero(down[1:, f] & ~down[:-1, f]) + 1
            if down.shape[0] and down[0, f]:
                starts = np.concatenate([[0], starts])
            for k in starts:
                out.append((float(self.time_s[k]), f, float(self.foot_pos_m[k, f, 0]),
                            float(self.foot_pos_m[k, f, 1])))
        out.sort()
        return out


def _start_state(sim: SimModel, x_m: float, y_m: float, yaw_rad: float) -> mujoco.MjData:
    """At rest in the nominal stance at (x, y) facing `yaw_rad`, feet just touching the floor."""
    model, robot = sim.model, sim.robot
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0:3] = (x_m, y_m, robot.stance_base_height_m + 5e-4)
    data.qpos[3:7] = (math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2))
    data.qpos[sim.qpos_adr] = robot.nominal_stance_rad
    mujoco.mj_forward(model, data)
    return data


def blend_limits(robot: Robot, settings: FollowSettings) -> BlendLimits:
    """The blender's limits for `robot`: servo speeds and joint limits, scaled accelerations."""
    accel = settings.accel_m_s2
    if accel is None:
        accel = ACCEL_LEG_LENGTHS_PER_S2 * robot.leg_length_m
    yaw_accel = settings.yaw_accel_rad_s2
    if yaw_accel is None:
        yaw_accel = ACCEL_LEG_LENGTHS_PER_S2
    return BlendLimits.for_robot(robot, accel, yaw_accel)


def follow(
    library: GaitLibrary,
    robot: Robot,
    path: PlannedPath,
    settings: FollowSettings = FollowSettings(),
    *,
    conditions: SimConditions = SimConditions(),
    servo_settings: Sequence[ServoSetting] | None = None,
    progress: FollowProgress | None = None,
) -> tuple[SimModel, FollowLog]:
    """Drive `path` (`settings.laps` times if closed) with `library` on `robot` in MuJoCo;
    `servo_settings`: the identified servos (`robots.servo_params`; None: the catalogue's)."""
    library.check_robot(robot)
    sim = build_sim_model(robot, conditions, servo_settings=servo_settings)
    model = sim.model
    limits = blend_limits(robot, settings)
    stance = np.asarray(robot.nominal_stance_rad, dtype=float)
    blender = GaitBlender(library, limits, start_rad=stance)
    bounds = library.command_bounds()
    pursuit = replace(settings.pursuit, decel_m_s2=min(settings.pursuit.decel_m_s2,
                                                       BRAKE_FRACTION * limits.accel_m_s2))
    ctrl = PurePursuit(path, bounds, robot.leg_length_m, pursuit, settings.laps)
    start_xy = path.point_at(0.0)
    data = _start_state(sim, float(start_xy[0]), float(start_xy[1]),
                        float(path.heading_at(0.0)))
    dt = float(model.opt.timestep)
    substeps = max(1, round(1.0 / (settings.rate_hz * dt)))
    tick_s = substeps * dt
    delay_ticks = np.round((settings.latency_s + sim.servo_latency_s) / tick_s).astype(int)
    history: deque[np.ndarray] = deque([stance.copy()] * (int(delay_ticks.max()) + 1),
                                       maxlen=int(delay_ticks.max()) + 1)
    joint_cols = np.arange(robot.dof)
    data.ctrl[:] = stance
    feedback = _Feedback.of(settings.attitude, library, robot, model, data, limits)

    def cols(prefix: str, names: tuple[str, ...]) -> np.ndarray:
        return np.concatenate([np.arange(model.nsensordata)[sim.sensors[f"{prefix}{n}"]]
                               for n in names])

    feet = robot.foot_names
    drive_idx = cols("gs_drive_", robot.joint_names)
    qd_idx = cols("gs_qd_", robot.joint_names)
    q_idx = cols("gs_q_", robot.joint_names)
    contact_idx = [np.arange(model.nsensordata)[sim.sensors[f"gs_foot_contact_{f}"]]
                   for f in feet]
    foot_idx = [np.arange(model.nsensordata)[sim.sensors[f"gs_foot_pos_{f}"]] for f in feet]
    base_pos, base_quat = sim.sensors["gs_base_pos"], sim.sensors["gs_base_quat"]
    robot_contacts = sim.sensors["gs_robot_contacts"].start
    back_emf = sim.back_emf_nm_s_per_rad
    down_force_n = CONTACT_FORCE_FRACTION * sim.mass_kg * GRAVITY_M_S2
    th = settings.falls
    low_m = th.min_height_fraction * robot.stance_base_height_m

    cruise = ctrl.cruise_m_s
    t_limit = (settings.settle_s + settings.timeout_factor * ctrl.total_m / cruise + 30.0)
    logs: dict[str, list[np.ndarray | float | bool]] = {k: [] for k in (
        "t", "pos", "yaw", "tilt", "qpos", "req", "cmd", "tgt", "q", "s", "e", "h", "drv",
        "stand", "fpos", "fdown", "tau")}
    peak = np.zeros(robot.dof)
    t = 0.0
    arrived: float | None = None
    fall: tuple[float, str] | None = None
    clipped = 0
    timed_out = False
    stand_since: float | None = None
    while True:
        sd = data.sensordata
        pos = sd[base_pos].copy()
        quat = sd[base_quat].copy()
        yaw = float(yaw_of(quat))
        driving = t >= settings.settle_s and arrived is None
        st = ctrl.step(float(pos[0]), float(pos[1]), yaw)
        if driving and st.finished:
            arrived, driving = t, False
        command = st.command if driving else Velocity()
        targets = blender.step(command, tick_s)
        if feedback is not None:
            targets = feedback.corrected(blender, targets, t)
        clipped += int(blender.command_clipped)
        history.append(targets)
        data.ctrl[:] = np.stack(history)[-1 - delay_ticks, joint_cols]
        tick_peak = np.zeros(robot.dof)
        for _ in range(substeps):
            mujoco.mj_step(model, data)
            if feedback is not None:
                feedback.imu.record(np.array([data.time]), data.qpos[None, 3:7])
            tau = np.abs(data.sensordata[drive_idx] - back_emf * data.sensordata[qd_idx])
            np.maximum(tick_peak, tau, out=tick_peak)
        np.maximum(peak, tick_peak, out=peak)
        t += tick_s
        sd = data.sensordata
        if not np.all(np.isfinite(data.qpos)):
            raise SimDivergedError(f"physics diverged (NaN) near t = {t:.3f} s")
        contacts = np.array([sd[c[0]] for c in contact_idx])
        forces = np.array([np.linalg.norm(sd[c[1:4]]) for c in contact_idx])
        down = (contacts > 0) & (forces >= down_force_n)
        c = blender.command
        for key, value in (
            ("t", t), ("pos", sd[base_pos].copy()), ("yaw", float(yaw_of(sd[base_quat]))),
            ("tilt", float(tilt_of(sd[base_quat]))), ("qpos", data.qpos.copy()),
            ("req", np.array([command.vx_m_s, command.vy_m_s, command.yaw_rate_rad_s])),
            ("cmd", np.array([c.vx_m_s, c.vy_m_s, c.yaw_rate_rad_s])), ("tgt", targets),
            ("q", sd[q_idx].copy()), ("s", st.progress_m), ("e", st.cross_track_m),
            ("h", st.heading_error_rad), ("drv", driving), ("stand", blender.standing),
            ("fpos", np.stack([sd[i] for i in foot_idx])), ("fdown", down),
            ("tau", tick_peak),
        ):
            logs[key].append(value)
        if fall is None:
            why = None
            if sd[robot_contacts] > contacts.sum() + 0.5:
                why = "body touched the ground"
            elif sd[base_pos][2] < low_m:
                why = f"base dropped below {th.min_height_fraction:.0%} of stance height"
            elif float(tilt_of(sd[base_quat])) > th.max_tilt_rad:
                why = f"tilted beyond {math.degrees(th.max_tilt_rad):.0f}°"
            if why is not None:
                fall = (t, why)
        if progress is not None and len(logs["t"]) % 50 == 0:
            progress(t, st.progress_m, ctrl.total_m)
        if fall is not None and t >= fall[0] + FALL_SHOW_S:
            break
        if arrived is not None and blender.standing:
            stand_since = t if stand_since is None else stand_since
            if t >= stand_since + settings.end_hold_s:
                break
        if t >= t_limit:
            timed_out = arrived is None
            break
    if progress is not None:
        progress(t, ctrl.progress_m, ctrl.total_m)
    yaw_log = np.unwrap(np.asarray(logs["yaw"], dtype=float))
    return sim, FollowLog(
        path=path,
        laps=settings.laps,
        leg_length_m=robot.leg_length_m,
        time_s=np.asarray(logs["t"], dtype=float),
        base_pos_m=np.asarray(logs["pos"], dtype=float),
        yaw_rad=yaw_log,
        tilt_rad=np.asarray(logs["tilt"], dtype=float),
        qpos=np.asarray(logs["qpos"], dtype=float),
        requested=np.asarray(logs["req"], dtype=float),
        commanded=np.asarray(logs["cmd"], dtype=float),
        targets_rad=np.asarray(logs["tgt"], dtype=float),
        q_rad=np.asarray(logs["q"], dtype=float),
        progress_m=np.asarray(logs["s"], dtype=float),
        cross_track_m=np.asarray(logs["e"], dtype=float),
        heading_error_rad=np.asarray(logs["h"], dtype=float),
        driving=np.asarray(logs["drv"], dtype=bool),
        standing=np.asarray(logs["stand"], dtype=bool),
        foot_pos_m=np.asarray(logs["fpos"], dtype=float),
        foot_down=np.asarray(logs["fdown"], dtype=bool),
        tick_torque_nm=np.asarray(logs["tau"], dtype=float),
        peak_torque_nm=peak,
        stall_torque_nm=sim.stall_torque_nm,
        drive_start_s=settings.settle_s,
        arrived_s=arrived,
        fell=fall is not None,
        fall_time_s=None if fall is None else fall[0],
        fall_reason=None if fall is None else fall[1],
        timed_out=timed_out,
        command_clipped_ticks=clipped,
        attitude_gain=0.0 if feedback is None else feedback.law.gain,
        attitude_offset_max_rad=0.0 if feedback is None else feedback.offset_max_rad,
        attitude_clipped_ticks=0 if feedback is None else feedback.clipped_ticks,
    )


class _Feedback:
    """The attitude feedback of a closed-loop drive: the simulated IMU (`sim.attitude_loop`)
    read each tick, the law on the blend the blender played (`robots.attitude.blended_offsets`:
    the entries' reference roll/pitch and support weights with the blender's weights, at its
    phase, faded by its entry/exit weight α — zero while it stands or ramps, as in
    `gaitsmith-play drive`), the corrected targets clipped to the joint limits (the player's
    SafetyGate does the same)."""

    def __init__(self, settings: AttitudeSettings, library: GaitLibrary, amap: AttitudeMap,
                 limits: BlendLimits) -> None:
        self.law = settings.law
        self.imu = SimulatedImu(settings.imu)
        self.amap = amap
        self.gaits = [e.gait for e in library.entries]
        self.limits = limits
        self.offset_max_rad = 0.0
        self.clipped_ticks = 0

    @staticmethod
    def of(settings: AttitudeSettings | None, library: GaitLibrary, robot: Robot,
           model: mujoco.MjModel, data: mujoco.MjData, limits: BlendLimits) -> _Feedback | None:
        if settings is None or settings.law.gain == 0.0:
            return None
        from robots.attitude_maps import attitude_map

        out = _Feedback(settings, library, attitude_map(robot, model), limits)
        out.imu.record(np.array([data.time]), data.qpos[None, 3:7])
        return out

    def corrected(self, blender: GaitBlender, targets: np.ndarray, t_s: float) -> np.ndarray:
        """`targets` of the tick sent at run time `t_s` plus the law's offsets."""
        idx, w = blender.entry_weights
        off = blended_offsets(self.law, self.amap, [self.gaits[i] for i in idx], w,
                              self.imu.measured(t_s), blender.blend_weight, blender.phase)
        peak = float(np.max(np.abs(off))) if off.size else 0.0
        self.offset_max_rad = max(self.offset_max_rad, peak)
        self.clipped_ticks += int(peak >= self.law.max_offset_rad - 1e-12)
        q = targets + off
        if self.limits.lower_rad is not None and self.limits.upper_rad is not None:
            q = np.clip(q, self.limits.lower_rad, self.limits.upper_rad)
        return np.asarray(q)

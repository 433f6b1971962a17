"""One validation run: rest → hold → ramp-in → the gait's cycles, on flat ground.

The player's target stream is open-loop (a function of time only), so the whole control sequence
is computed up front: stance hold for `settle_s`, the shared `robots.ramp.gait_entry` (min-jerk
move to the gait's mean pose, `stand_s` held there — the stand —, then the gait blended in over
whole cycles, ending at its phase 0), then `gait.joint_targets(t)`, and with `end_at_stand` the
player's normal ending: the gait blended out to the stand (`robots.ramp.gait_exit`) and the stand
held `stand_s`; sampled at the stream rate, held and delayed by
`sim.servo.held_targets`. The physics runs natively (`mujoco.rollout`) one gait cycle at a time so
a fall can stop the run early and progress can be reported.

With `RunSettings.attitude` (IMU feedback, `sim.attitude_loop`) the stream is no longer a function
of time only: each cycle is rolled out one stream tick at a time, and before a tick's goals are
held and delayed the loop reads the simulated IMU and adds the law's offsets to them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import mujoco
import mujoco.rollout
import numpy as np

from robots.gait import Gait
from robots.ramp import GaitEntry, GaitExit, gait_entry, gait_exit, min_jerk
from robots.robot import Robot
from robots.sole import sole_pose_world
from sim.attitude_loop import AttitudeLoop, AttitudeSettings, RunClock
from sim.errors import SimConfigError, SimDivergedError
from sim.model import SimModel
from sim.servo import DEFAULT_RATE_HZ, held_targets

Progress = Callable[[int, int], None]  # (steps done, steps total)
RAMP_SPEED_FRACTION = 0.5  # ramp-in peak joint speed ≤ this fraction of the servo's no-load speed


@dataclass(frozen=True)
class RunSettings:
    cycles: int = 20
    rate_hz: float = DEFAULT_RATE_HZ
    latency_s: float = 0.0
    settle_s: float = 0.25  # servos on, holding the stance, before the ramp starts
    ramp_min_s: float = 1.0
    stand_s: float = 0.0  # hold at the gait's stand (mean pose) after the ramp, and at the end
    end_at_stand: bool = False  # after the cycles, blend out to the stand as the player does
    attitude: AttitudeSettings | None = None  # closed-loop IMU feedback (sim.attitude_loop)

    @property
    def attitude_gain(self) -> float:
        return 0.0 if self.attitude is None else self.attitude.law.gain

    def __post_init__(self) -> None:
        if not (isinstance(self.cycles, int) and self.cycles >= 1):
            raise SimConfigError(f"cycles must be a positive integer, got {self.cycles!r}")
        if not (math.isfinite(self.rate_hz) and 1.0 <= self.rate_hz <= 10_000.0):
            raise SimConfigError(f"stream rate must be in [1, 10000] Hz, got {self.rate_hz!r}")
        if not (math.isfinite(self.latency_s) and 0.0 <= self.latency_s <= 1.0):
            raise SimConfigError(f"latency must be in [0, 1] s, got {self.latency_s!r}")
        if not (math.isfinite(self.settle_s) and self.settle_s >= 0):
            raise SimConfigError("settle_s must be ≥ 0")
        if not (math.isfinite(self.ramp_min_s) and self.ramp_min_s > 0):
            raise SimConfigError("ramp_min_s must be positive")
        if not (math.isfinite(self.stand_s) and 0 <= self.stand_s <= 60.0):
            raise SimConfigError(f"stand_s must be in [0, 60] s, got {self.stand_s!r}")


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Per-physics-step log of one run (arrays have the step count T as first axis)."""

    time_s: np.ndarray  # (T,) time at the end of each step
    gait_start_s: float
    ramp: GaitEntry  # hold → ramp-in → blend; the gait proper starts at gait_start_s
    period_s: float
    cycles_run: int
    stopped_early: bool
    goal_rad: np.ndarray  # (T, J) goal the servo held during the step (held + delayed)
    planned_rad: np.ndarray  # (T, J) the stream's value at that time, undelayed
    expected_rad: np.ndarray  # (T, J) angles the servos should reach (≠ stream for servo goals)
    q_rad: np.ndarray  # (T, J)
    qd_rad_s: np.ndarray  # (T, J)
    drive_nm: np.ndarray  # (T, J) clipped position-loop torque
    torque_nm: np.ndarray  # (T, J) servo output torque (drive − back-EMF)
    base_pos_m: np.ndarray  # (T, 3)
    base_quat: np.ndarray  # (T, 4) w, x, y, z
    base_linvel_m_s: np.ndarray  # (T, 3) world frame
    foot_pos_m: np.ndarray  # (T, F, 3)
    foot_slip_speed_m_s: np.ndarray  # (T, F) horizontal speed of the foot sphere's lowest point
    foot_force_n: np.ndarray  # (T, F) net contact force magnitude
    foot_contacts: np.ndarray  # (T, F) number of foot–ground contacts
    robot_contacts: np.ndarray  # (T,) number of robot–ground contacts (all geoms)
    qpos: np.ndarray  # (T, nq) for rendering
    gait_end_s: float = math.inf  # end of the gait's cycles (then the blend-out, if any)
    attitude_gain: float = 0.0  # the IMU feedback's gain G (0: open loop; sim.attitude_loop)

    @property
    def dt_s(self) -> float:
        return (
            float(self.time_s[1] - self.time_s[0])
            if len(self.time_s) > 1
            else float(self.time_s[0])
        )

    @property
    def n_steps(self) -> int:
        return len(self.time_s)

    def gait_phase(self) -> np.ndarray:
        """Gait phase in cycles since the gait started (negative during hold and ramp)."""
        return (self.time_s - self.gait_start_s) / self.period_s

    def flight_fraction(self, from_cycle: float = 2.0) -> float:
        """Measured share of the gait's steps, from `from_cycle` cycles after the gait started
        to the end of its cycles, with no foot touching the ground (NaN: no such step)."""
        steady = (self.gait_phase() >= from_cycle) & (self.time_s <= self.gait_end_s)
        if not np.any(steady):
            return math.nan
        airborne = ~np.any(self.foot_contacts[steady] > 0, axis=1)
        return float(np.mean(airborne))


@dataclass(frozen=True, eq=False)
class RunPlan:
    """When each part of a run happens [s]: hold, entry, the gait's cycles, the ending."""

    entry: GaitEntry
    settle_s: float
    gait_start_s: float
    gait_end_s: float
    exit: GaitExit | None  # the blend-out to the stand (None: the run ends with the cycles)
    end_s: float


def run_plan(gait: Gait, sim: SimModel, settings: RunSettings) -> RunPlan:
    robot = sim.robot
    stance = np.asarray(robot.nominal_stance_rad, dtype=float)
    speed = RAMP_SPEED_FRACTION * np.array([j.servo.no_load_speed_rad_s for j in robot.joints])
    entry = gait_entry(gait, stance, speed, settings.ramp_min_s)
    if settings.stand_s > 0:
        entry = replace(entry, hold_s=settings.stand_s)
    settle = _settle_s(entry, settings)
    gait_start = settle + entry.duration_s
    gait_end = gait_start + settings.cycles * gait.period_s
    exit_ = None
    end = gait_end
    if settings.end_at_stand:
        exit_ = gait_exit(gait, settings.cycles * gait.period_s, speed)
        end = gait_end + exit_.duration_s + settings.stand_s
    return RunPlan(entry, settle, gait_start, gait_end, exit_, end)


def stream_targets(
    gait: Gait, sim: SimModel, settings: RunSettings
) -> tuple[np.ndarray, GaitEntry, float]:
    """The player's target stream at `rate_hz` for the whole run: (K, J), ramp, gait start [s]."""
    plan = run_plan(gait, sim, settings)
    stance = np.asarray(sim.robot.nominal_stance_rad, dtype=float)
    tick = 1.0 / settings.rate_hz
    t = np.arange(math.ceil(plan.end_s / tick - 1e-9) + 1) * tick
    out = reference(gait, stance, plan.entry, plan.settle_s, plan.gait_start_s, t,
                    ending=plan)
    return out, plan.entry, plan.gait_start_s


def _settle_s(entry: GaitEntry, settings: RunSettings) -> float:
    """The stance hold, stretched (< one tick) so that the min-jerk ramp ends on a tick and the
    blend starts there, as in the player (whose gait then follows the blend without a pause)."""
    tick = 1.0 / settings.rate_hz
    ramp_end = math.ceil((settings.settle_s + entry.ramp.duration_s) / tick - 1e-9) * tick
    return ramp_end - entry.ramp.duration_s


def reference(
    gait: Gait,
    stance_rad: np.ndarray,
    ramp: GaitEntry,
    settle_s: float,
    gait_start_s: float,
    t_s: np.ndarray,
    expected: bool = False,
    ending: RunPlan | None = None,
) -> np.ndarray:
    """The player's targets at times `t_s`: stance hold, then the ramp, then the gait, then
    (`ending` with an exit) the blend-out to the stand and the stand.

    With `expected`, the gait part is the angles the servos should reach
    (`Gait.expected_joint_angles`) instead of the goals streamed to them.
    """
    t = np.asarray(t_s, dtype=float)
    out = np.empty((len(t), len(stance_rad)))
    hold = t < settle_s
    in_ramp = (~hold) & (t < gait_start_s)
    in_gait = t >= gait_start_s
    out[hold] = stance_rad
    out[in_ramp] = ramp.positions(t[in_ramp] - settle_s)
    if np.any(in_gait):
        curve = gait.expected_joint_angles if expected else gait.joint_targets
        out[in_gait] = curve(t[in_gait] - gait_start_s)
    if ending is not None and ending.exit is not None:
        after = t > ending.gait_end_s
        if np.any(after):
            ex = ending.exit
            t_exit = np.clip(t[after] - ending.gait_end_s, 0.0, ex.duration_s)
            curve = gait.expected_joint_angles if expected else gait.joint_targets
            keep = 1.0 - min_jerk(t_exit / ex.duration_s)[:, None]
            mean = ex.mean_rad
            out[after] = mean + keep * (curve(ex.start_gait_s + t_exit) - mean)
    return out


def stream_latency_s(settings: RunSettings, sim: SimModel) -> float | np.ndarray:
    """The goals' delay: the stream's, plus each servo's own (identified) where it has one."""
    own = sim.servo_latency_s
    return settings.latency_s + own if np.any(own > 0) else settings.latency_s


def run(
    gait: Gait,
    sim: SimModel,
    settings: RunSettings = RunSettings(),
    *,
    progress: Progress | None = None,
    stop: Callable[[np.ndarray, SimModel], bool] | None = None,
) -> Trajectory:
    """Simulate the run; `stop(sensordata_chunk, sim)` may end it after any cycle (e.g. a fall)."""
    model = sim.model
    dt = float(model.opt.timestep)
    stream, _, gait_start = stream_targets(gait, sim, settings)
    plan = run_plan(gait, sim, settings)
    stance = np.asarray(sim.robot.nominal_stance_rad, dtype=float)
    gait_total = round((gait_start + settings.cycles * gait.period_s) / dt)
    total = round(plan.end_s / dt)
    ramp_steps = round(gait_start / dt)
    cycle_steps = max(1, round(gait.period_s / dt))
    bounds = [0, ramp_steps] + [
        min(gait_total, ramp_steps + c * cycle_steps) for c in range(1, settings.cycles + 1)
    ]
    bounds[-1] = gait_total
    bounds.append(total)
    bounds = sorted(set(b for b in bounds if b > 0))
    data = mujoco.MjData(model)
    state = sim.initial_state()
    loop = _attitude_loop(gait, sim, settings, plan)
    if loop is not None:
        stream = stream.copy()  # each tick's goals get the offsets as the run reaches it
    latency = stream_latency_s(settings, sim)
    states, sensors = [], []
    start, stopped, tick = 0, False, 0
    for end in bounds:
        if loop is None:
            ctrl = held_targets(stream, rate_hz=settings.rate_hz, latency_s=latency, dt_s=dt,
                                n_steps=end - start, initial_rad=stance, first_step=start)
            st, sd = mujoco.rollout.rollout(model, data, state[None], ctrl[None])
            st, sd = st[0], sd[0]
        else:  # one stream tick at a time: the IMU is read and the tick's goals corrected
            parts_st, parts_sd = [], []
            s0 = start
            while s0 < end:
                while tick < len(stream) and tick / settings.rate_hz <= s0 * dt + 1e-9:
                    stream[tick] += loop.correct(tick / settings.rate_hz)
                    tick += 1
                s1 = min(end, max(s0 + 1, math.ceil(tick / settings.rate_hz / dt - 1e-9)))
                ctrl = held_targets(stream, rate_hz=settings.rate_hz, latency_s=latency,
                                    dt_s=dt, n_steps=s1 - s0, initial_rad=stance, first_step=s0)
                st, sd = mujoco.rollout.rollout(model, data, state[None], ctrl[None])
                st, sd = st[0], sd[0]
                loop.record(st[:, 0], st[:, 4:8])
                parts_st.append(st)
                parts_sd.append(sd)
                state = st[-1].copy()
                if not np.all(np.isfinite(state)):
                    break
                s0 = s1
            st, sd = np.concatenate(parts_st), np.concatenate(parts_sd)
        if not (np.all(np.isfinite(st[-1])) and np.all(np.isfinite(sd[-1]))):
            raise SimDivergedError(f"physics diverged (NaN) near t = {st[-1, 0]:.3f} s")
        states.append(st)
        sensors.append(sd)
        state = st[-1].copy()
        start = end
        if progress is not None:
            progress(end, total)
        if stop is not None and stop(sd, sim):
            stopped = end < total
            break
    st_all, sd_all = np.concatenate(states), np.concatenate(sensors)
    return _trajectory(gait, sim, settings, stream, plan, st_all, sd_all, stopped)


def _attitude_loop(gait: Gait, sim: SimModel, settings: RunSettings,
                   plan: RunPlan) -> AttitudeLoop | None:
    """The run's attitude loop (None: open loop, or a gain of 0)."""
    if settings.attitude is None or settings.attitude.law.gain == 0.0:
        return None
    if sim.conditions.lifted:
        raise SimConfigError("attitude feedback needs the robot on the ground (not lifted)")
    from robots.attitude_maps import attitude_map

    clock = RunClock(plan.settle_s, plan.entry, plan.gait_end_s, plan.exit)
    return AttitudeLoop(settings.attitude, attitude_map(sim.robot, sim.model), gait, clock)


def _sole_centre_velocity(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    robot: Robot,
    flat: list[int],
    site_pos: np.ndarray,
    site_vel: np.ndarray,
    site_w: np.ndarray,
) -> np.ndarray:
    """(T, len(flat), 2) horizontal world velocity of the flat feet's sole centres,
    v_site + ω × (p_sole − p_site), from the foot-site sensors and the recorded qpos."""
    data = mujoco.MjData(model)
    offset = np.zeros((len(qpos), len(flat), 3))
    for t, qp in enumerate(qpos):
        data.qpos[:] = qp
        mujoco.mj_kinematics(model, data)
        for i, f in enumerate(flat):
            offset[t, i] = sole_pose_world(model, data, robot.legs[f])[0] - site_pos[t, f]
    return (site_vel[:, flat] + np.cross(site_w[:, flat], offset))[..., :2]


def _trajectory(
    gait: Gait,
    sim: SimModel,
    settings: RunSettings,
    stream: np.ndarray,
    plan: RunPlan,
    st: np.ndarray,
    sd: np.ndarray,
    stopped: bool,
) -> Trajectory:
    ramp, gait_start = plan.entry, plan.gait_start_s
    robot, model = sim.robot, sim.model
    n = len(st)
    dt = float(model.opt.timestep)
    time_s = st[:, 0]
    qpos = st[:, 1 : 1 + model.nq]
    stance = np.asarray(robot.nominal_stance_rad, dtype=float)
    goal = held_targets(
        stream,
        rate_hz=settings.rate_hz,
        latency_s=stream_latency_s(settings, sim),
        dt_s=dt,
        n_steps=n,
        initial_rad=stance,
    )
    settle = _settle_s(ramp, settings)
    planned = reference(gait, stance, ramp, settle, gait_start, time_s, ending=plan)
    expected = reference(gait, stance, ramp, settle, gait_start, time_s, expected=True,
                         ending=plan)

    def cols(prefix: str, names: tuple[str, ...]) -> np.ndarray:
        return np.stack([sim.sensor(sd, f"{prefix}{x}") for x in names], axis=1)

    joints, feet = robot.joint_names, robot.foot_names
    q, qd = cols("gs_q_", joints)[..., 0], cols("gs_qd_", joints)[..., 0]
    drive = cols("gs_drive_", joints)[..., 0]
    torque = drive - sim.back_emf_nm_s_per_rad * qd
    foot_pos = cols("gs_foot_pos_", feet)
    foot_vel = cols("gs_foot_vel_", feet)
    foot_w = cols("gs_foot_angvel_", feet)
    # velocity of the sphere's lowest point: v + ω × (−r ẑ) = v + r·(−ω_y, ω_x, 0)
    r = robot.foot_radius_m
    slip_xy = foot_vel[..., :2] + r * np.stack([-foot_w[..., 1], foot_w[..., 0]], axis=-1)
    flat = [f for f, leg in enumerate(robot.legs) if leg.is_flat]
    if flat:  # a flat foot slips where its sole centre moves (robots.sole)
        slip_xy[:, flat] = _sole_centre_velocity(
            model, qpos, robot, flat, foot_pos, foot_vel, foot_w
        )
    contact = cols("gs_foot_contact_", feet)
    return Trajectory(
        time_s=time_s,
        gait_start_s=gait_start,
        ramp=ramp,
        period_s=gait.period_s,
        cycles_run=min(settings.cycles, int(max(0.0, math.floor(
            (time_s[-1] + dt - gait_start) / gait.period_s)))),
        stopped_early=stopped,
        goal_rad=goal,
        planned_rad=planned,
        expected_rad=expected,
        q_rad=q,
        qd_rad_s=qd,
        drive_nm=drive,
        torque_nm=torque,
        base_pos_m=sim.sensor(sd, "gs_base_pos"),
        base_quat=sim.sensor(sd, "gs_base_quat"),
        base_linvel_m_s=sim.sensor(sd, "gs_base_linvel"),
        foot_pos_m=foot_pos,
        foot_slip_speed_m_s=np.linalg.norm(slip_xy, axis=-1),
        foot_force_n=np.linalg.norm(contact[..., 1:4], axis=-1),
        foot_contacts=contact[..., 0],
        robot_contacts=sim.sensor(sd, "gs_robot_contacts")[:, 0],
        qpos=qpos,
        gait_end_s=plan.gait_end_s if plan.exit is not None else math.inf,
        attitude_gain=settings.attitude_gain,
    )

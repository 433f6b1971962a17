"""`MujocoTwin`: a virtual servo bus whose servos are the robot's joints in MuJoCo.

The player talks to `twin.vbus` exactly as to real servos — byte-level Feetech / Dynamixel
packets through the unmodified vendor SDKs — and the servos' present positions come from a
MuJoCo rollout of the robot's MJCF, driven by the goal positions decoded from those packets:

    player ─► SDK ─► bytes ─► VirtualServoBus ─► goal ticks ─► MujocoTwin.advance
                                                     ▲                │ position servo per joint
                                                     └── present ◄────┘ (sim.servo / sim.model)

The servo model is the simulator's (`sim.model.build_sim_model`: a position loop whose drive is
clipped to the servo's torque–speed envelope, plus back-EMF damping), so the twin sees what
`sim.validate` sees. A servo with torque off is limp (no drive; gearbox damping only).

Lockstep: before serving each packet the bus calls `advance(now_s)`; the twin steps the physics
until sim time reaches `now_s − t_start` (whole timesteps). Give the bus the player's clock: with
a `VirtualClock` the sim advances exactly one tick period per player tick, deterministically and
as fast as the CPU allows; with a real clock it follows wall time.

The robot starts standing in its nominal stance, servos powered and holding it (as after
`torque on` at stance), feet just touching the floor — or, with `lifted=True`, hung in the air
(base welded, floor contacts off: `sim.model` lifted mode), the bench of `gaitsmith-play
identify`.

Per-servo settings (`servo_settings`, a `robots.servo_params` file or one `ServoSetting` per
joint) make each servo differ from its catalogue model: position gain scale, strength scale and
the latency of a goal reaching it. A goal the player writes at bus time t acts from t + latency:
the twin keeps the goals' history and, over each physics step [t₀, t₀ + dt), commands the time
average of that delayed, held goal (so a latency between two steps is not rounded to one).
`sim.identify` fits those three numbers back from a recorded run.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from hardware.bus.virtual.bus import VirtualServoBus
from hardware.bus.virtual.faults import NO_FAULTS, FaultPlan
from hardware.bus.virtual.servo import VirtualServo
from hardware.play.virtual_rig import place_servos
from robots.robot import Robot
from robots.servo_params import ServoParamsFile, ServoSetting
from sim.errors import SimConfigError
from sim.metrics import yaw_of
from sim.model import STATE_SPEC, SimConditions, build_sim_model

MAX_CATCH_UP_S = 1.0  # a (real-time) clock jump larger than this is not simulated step by step


@dataclass(frozen=True)
class BaseSample:
    """Base (root body) state at one sim time."""

    t_s: float
    position_m: tuple[float, float, float]
    yaw_rad: float = 0.0  # heading in the world frame, wrapped to (−π, π]


class MujocoTwin:
    """The robot in MuJoCo behind a byte-level virtual servo bus (see the module docstring)."""

    def __init__(
        self,
        robot: Robot,
        clock: Callable[[], float],
        conditions: SimConditions | None = None,
        faults: FaultPlan = NO_FAULTS,
        record_every_s: float = 0.01,
        *,
        lifted: bool = False,
        servo_settings: ServoParamsFile | Sequence[ServoSetting] | None = None,
    ) -> None:
        self.robot = robot
        cond = conditions or SimConditions()
        if lifted and not cond.lifted:
            cond = SimConditions(cond.friction, cond.payload_kg, cond.strength, lifted=True)
        settings = _settings_for(robot, servo_settings)
        self.servo_settings = settings
        self.sim = build_sim_model(robot, cond, servo_settings=settings)
        self.model = self.sim.model
        self.data = mujoco.MjData(self.model)
        mujoco.mj_setState(self.model, self.data, self.sim.initial_state(), STATE_SPEC)
        mujoco.mj_forward(self.model, self.data)
        self._qadr = self.sim.qpos_adr
        self._dadr = self.sim.dof_adr
        self._zero = np.array([j.zero_offset_ticks for j in robot.joints], float)
        self._scale = np.array([j.direction * j.servo.ticks_per_rad for j in robot.joints], float)
        self._index = {j.bus_id: n for n, j in enumerate(robot.joints)}
        self.vbus = VirtualServoBus.from_robot(robot, clock=clock, faults=faults)
        place_servos(self.vbus, robot, robot.nominal_stance_rad)
        torque = self.vbus.table["torque_enable"]
        for s in self.vbus.servos:
            s.write(torque.addr, b"\x01")  # powered, holding the stance
        self._t_start = clock()
        self._record_every_s = record_every_s
        self._latency_s = self.sim.servo_latency_s
        # goal history: (sim time written, goals [rad]); the stance holds since forever
        self._goal_log: list[tuple[float, np.ndarray]] = [
            (-math.inf, np.asarray(robot.nominal_stance_rad, float))
        ]
        self._written_at = 0.0  # sim time of the previous advance (packets since then: after it)
        self.history: list[BaseSample] = []
        self.steps = 0
        self._sync_servos(self.vbus.servos)
        self._record()
        self.vbus.plant = self

    # -- ServoPlant -----------------------------------------------------------------------------
    def advance(self, now_s: float, servos: Sequence[VirtualServo]) -> None:
        """Step the physics to bus time `now_s`, then impose the joints' state on the servos."""
        dt = self.model.opt.timestep
        target = now_s - self._t_start
        if target - self.data.time > MAX_CATCH_UP_S:  # e.g. the process was suspended
            self._t_start += target - self.data.time - MAX_CATCH_UP_S
            target = now_s - self._t_start
        goal_rad, enabled = self._goals(servos)
        if not np.array_equal(goal_rad, self._goal_log[-1][1]):
            self._goal_log.append((self._written_at, goal_rad))
        if self.data.time + 0.5 * dt <= target:
            while self.data.time + 0.5 * dt <= target:
                q = self.data.qpos[self._qadr]
                t0 = float(self.data.time)
                acting = self._delayed_goal(t0, t0 + dt)
                self.data.ctrl[:] = np.where(enabled, acting, q)  # limp: no position error
                mujoco.mj_step(self.model, self.data)
                self.steps += 1
                if self.data.time - self.history[-1].t_s >= self._record_every_s - 1e-9:
                    self._record()
        self._written_at = float(self.data.time)
        self._sync_servos(servos)

    # -- helpers ----------------------------------------------------------------------------------
    def _delayed_goal(self, t0: float, t1: float) -> np.ndarray:
        """Per joint, the time average over [t0, t1) of the goal written at w acting from
        w + latency (held until the next one acts)."""
        log, lat = self._goal_log, self._latency_s
        while len(log) > 1 and log[1][0] + float(np.max(lat)) <= t0:
            log.pop(0)  # superseded for every joint before this step begins
        total = np.zeros_like(lat)
        for i, (w, goal) in enumerate(log):
            start = np.maximum(w + lat, t0)
            end = np.minimum(log[i + 1][0] + lat, t1) if i + 1 < len(log) else np.full_like(lat, t1)
            total += goal * np.clip(end - start, 0.0, None)
        return total / (t1 - t0)

    def _goals(self, servos: Sequence[VirtualServo]) -> tuple[np.ndarray, np.ndarray]:
        goal_ticks = self._zero.copy()
        enabled = np.zeros(len(self._zero), dtype=bool)
        for s in servos:
            n = self._index.get(s.servo_id)
            if n is not None:
                goal_ticks[n] = s.goal_tick
                enabled[n] = s.torque_enabled
        return (goal_ticks - self._zero) / self._scale, enabled

    def _sync_servos(self, servos: Sequence[VirtualServo]) -> None:
        q = self.data.qpos[self._qadr]
        qd = self.data.qvel[self._dadr]
        ticks = self._zero + self._scale * q
        speed = self._scale * qd
        for s in servos:
            n = self._index.get(s.servo_id)
            if n is not None:
                s.drive(float(ticks[n]), float(speed[n]))

    def _record(self) -> None:
        x, y, z = (float(v) for v in self.base_position_m)
        yaw = float(yaw_of(self._base_quat()))
        self.history.append(BaseSample(float(self.data.time), (x, y, z), yaw))

    # -- results ---------------------------------------------------------------------------
    @property
    def sim_time_s(self) -> float:
        return float(self.data.time)

    @property
    def base_position_m(self) -> np.ndarray:
        if self.sim.conditions.lifted:  # welded: where the build put it
            return np.array(self.data.xpos[self.sim.root_body], dtype=float)
        return np.array(self.data.qpos[0:3], dtype=float)

    def _base_quat(self) -> np.ndarray:
        if self.sim.conditions.lifted:
            return np.array(self.data.xquat[self.sim.root_body], dtype=float)
        return np.array(self.data.qpos[3:7], dtype=float)

    def roll_pitch_rad(self) -> tuple[float, float]:
        """The base's roll and pitch now (z-y'-x''), as an IMU on the body reads them: the
        player's attitude source on the twin (`gaitsmith-play run --virtual sim`)."""
        from robots.attitude import roll_pitch

        roll, pitch = roll_pitch(self._base_quat())
        return float(roll), float(pitch)

    @property
    def joint_angles_rad(self) -> np.ndarray:
        return np.array(self.data.qpos[self._qadr], dtype=float)

    def base_track(self) -> tuple[np.ndarray, np.ndarray]:
        """(times [s], positions [m] (K × 3)) of the base, sampled every `record_every_s`."""
        t = np.array([h.t_s for h in self.history])
        p = np.array([h.position_m for h in self.history], dtype=float).reshape(-1, 3)
        return t, p

    def heading_change_rad(self) -> float:
        """Yaw now − yaw when the twin was created (unwrapped over the recorded history)."""
        yaw = np.unwrap(np.array([h.yaw_rad for h in self.history]))
        return float(yaw[-1] - yaw[0])

    def mean_velocity_m_s(self, t0_s: float, t1_s: float) -> np.ndarray:
        """Average base velocity [m/s] between sim times `t0_s` and `t1_s` (x, y, z)."""
        t, p = self.base_track()
        if len(t) < 2 or not t[0] <= t0_s < t1_s <= t[-1] + 1e-9:
            raise ValueError(f"no base track over [{t0_s}, {t1_s}] s (have {t[0]}..{t[-1]})")
        a = np.array([np.interp(t0_s, t, p[:, i]) for i in range(3)])
        b = np.array([np.interp(t1_s, t, p[:, i]) for i in range(3)])
        return np.asarray((b - a) / (t1_s - t0_s))

    def summary(self) -> str:
        x, y, z = self.base_position_m
        t = self.sim_time_s
        return (
            f"twin: {t:.2f} s simulated ({self.steps} steps); base moved x {x:+.3f} m, "
            f"y {y:+.3f} m, turned {np.degrees(self.heading_change_rad()):+.1f}°; "
            f"height {z:.3f} m"
        )


def _settings_for(
    robot: Robot, given: ServoParamsFile | Sequence[ServoSetting] | None
) -> tuple[ServoSetting, ...]:
    if given is None:
        return tuple(ServoSetting() for _ in robot.joints)
    if isinstance(given, ServoParamsFile):
        return given.for_robot(robot)
    out = tuple(given)
    if len(out) != robot.dof:
        raise SimConfigError(
            f"{len(out)} servo settings for the {robot.dof} joints of {robot.name}"
        )
    return out

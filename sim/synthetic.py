"""Kinematic reference gaits (no optimisation) for tests, benchmarks and smoke checks.

- `standing_gait`: the nominal stance held, all feet down, zero speed.
- `kinematic_gait`: for any schedule, each stance foot slides backwards in the body frame at the
  commanded speed along a straight line under its hip, each swing foot returns forwards on a
  half-sine arc of `lift_m`; joint angles from damped least-squares IK on the MJCF (MuJoCo site
  Jacobians), base held at the stance height. No dynamics: a smoke test, not a planner.
"""

from __future__ import annotations

import mujoco
import numpy as np

from robots.gait import Gait, Velocity
from robots.robot import Robot
from robots.schedule import ContactSchedule
from sim.errors import SimSetupError


def standing_gait(robot: Robot, period_s: float = 0.5, n_knots: int = 16) -> Gait:
    """Zero-speed "gait": the nominal stance at every knot, every foot down the whole cycle."""
    feet = robot.foot_names
    schedule = ContactSchedule(period_s, feet, tuple(0.0 for _ in feet), tuple(1.0 for _ in feet))
    knots = np.tile(np.asarray(robot.nominal_stance_rad), (n_knots, 1))
    return Gait.create(
        robot=robot, knots_rad=knots, schedule=schedule, velocity=Velocity(), gait_label="stand"
    )


class _LegIK:
    """Damped least-squares IK of each foot site, base fixed at the origin, stance height."""

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.model = robot.mj_model()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.qadr = np.array(
            [
                m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]
                for n in robot.joint_names
            ]
        )
        self.dadr = np.array(
            [
                m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]
                for n in robot.joint_names
            ]
        )
        self.sites = [
            mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site) for leg in robot.legs
        ]
        self.leg_cols = [
            np.array([robot.joint_names.index(j) for j in leg.joints]) for leg in robot.legs
        ]
        self.lo = np.array([j.lower_rad for j in robot.joints])
        self.hi = np.array([j.upper_rad for j in robot.joints])

    def feet(self, q: np.ndarray) -> np.ndarray:
        d = self.data
        d.qpos[:] = self.model.qpos0
        d.qpos[0:3] = (0.0, 0.0, self.robot.stance_base_height_m)
        d.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        d.qpos[self.qadr] = q
        mujoco.mj_kinematics(self.model, d)
        return np.array([d.site_xpos[s].copy() for s in self.sites])

    def solve(self, targets: np.ndarray, q0: np.ndarray, iters: int = 60) -> np.ndarray:
        q = q0.copy()
        jac = np.zeros((3, self.model.nv))
        for _ in range(iters):
            pos = self.feet(q)
            err = targets - pos
            if np.max(np.abs(err)) < 1e-6:
                break
            mujoco.mj_comPos(self.model, self.data)
            for f, site in enumerate(self.sites):
                mujoco.mj_jacSite(self.model, self.data, jac, None, site)
                cols = self.leg_cols[f]
                jl = jac[:, self.dadr[cols]]
                dq = jl.T @ np.linalg.solve(jl @ jl.T + 1e-6 * np.eye(3), err[f])
                q[cols] = np.clip(q[cols] + dq, self.lo[cols], self.hi[cols])
        if np.max(np.abs(targets - self.feet(q))) > 2e-3:
            raise SimSetupError("kinematic gait: foot targets out of reach (lower speed or lift)")
        return q


def kinematic_gait(
    robot: Robot,
    schedule: ContactSchedule,
    speed_m_s: float,
    *,
    lift_m: float = 0.03,
    n_knots: int = 40,
    label: str = "kinematic",
) -> Gait:
    """A kinematic walking gait along +x at `speed_m_s` for `schedule` (see module docstring)."""
    ik = _LegIK(robot)
    q_stance = np.asarray(robot.nominal_stance_rad, dtype=float)
    home = ik.feet(q_stance)
    phases = np.arange(n_knots) / n_knots
    knots = np.empty((n_knots, robot.dof))
    q = q_stance.copy()
    period = schedule.period_s
    for k, s in enumerate(phases):
        targets = home.copy()
        for f in range(schedule.n_feet):
            duty = schedule.duty_factor[f]
            u = (s - schedule.touchdown_phase[f]) % 1.0
            stride = speed_m_s * period * duty  # distance the body moves during one stance
            if u < duty:  # stance: from +stride/2 to −stride/2
                targets[f, 0] += stride * (0.5 - u / duty)
            else:  # swing: back to the front on an arc
                v = (u - duty) / (1.0 - duty)
                targets[f, 0] += stride * (-0.5 + (3 * v**2 - 2 * v**3))
                targets[f, 2] += lift_m * np.sin(np.pi * v)
        q = ik.solve(targets, q)
        knots[k] = q
    return Gait.create(
        robot=robot,
        knots_rad=knots,
        schedule=schedule,
        velocity=Velocity(vx_m_s=float(speed_m_s)),
        gait_label=label,
        planner={"generator": "sim.synthetic.kinematic_gait", "lift_m": lift_m},
    )


def feet_offset_pose(robot: Robot, offsets_m: np.ndarray) -> np.ndarray:
    """Joint angles placing every foot at its stance position + `offsets_m` (F × 3, body frame)."""
    ik = _LegIK(robot)
    q0 = np.asarray(robot.nominal_stance_rad, dtype=float)
    return ik.solve(ik.feet(q0) + np.asarray(offsets_m, dtype=float), q0)


def trot_schedule(robot: Robot, period_s: float = 0.5, duty: float = 0.6) -> ContactSchedule:
    """Diagonal pairs for a quadruped, alternating tripods for a hexapod (by foot position)."""
    ik = _LegIK(robot)
    feet = ik.feet(np.asarray(robot.nominal_stance_rad))
    order = np.argsort(-feet[:, 0], kind="stable")  # front to back
    phase = np.zeros(len(feet))
    for rank, f in enumerate(order):
        left = feet[f, 1] > 0
        phase[f] = 0.5 * ((rank // 2 + (0 if left else 1)) % 2)
    return ContactSchedule(
        period_s, robot.foot_names, tuple(float(p) for p in phase), tuple(duty for _ in feet)
    )

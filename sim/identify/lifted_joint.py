"""One lifted joint: the servo of `sim.servo` driving the links beyond it, everything else held.

With the base welded in the air (`SimConditions(lifted=True)`) and the other joints held where
they were measured, joint j is a pendulum about its axis: constant inertia I (the subtree's
inertia about the axis plus the rotor's armature, the joint's diagonal entry of MuJoCo's mass
matrix: it does not depend on q_j itself) and a gravity torque that is exactly sinusoidal in
q_j, g(q) = α·cos q + β·sin q (the subtree's centre of mass turns about the axis; fitted by
least squares to MuJoCo's bias force on a grid of angles). Its equation of motion is

    I·q̈ = clip(kp·(u − q) − kd·q̇, ±F) − (d + b)·q̇ − g(q) − f_c·tanh(q̇ / ε)

with u the goal acting on the servo, kp = gain_scale·g_p·F, kd = gain_scale·g_d·F,
F = strength·τ_stall the drive limit, b = F/ω₀ the back-EMF slope (`sim.servo`), d the MJCF
joint damping and f_c its frictionloss (smoothed over ε = `FRICTION_EPS_RAD_S`). It is
integrated as MuJoCo's `implicitfast` does the damping (semi-implicit Euler, damping implicit)
at the model's timestep. u over a step is the step's time average of the goals, held between
ticks and each acting `latency` after it was written (as `sim.twin` applies them).

`simulate` runs B copies at once (numpy over the batch): joints of a group and the parameter
sets of a finite-difference Jacobian in one pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from robots.robot import Robot
from sim.model import SimConditions, build_sim_model
from sim.servo import default_gains

FRICTION_EPS_RAD_S = 0.05
GRAVITY_GRID = 13  # angles over the joint's range to fit α, β


@dataclass(frozen=True)
class JointPlant:
    """The mechanics and catalogue servo of one lifted joint (see the module docstring)."""

    name: str
    inertia_kg_m2: float
    gravity_cos_nm: float  # α
    gravity_sin_nm: float  # β
    damping_nm_s_per_rad: float  # MJCF joint damping (gearbox), without the back-EMF
    frictionloss_nm: float
    stall_torque_nm: float
    no_load_speed_rad_s: float
    duty_per_rad: float
    duty_s_per_rad: float
    timestep_s: float

    def gravity_nm(self, q_rad: np.ndarray) -> np.ndarray:
        return self.gravity_cos_nm * np.cos(q_rad) + self.gravity_sin_nm * np.sin(q_rad)


def joint_plants(robot: Robot, joints: list[int], held_rad: np.ndarray) -> list[JointPlant]:
    """The plants of `joints` (indices into `robot.joints`) with every joint at `held_rad` (J,)
    except the one moving, from the lifted MuJoCo model of the robot's MJCF."""
    sim = build_sim_model(robot, SimConditions(lifted=True))
    model, data = sim.model, mujoco.MjData(sim.model)
    mass = np.zeros((model.nv, model.nv))
    out = []
    for j in joints:
        joint, servo = robot.joints[j], sim.servos[j]
        qadr, dadr = int(sim.qpos_adr[j]), int(sim.dof_adr[j])
        grid = np.linspace(joint.lower_rad, joint.upper_rad, GRAVITY_GRID)
        bias = []
        for q in grid:
            data.qpos[:] = model.qpos0
            data.qpos[sim.qpos_adr] = held_rad
            data.qpos[qadr] = q
            data.qvel[:] = 0.0
            mujoco.mj_forward(model, data)
            bias.append(float(data.qfrc_bias[dadr]))
        alpha, beta = np.linalg.lstsq(
            np.stack([np.cos(grid), np.sin(grid)], axis=1), np.array(bias), rcond=None
        )[0]
        data.qpos[sim.qpos_adr] = held_rad
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, mass)
        duty_p, duty_d = default_gains(joint.servo)
        out.append(
            JointPlant(
                name=joint.name,
                inertia_kg_m2=float(mass[dadr, dadr]),
                gravity_cos_nm=float(alpha),
                gravity_sin_nm=float(beta),
                damping_nm_s_per_rad=float(model.dof_damping[dadr]) - servo.back_emf_nm_s_per_rad,
                frictionloss_nm=float(model.dof_frictionloss[dadr]),
                stall_torque_nm=joint.servo.stall_torque_nm,
                no_load_speed_rad_s=joint.servo.no_load_speed_rad_s,
                duty_per_rad=duty_p,
                duty_s_per_rad=duty_d,
                timestep_s=float(model.opt.timestep),
            )
        )
    return out


@dataclass(frozen=True, eq=False)
class GoalRecord:
    """Goals written at times `written_s` (K,), per joint `goal_rad` (K, n), held between."""

    written_s: np.ndarray
    goal_rad: np.ndarray

    def step_average(
        self, column: int, t0_s: np.ndarray, dt_s: float, latency_s: float
    ) -> np.ndarray:
        """Time average over [t0, t0 + dt) of the held goal of `column` delayed by
        `latency_s` (before the first write: the first goal)."""
        w, g = self.written_s, self.goal_rad[:, column]
        cum = np.concatenate([[0.0], np.cumsum(g[:-1] * np.diff(w))])  # ∫ from w[0] to w[k]

        def integral(t: np.ndarray) -> np.ndarray:
            inside = np.interp(t, w, cum)
            before = np.minimum(t - w[0], 0.0) * g[0]
            after = np.maximum(t - w[-1], 0.0) * g[-1]
            return inside + before + after

        a = t0_s - latency_s
        return (integral(a + dt_s) - integral(a)) / dt_s


def simulate(
    plants: list[JointPlant],
    columns: list[int],
    goals: GoalRecord,
    params: np.ndarray,
    t_start_s: float,
    sample_s: np.ndarray,
    q0_rad: np.ndarray,
) -> np.ndarray:
    """Joint angles (B, S) at times `sample_s` (S,) of B lifted joints, started at rest at
    `q0_rad` (B,) at `t_start_s`; batch b is plant `plants[b]` fed goal column `columns[b]`,
    with `params[b]` = (gain_scale, latency_s, strength)."""
    dt = plants[0].timestep_s
    n_steps = int(np.ceil((float(np.max(sample_s)) - t_start_s) / dt - 1e-9)) + 1
    t0 = t_start_s + dt * np.arange(n_steps)
    gain, latency, strength = (np.asarray(params, float)[:, i] for i in range(3))
    u = np.stack(
        [goals.step_average(c, t0, dt, float(lat)) for c, lat in zip(columns, latency, strict=True)]
    )
    stall = np.array([p.stall_torque_nm for p in plants])
    drive = strength * stall
    kp = gain * drive * np.array([p.duty_per_rad for p in plants])
    kd = gain * drive * np.array([p.duty_s_per_rad for p in plants])
    damp = np.array([p.damping_nm_s_per_rad for p in plants]) + drive / np.array(
        [p.no_load_speed_rad_s for p in plants]
    )
    inertia = np.array([p.inertia_kg_m2 for p in plants])
    eff = inertia + dt * damp
    ga = np.array([p.gravity_cos_nm for p in plants])
    gb = np.array([p.gravity_sin_nm for p in plants])
    fc = np.array([p.frictionloss_nm for p in plants])
    q = np.asarray(q0_rad, float).copy()
    v = np.zeros_like(q)
    traj = np.empty((n_steps + 1, len(q)))
    traj[0] = q
    for n in range(n_steps):
        force = np.clip(kp * (u[:, n] - q) - kd * v, -drive, drive)
        force -= damp * v + ga * np.cos(q) + gb * np.sin(q)
        if fc.any():
            force -= fc * np.tanh(v / FRICTION_EPS_RAD_S)
        v = v + dt * force / eff
        q = q + dt * v
        traj[n + 1] = q
    idx = np.clip(np.round((sample_s - t_start_s) / dt).astype(int), 0, n_steps)
    return traj[idx].T

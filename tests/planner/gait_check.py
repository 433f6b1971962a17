"""Independent numpy/MuJoCo check of a written gait file (not the NLP's own constraint values).

Kinematics from `mj_kinematics` at the file's base pose + joint angles (base x shifted by v·t back
to the ground frame); velocities/accelerations by cyclic finite differences of MuJoCo's qpos with
`mj_differentiatePos`; torques by `mj_inverse` minus Jᵀf (`mj_jacSite`) with the file's forces.

Servo goals: when the file says ``planner["joint_angles"] == "servo_goal"`` its joint samples are
goals for the servos' position loops and the motion is ``expected_joint_angles_rad``.
Kinematics and dynamics are checked on the achieved motion, and the goals independently: the
simulator's servo law (`sim.servo.ServoParams.torque_nm`, factory gains) driven by the file's goal
at the achieved angle and MuJoCo's finite-difference speed must produce the `mj_inverse` torque.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

import robots
from sim.servo import servo_params


@dataclass(frozen=True)
class GaitCheck:
    stance_height_err_m: float  # max |z − r| of stance feet
    stance_slip_m: float  # max ground-frame displacement of a stance foot between stance knots
    transition_slip_m: float  # same over the interval into touchdown / out of lift-off
    min_swing_height_m: float  # min z − r of swing feet
    max_swing_apex_m: float  # smallest per-foot swing apex (z − r)
    friction_excess: float  # max of |f_t| − µ f_z over stance (≤ 0 inside the cone)
    min_normal_force_n: float
    max_swing_force_n: float
    base_residual_n: float  # max |base rows| of mj_inverse − Jᵀf (whole-body balance)
    torque_err_over_stall: float  # max |τ_mj − τ_file| / stall
    envelope_excess: float  # max of |τ|/(margin τ_s) + |q̇|/ω₀ − 1 (≤ 0 inside)
    servo_torque_err_over_stall: float  # max |τ_servo(goal, q, q̇) − τ_mj| / stall (0: no goals)
    servo_drive_over_stall: float  # max |clipped drive| / (s·τ_stall): 1 means saturated


def _qpos(
    model: mujoco.MjModel, robot: robots.Robot, base: np.ndarray, q: np.ndarray
) -> np.ndarray:
    qpos = np.array(model.qpos0)
    qpos[0:3] = base[:3]
    # R = Rz(yaw) Ry(pitch) Rx(roll) via MuJoCo's own quaternion algebra
    quat = np.array([1.0, 0, 0, 0])
    for axis, angle in ((2, base[5]), (1, base[4]), (0, base[3])):
        ax = np.zeros(3)
        ax[axis] = 1.0
        qa = np.zeros(4)
        mujoco.mju_axisAngle2Quat(qa, ax, angle)
        out = np.zeros(4)
        mujoco.mju_mulQuat(out, quat, qa)
        quat = out
    qpos[3:7] = quat
    for j, joint in enumerate(robot.joints):
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
        qpos[model.jnt_qposadr[jid]] = q[j]
    return qpos


def check_gait(
    gait: robots.Gait, robot: robots.Robot, mu: float, torque_margin: float
) -> GaitCheck:
    assert gait.base_pose is not None and gait.contact_forces_n is not None
    assert gait.joint_torques_nm is not None
    model = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    data = mujoco.MjData(model)
    n, v, period = gait.n_knots, gait.velocity.vx_m_s, gait.period_s
    h = period / n
    r = robot.foot_radius_m
    sites = [
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site) for leg in robot.legs
    ]
    jdofs = [
        int(model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)])
        for j in robot.joints
    ]
    goals = gait.planner.get("joint_angles") == "servo_goal"
    angles = (
        np.asarray(gait.expected_joint_angles_rad, dtype=float)
        if goals
        else gait.knots_rad
    )
    assert angles.shape == gait.knots_rad.shape
    qpos = []
    feet = np.zeros((n, len(sites), 3))
    for k in range(n):
        base = gait.base_pose[k].copy()
        base[0] += v * k * h  # ground frame: the base advances, feet stay put
        qpos.append(_qpos(model, robot, base, angles[k]))
        data.qpos[:] = qpos[-1]
        mujoco.mj_kinematics(model, data)
        feet[k] = data.site_xpos[sites]
    # the cycle closes with the base advanced by v·T
    closing = qpos[0].copy()
    closing[0] += v * period
    qpos_ext = [*qpos, closing]
    vel_half = np.zeros((n, model.nv))  # between knot k and k+1
    for k in range(n):
        mujoco.mj_differentiatePos(model, vel_half[k], h, qpos_ext[k], qpos_ext[k + 1])
    contact = gait.schedule.contact_matrix(n)
    stance_z = np.abs(feet[..., 2] - r)[contact]
    slip, transition_slip = 0.0, 0.0
    for k in range(n):
        both = contact[k] & contact[(k + 1) % n]
        switch = contact[k] ^ contact[(k + 1) % n]
        nxt = feet[(k + 1) % n] + (np.array([v * period, 0, 0]) if k == n - 1 else 0.0)
        moved = np.linalg.norm((nxt - feet[k])[:, :2], axis=1)
        if both.any():
            slip = max(slip, float(np.max(moved[both])))
        if switch.any():
            transition_slip = max(transition_slip, float(np.max(moved[switch])))
    swing_h = (feet[..., 2] - r)[~contact]
    apex = min(float(np.max((feet[:, f, 2] - r)[~contact[:, f]])) for f in range(len(sites)))
    forces = gait.contact_forces_n
    tangential = np.linalg.norm(forces[..., :2], axis=-1)
    stall = np.array([j.servo.stall_torque_nm for j in robot.joints])
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in robot.joints])
    base_res, tau_err, env = 0.0, 0.0, -np.inf
    servo_err, drive_max = 0.0, 0.0
    servos = [servo_params(j.servo) for j in robot.joints]
    for k in range(n):
        data.qpos[:] = qpos[k]
        data.qvel[:] = 0.5 * (vel_half[k] + vel_half[k - 1])
        data.qacc[:] = (vel_half[k] - vel_half[k - 1]) / h
        mujoco.mj_inverse(model, data)
        qfrc = data.qfrc_inverse.copy()
        for f, sid in enumerate(sites):
            jac = np.zeros((3, model.nv))
            mujoco.mj_jacSite(model, data, jac, None, sid)
            qfrc -= jac.T @ forces[k, f]
        base_res = max(base_res, float(np.max(np.abs(qfrc[:3]))))
        tau = qfrc[jdofs]
        tau_err = max(tau_err, float(np.max(np.abs(tau - gait.joint_torques_nm[k]) / stall)))
        qd = data.qvel[jdofs]
        if goals:
            for j, sp in enumerate(servos):
                tq = sp.torque_nm(gait.knots_rad[k, j], angles[k, j], qd[j])
                servo_err = max(servo_err, float(abs(tq - tau[j]) / stall[j]))
                drive = sp.drive_nm(gait.knots_rad[k, j], angles[k, j], qd[j])
                drive_max = max(drive_max, float(abs(drive) / sp.drive_limit_nm))
        env = max(
            env, float(np.max(np.abs(tau) / (torque_margin * stall) + np.abs(qd) / omega0 - 1.0))
        )
    return GaitCheck(
        stance_height_err_m=float(stance_z.max()),
        stance_slip_m=slip,
        transition_slip_m=transition_slip,
        min_swing_height_m=float(swing_h.min()),
        max_swing_apex_m=apex,
        friction_excess=float(np.max((tangential - mu * forces[..., 2])[contact])),
        min_normal_force_n=float(forces[..., 2][contact].min()),
        max_swing_force_n=float(np.max(np.linalg.norm(forces, axis=-1)[~contact])),
        base_residual_n=base_res,
        torque_err_over_stall=tau_err,
        envelope_excess=env,
        servo_torque_err_over_stall=servo_err,
        servo_drive_over_stall=drive_max,
    )

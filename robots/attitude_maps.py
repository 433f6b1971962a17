"""The attitude law's kinematic map of a robot, from its MuJoCo model (`robots.attitude`).

At the stance pose (base at the origin, level, joints at `Robot.nominal_stance_rad`) each leg's
foot Jacobian is taken with `mujoco.mj_jac` at its contact point: the sole centre of a flat foot
(6 rows: the sole is held in position and orientation) or the foot sphere's lowest point (3
rows: position only). Splitting its columns into the floating base's six (J_b: MuJoCo's freejoint
velocity is the base origin's linear velocity and the angular velocity, both world = body frame
at a level base) and the leg's own joints (J_q), a foot held still while the base moves with
twist ξ needs J_b·ξ + J_q·Δq = 0, so

    Δq_leg = K·ξ,   K = −J_q⁺ · J_b   (least squares where the leg has fewer joints than rows).

Nothing here reads a joint name: which servo corrects which axis, and with which sign, is
whatever the chain's geometry says.
"""

from __future__ import annotations

import numpy as np

from robots.attitude import AttitudeError, AttitudeMap, LegMap
from robots.robot import Robot
from robots.sole import sole_pose_world


def attitude_map(robot: Robot, model: object | None = None) -> AttitudeMap:
    """The map of `robot` at its stance pose (`model`: a compiled MjModel of it, e.g. the
    simulator's; default `robot.mj_model()`)."""
    import mujoco

    m = robot.mj_model() if model is None else model
    assert isinstance(m, mujoco.MjModel)
    if m.njnt == 0 or m.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise AttitudeError(f"{robot.name}: attitude feedback needs a free-floating base "
                            "(the model's first joint a freejoint)")
    data = mujoco.MjData(m)
    data.qpos[:] = m.qpos0
    data.qpos[0:3] = (0.0, 0.0, robot.stance_base_height_m)
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    names = robot.joint_names
    jid = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in names]
    data.qpos[[m.jnt_qposadr[j] for j in jid]] = robot.nominal_stance_rad
    mujoco.mj_kinematics(m, data)
    mujoco.mj_comPos(m, data)
    base = np.array(data.qpos[0:3], dtype=float)
    legs = []
    for leg in robot.legs:
        site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
        body = int(m.site_bodyid[site])
        if leg.is_flat:
            point = sole_pose_world(m, data, leg)[0]
        else:
            point = np.array(data.site_xpos[site], dtype=float)
            point[2] -= robot.foot_radius_m
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        mujoco.mj_jac(m, data, jacp, jacr, point, body)
        jac = np.vstack([jacp, jacr]) if leg.is_flat else jacp
        cols = [int(m.jnt_dofadr[jid[names.index(n)]]) for n in leg.joints]
        j_b, j_q = jac[:, 0:6], jac[:, cols]
        k = -np.linalg.pinv(j_q, rcond=1e-6) @ j_b
        legs.append(LegMap(tuple(names.index(n) for n in leg.joints), k, point - base))
    return AttitudeMap(len(names), tuple(legs))


__all__ = ["attitude_map"]

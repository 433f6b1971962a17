"""The robot at its nominal stance, for geometry the planner reads off the model: the prepared
MJCF with the base at the origin and level, every joint at its ``stance_deg``, and MuJoCo's
forward kinematics done (body, site and joint frames: `xpos`, `site_xpos`, `xanchor`, `xaxis`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco

from robots import Robot


@dataclass(frozen=True)
class StanceKinematics:
    model: Any  # mujoco.MjModel (the robot's prepared model)
    data: Any  # mujoco.MjData after mj_kinematics at the stance
    joint_ids: tuple[int, ...]  # MuJoCo joint id of each of `robot.joints`


def stance_kinematics(robot: Robot) -> StanceKinematics:
    """Forward kinematics of `robot` at its nominal stance (module docstring)."""
    model = robot.mj_model()
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0:7] = (0, 0, 0, 1, 0, 0, 0)
    ids = tuple(
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name) for j in robot.joints
    )
    for jid, joint in zip(ids, robot.joints, strict=True):
        data.qpos[model.jnt_qposadr[jid]] = joint.stance_rad
    mujoco.mj_kinematics(model, data)
    return StanceKinematics(model, data, ids)

"""Each built-in robot stands in MuJoCo on position actuators holding its nominal stance."""

import math

import mujoco
import numpy as np
import pytest

import robots

SETTLE_S, HOLD_S = 2.0, 5.0


def _standing_model(r: robots.Robot) -> tuple[mujoco.MjModel, mujoco.MjData]:
    spec = mujoco.MjSpec.from_file(str(r.mjcf_path))
    for j in r.joints:
        # stiff position servo: full stall torque at 6° error, clipped at stall
        kp = j.servo.stall_torque_nm / math.radians(6.0)
        act = spec.add_actuator(name=j.name, target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=kp, kv=0.05 * kp)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-j.servo.stall_torque_nm, j.servo.stall_torque_nm]
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[2] = r.stance_base_height_m + 0.01  # dropped from 1 cm
    for j in r.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        data.qpos[model.jnt_qposadr[jid]] = j.stance_rad
    data.ctrl[:] = r.nominal_stance_rad
    return model, data


@pytest.mark.parametrize("name", ["quad12", "hex18"])
def test_robot_stands_still(name: str) -> None:
    r = robots.load(name)
    model, data = _standing_model(r)
    heights, tilts_deg = [], []
    while data.time < SETTLE_S + HOLD_S:
        mujoco.mj_step(model, data)
        if data.time >= SETTLE_S:
            heights.append(data.qpos[2])
            z_axis_z = data.xmat[1].reshape(3, 3)[2, 2]
            tilts_deg.append(math.degrees(math.acos(min(1.0, z_axis_z))))
    heights_m = np.array(heights)
    assert np.ptp(heights_m) <= 0.005
    assert max(tilts_deg) <= 2.0
    # it stands on its feet near the stance height, not on its belly
    assert abs(np.mean(heights_m) - r.stance_base_height_m) < 0.02
    torque_frac = np.abs(data.actuator_force) / np.array(
        [j.servo.stall_torque_nm for j in r.joints]
    )
    assert torque_frac.max() < 0.5

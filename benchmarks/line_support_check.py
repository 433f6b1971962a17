"""Plan against MuJoCo on the support lines of a gait: where the capture point is, and which
swing feet touch the ground.

    python benchmarks/line_support_check.py ROBOT GAIT.json [cycles=20]

For every knot of the written cycle at which exactly two feet stand (a support line), prints
the signed distance of the capture point ξ = c + ċ/ω (ω = √(g/h), h = the robot's stance
height, ċ relative to the ground) from that line, + toward the foot that lands next
(`planner.nlp.line_capture`): the plan's (from the file's base pose and planned angles) and
MuJoCo's mean and worst over the steady cycles (4 to the end). Then, per foot, the share of
the steady samples in its planned swing with the foot on the ground. Used for
docs/results/heavy_rotor.md §7.
"""

from __future__ import annotations

import math
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import casadi as ca
import mujoco
import numpy as np

import robots
from planner.nlp.line_capture import line_sides, next_touchdown_weights
from planner.templates import stance_foot_positions_m
from robots.gait import load as load_gait
from sim.validate import simulate

STEADY_FROM_CYCLE = 4


def _quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def _com(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray) -> np.ndarray:
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    return np.array(data.subtree_com[1])


def _side(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> float:
    u = (b - a) / np.linalg.norm(b - a)
    return float(u[0] * (p[1] - a[1]) - u[1] * (p[0] - a[0]))


def main(argv: list[str]) -> None:
    bot = robots.load(argv[0])
    gait = load_gait(argv[1])
    cycles = int(argv[2].split("=")[1]) if len(argv) > 2 else 20
    base = np.asarray(gait.base_pose, dtype=float)
    q_plan = np.asarray(gait.expected_joint_angles_rad, dtype=float)
    n = base.shape[0]
    h = gait.period_s / n
    vx = float(gait.velocity.vx_m_s)
    contact = np.asarray(gait.schedule.contact_matrix(n), dtype=float).T  # F × N
    weights = [np.asarray(ca.DM(w)).ravel() for w in next_touchdown_weights(ca.DM(contact))]
    sides = line_sides(stance_foot_positions_m(bot)[:, :2])
    omega = math.sqrt(9.81 / bot.stance_base_height_m)
    model = bot.mj_model()
    data = mujoco.MjData(model)
    jadr = [model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)]
            for j in bot.joints]
    sites = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site) for leg in bot.legs]
    plan_com, plan_feet = [], []
    for k in range(n):
        qpos = np.array(model.qpos0)
        qpos[0:3], qpos[3:7] = base[k, :3], _quat(*base[k, 3:6])
        qpos[jadr] = q_plan[k]
        plan_com.append(_com(model, data, qpos))
        plan_feet.append(np.array(data.site_xpos[sites])[:, :2])
    pc, pf = np.array(plan_com), np.array(plan_feet)
    pv = (np.roll(pc, -1, 0) - np.roll(pc, 1, 0)) / (2 * h)
    pv[:, 0] += vx  # the plan's frame moves at the command: velocities relative to the ground
    _, tr = simulate(gait, bot, cycles)
    ph = tr.gait_phase()
    idx = np.flatnonzero((ph >= STEADY_FROM_CYCLE) & (tr.time_s <= tr.gait_end_s))
    com = np.zeros((len(tr.time_s), 3))
    for t in range(max(idx[0] - 1, 0), min(idx[-1] + 2, len(tr.time_s))):
        com[t] = _com(model, data, tr.qpos[t])
    vel = (np.roll(com, -1, 0) - np.roll(com, 1, 0)) / (2 * tr.dt_s)
    icp = com[:, :2] + vel[:, :2] / omega
    feet = tr.foot_pos_m[:, :, :2]
    bins = ((ph % 1.0) * n).astype(int)
    print("knot | line | plan ξ toward next [mm] | MuJoCo mean / worst [mm]")
    for k in range(n):
        stand = np.flatnonzero(contact[:, k] > 0.5)
        if len(stand) != 2:
            continue
        i, j = (int(v) for v in stand)
        s = sum(sides[(i, j)][f] * weights[f][k] for f in range(len(bot.legs)) if f not in (i, j))
        if s == 0:
            continue
        sgn = math.copysign(1.0, s)
        plan = sgn * _side(pf[k, i], pf[k, j], pc[k, :2] + pv[k, :2] / omega)
        at = idx[bins[idx] == k]
        sim = np.array([sgn * _side(feet[t, i], feet[t, j], icp[t]) for t in at])
        print(f"{k:4d} | {bot.foot_names[i]}-{bot.foot_names[j]} | {1000 * plan:6.1f} | "
              f"{1000 * sim.mean():6.1f} / {1000 * sim.min():6.1f}")
    down = []
    for f in range(len(bot.legs)):
        swing = np.array([not gait.schedule.in_stance(f, p % 1.0) for p in ph[idx]])
        down.append(float(np.mean(tr.foot_contacts[idx[swing], f] > 0)) if swing.any() else 0.0)
    print("feet on the ground in their planned swing: "
          + ", ".join(f"{name} {d:.0%}" for name, d in zip(bot.foot_names, down, strict=True)))


if __name__ == "__main__":
    main(sys.argv[1:])

"""Plan vs MuJoCo through each foot's touchdown: sole force, knee torque, foot height and speed.

    python benchmarks/touchdown_load.py tests/zoo/humanoid20 0.215 knots=36
    python benchmarks/touchdown_load.py tests/zoo/humanoid20 0.215 gait=/tmp/t36.json

Arguments: robot, commanded speed [m/s], then `key=value`: `knots` (default 30), `gait` (a gait
file to use instead of planning), `cycles` (default 20), `save` (write the planned gait there)
and any float field of `PlannerOptions`. Plans the robot's default template (or loads the file),
runs `sim.validate.simulate` (default settings, the player's one-cycle entry blend), and for
every touchdown in the steady cycles (3 to the last) lines the run up on the *planned*
touchdown time. Prints, per leg, the mean over touchdowns at −30 … +120 ms:

- planned normal force (the knot values, held) and the simulated sole force [N], of this foot,
  of the other feet and of all of them (the split of the load in double support);
- planned knee torque and simulated servo torque, as fractions of stall;
- the planned sole height (forward kinematics of the planned base pose and expected angles at
  the knots, linear in between) and the simulated one [mm], and their vertical speeds [m/s];
- planned (expected) knee angle, the streamed goal and the simulated angle [deg];

then the measured touchdown (first contact) relative to the planned one, the impulse of the
excess force over the plan in the first 100 ms of stance, and the verdict.
Used for docs/results/zoo_gaits.md "Session 24: humanoid20".
"""

from __future__ import annotations

import json
import os
import sys
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np

import robots
from gaitsmith.gait_choice import default_gait
from planner.nlp.config import PlannerOptions
from planner.nlp.rotations import rpy_to_quat_np
from planner.nlp.spacetime import GaitPlanner
from planner.user_schedule import command_schedule
from robots.gait import Gait
from robots.gait import load as load_gait
from robots.gait import save as save_gait
from robots.sole import sole_pose_world
from sim.validate import evaluate, simulate

OFFSETS_MS = (-30, -20, -10, 0, 10, 20, 30, 40, 50, 60, 70, 80, 100, 120)


def plan(robot: robots.Robot, speed_m_s: float, knots: int, **options: Any) -> Gait:
    gait_name = default_gait(robot)
    schedule, label = command_schedule(robot, gait_name)
    planner = GaitPlanner(robot, n_knots=knots, options=PlannerOptions(**options))
    result = planner.solve(schedule, speed_m_s)
    print(f"# plan: {result.status}, {result.iterations} it, cost {result.cost:.4f}, "
          f"feasible {result.feasible}", flush=True)
    return planner.to_gait(result, label)


def planned_sole_heights_m(gait: Gait, sim_model: mujoco.MjModel, robot: robots.Robot,
                           qpos_adr: np.ndarray) -> np.ndarray:
    """(N, F) planned sole-centre heights at the knots (planned base pose + expected angles)."""
    assert gait.base_pose is not None
    q = (gait.expected_joint_angles_rad if gait.expected_joint_angles_rad is not None
         else gait.joint_angles_rad[:-1])
    data = mujoco.MjData(sim_model)
    out = np.zeros((len(q), len(robot.legs)))
    for k in range(len(q)):
        data.qpos[:3] = gait.base_pose[k, :3]
        data.qpos[3:7] = rpy_to_quat_np(gait.base_pose[k, 3:])
        data.qpos[qpos_adr] = q[k]
        mujoco.mj_kinematics(sim_model, data)
        for f, leg in enumerate(robot.legs):
            if leg.is_flat:
                out[k, f] = sole_pose_world(sim_model, data, leg)[0][2]
            else:
                bid = mujoco.mj_name2id(sim_model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
                out[k, f] = data.site_xpos[bid][2] - robot.foot_radius_m
    return out


def knot_value(values: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """Values held from knot ⌊phase·N⌋ (the plan's force is constant over a knot's slot)."""
    n = len(values)
    return values[np.floor(np.mod(phase, 1.0) * n + 1e-9).astype(int) % n]


def knot_linear(values: np.ndarray, phase: np.ndarray) -> np.ndarray:
    n = len(values)
    x = np.mod(phase, 1.0) * n
    i = np.floor(x).astype(int) % n
    w = x - np.floor(x)
    return (1 - w) * values[i] + w * values[(i + 1) % n]


def tracking_lag(expected: np.ndarray, actual: np.ndarray, dt_s: float,
                 max_lag_s: float = 0.06) -> tuple[float, float]:
    """(lag [ms] of `actual` behind `expected` maximising their correlation, RMS error [deg])."""
    e, a = expected - expected.mean(), actual - actual.mean()
    lags = range(-round(max_lag_s / dt_s), round(max_lag_s / dt_s) + 1)
    best = max(lags, key=lambda k: float(np.dot(e[max(0, -k):len(e) - max(0, k)],
                                                a[max(0, k):len(a) - max(0, -k)])))
    return best * dt_s * 1e3, float(np.degrees(np.sqrt(np.mean((actual - expected) ** 2))))


def main(argv: list[str]) -> None:
    robot_arg, speed = argv[0], float(argv[1])
    kw: dict[str, Any] = {}
    for pair in argv[2:]:
        key, value = pair.split("=", 1)
        kw[key] = value
    bot = robots.load(robot_arg)
    knots = int(kw.pop("knots", 30))
    cycles = int(kw.pop("cycles", 20))
    gait_file, save_to = kw.pop("gait", None), kw.pop("save", None)
    if gait_file:
        gait = load_gait(gait_file, bot)
    else:
        gait = plan(bot, speed, knots, **{k: float(v) for k, v in kw.items()})
    if save_to:
        save_gait(gait, save_to)
    sim, traj = simulate(gait, bot, cycles)
    verdict = evaluate(traj, gait, sim, keep_trajectory=False)
    period, n = gait.period_s, len(gait.joint_angles_rad) - 1
    assert gait.contact_forces_n is not None and gait.joint_torques_nm is not None
    stall = sim.stall_torque_nm
    dt = traj.dt_s
    z_plan = planned_sole_heights_m(gait, sim.model, bot, sim.qpos_adr)
    # simulated sole height: the same kinematics on the recorded qpos
    data = mujoco.MjData(sim.model)
    z_sim = np.zeros((traj.n_steps, len(bot.legs)))
    for t in range(traj.n_steps):
        data.qpos[:] = traj.qpos[t]
        mujoco.mj_kinematics(sim.model, data)
        for f, leg in enumerate(bot.legs):
            z_sim[t, f] = sole_pose_world(sim.model, data, leg)[0][2] if leg.is_flat else np.nan
    phase = traj.gait_phase()
    last_cycle = traj.cycles_run
    print(f"# {bot.name}: period {period:.3f} s, N {n}, knot {1e3 * period / n:.1f} ms, "
          f"weight {mujoco.mj_getTotalmass(sim.model) * 9.81:.1f} N; verdict "
          f"{'PASS' if verdict.passed else 'FAIL'} {list(verdict.reasons)}")
    for f, leg in enumerate(bot.legs):
        knee = next(j for j, name in enumerate(bot.joint_names)
                    if name in leg.joints and "knee" in name)
        td = gait.schedule.touchdown_phase[f]
        duty = gait.schedule.duty_factor[f]
        fz_plan = gait.contact_forces_n[:, f, 2]
        tau_plan = gait.joint_torques_nm[:, knee] / stall[knee]
        rows: dict[int, list[list[float]]] = {o: [] for o in OFFSETS_MS}
        lags: list[float] = []
        impulses: list[float] = []
        vz_td: list[float] = []
        for c in range(3, last_cycle - 1):
            t_td = traj.gait_start_s + (c + td) * period
            i_td = round(t_td / dt) - round(float(traj.time_s[0]) / dt)
            if i_td + round(0.2 / dt) >= traj.n_steps:
                continue
            window = slice(max(0, i_td - round(0.15 / dt)), i_td + round(0.15 / dt))
            down = np.flatnonzero(traj.foot_contacts[window, f] > 0) + window.start
            before = down[down < i_td - round(0.1 / dt)]
            first = down[down > (before[-1] + 1 if len(before) else 0)]
            # first contact after the swing (the foot was airborne ≥ 50 ms before it)
            air = np.flatnonzero(traj.foot_contacts[window, f] == 0) + window.start
            air = air[air < i_td + round(0.1 / dt)]
            if len(air):
                landing = down[down > air[-1]] if np.any(down > air[-1]) else first
                if len(landing):
                    lags.append((landing[0] - i_td) * dt * 1e3)
            k100 = slice(i_td, i_td + round(0.1 / dt))
            ph = phase[k100]
            excess = traj.foot_force_n[k100, f] - knot_value(fz_plan, ph - 0.0)
            impulses.append(float(np.sum(excess) * dt))
            zs = z_sim[:, f]
            vz = np.gradient(zs, dt)
            vz_td.append(float(np.mean(vz[i_td - round(0.02 / dt):i_td])))
            for o in OFFSETS_MS:
                i = i_td + round(o / 1e3 / dt)
                p = phase[i]
                other = [g for g in range(len(bot.legs)) if g != f]
                rows[o].append([
                    float(knot_value(fz_plan, np.array([p]))[0]), float(traj.foot_force_n[i, f]),
                    float(sum(knot_value(gait.contact_forces_n[:, g, 2], np.array([p]))[0]
                              for g in other)),
                    float(sum(traj.foot_force_n[i, g] for g in other)),
                    float(knot_value(tau_plan, np.array([p]))[0]),
                    float(traj.torque_nm[i, knee] / stall[knee]),
                    1e3 * float(knot_linear(z_plan[:, f], np.array([p]))[0]), 1e3 * float(zs[i]),
                    float(np.degrees(gait.expected_joint_angles(np.array([p * period]))[0, knee])),
                    float(np.degrees(traj.goal_rad[i, knee])),
                    float(np.degrees(traj.q_rad[i, knee])),
                ])
        z_knots = z_plan[:, f]
        td_knot = round(td * n) % n
        vz_plan = (z_knots[td_knot] - z_knots[(td_knot - 1) % n]) / (period / n)
        print(f"\n## leg {leg.name} (knee {bot.joint_names[knee]}), touchdown phase {td:.3f}, "
              f"duty {duty:.2f}, {len(rows[0])} touchdowns")
        print("  planned fz at the knots from touchdown: "
              + " ".join(f"{fz_plan[(td_knot + k) % n]:.1f}" for k in range(-1, 8)))
        print("  planned knee τ/stall at the knots:      "
              + " ".join(f"{tau_plan[(td_knot + k) % n]:.2f}" for k in range(-1, 8)))
        print("  planned sole z [mm] at the knots:       "
              + " ".join(f"{1e3 * z_knots[(td_knot + k) % n]:.1f}" for k in range(-3, 3)))
        print(f"  planned sole vz over the last swing interval: {vz_plan:+.3f} m/s; "
              f"simulated mean vz over the 20 ms before the planned touchdown: "
              f"{np.mean(vz_td):+.3f} m/s")
        if lags:
            print(f"  measured first contact − planned touchdown: mean {np.mean(lags):+.1f} ms "
                  f"(min {np.min(lags):+.1f}, max {np.max(lags):+.1f})")
        print(f"  impulse of (sim − plan) force over the first 100 ms: {np.mean(impulses):+.3f} "
              f"N·s (planned impulse over the same window: "
              f"{np.sum(knot_value(fz_plan, td + np.arange(0, 0.1, dt) / period)) * dt:.3f} N·s)")
        print("  t[ms] | this foot fz plan, sim | other feet plan, sim | all feet plan, sim [N] "
              "| knee τ/stall plan, sim (max) | sole z plan, sim [mm] | knee exp, goal, sim [deg]")
        for o in OFFSETS_MS:
            a = np.array(rows[o])
            m, mx = np.mean(a, axis=0), np.max(np.abs(a), axis=0)
            print(f"  {o:+5d} | {m[0]:5.1f} {m[1]:5.1f} | {m[2]:5.1f} {m[3]:5.1f} | "
                  f"{m[0] + m[2]:5.1f} {m[1] + m[3]:5.1f} | "
                  f"{m[4]:+.2f} {m[5]:+.2f} ({mx[5]:.2f}) | "
                  f"{m[6]:5.1f} {m[7]:5.1f} | {m[8]:5.1f} {m[9]:5.1f} {m[10]:5.1f}")
    steady = (phase >= 3) & (phase < last_cycle - 1)
    print("\n## servo tracking, steady cycles: lag of the simulated angle behind the planned "
          "(expected) one by cross-correlation, and the RMS error")
    for j, name in enumerate(bot.joint_names):
        if not any(name in leg.joints for leg in bot.legs) or "yaw" in name:
            continue
        lag_ms, rms_deg = tracking_lag(traj.expected_rad[steady, j], traj.q_rad[steady, j], dt)
        print(f"  {name:16s} lag {lag_ms:+5.1f} ms, RMS error {rms_deg:4.2f}°")
    print(json.dumps({"passed": verdict.passed, "reasons": list(verdict.reasons)}))


if __name__ == "__main__":
    main(sys.argv[1:])

"""Where the simulated servo torque exceeds the plan: joint, phase, rotor share, loop saturation.

    python benchmarks/torque_peak.py ROBOT GAIT.json [cycles=20]

Runs `sim.validate.simulate` on the gait file (default settings: the player's entry blend, 20
cycles) and, over the verdict's steady window (after the warm-up cycles), prints:

- per joint: the simulated peak |τ|/τ_stall, the phase of the cycle where it occurs (and the
  planned contact of that leg there: stance/swing, with the knots since touchdown/lift-off), the
  plan's knot torque and envelope margin·(1 − |q̇|/ω₀) at the two neighbouring knots;
- at that instant: the joint speed q̇/ω₀, the loop's duty u = drive/τ_stall (saturated at ±1),
  the rotor's share I_a·q̈ (q̈ from the simulated q̇) and the rest τ − I_a·q̈ (gravity, contact,
  the link's own inertia, joint damping), the tracking error q − q_expected;
- the mean over the steady cycles of the simulated |τ| at every knot phase and between knots,
  against the plan's knot torque, and the planned rotor torque I_a·q̈ at the knots (the NLP's
  second differences) against the rotor torque of the played spline between knots;
- the fraction of the steady window with the loop at full duty, per joint.

Used for docs/results/heavy_rotor.md.
"""

from __future__ import annotations

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

import robots
from robots.gait import load as load_gait
from sim.metrics import steady_mask
from sim.validate import evaluate, simulate


def main(argv: list[str]) -> None:
    robot_arg, gait_file = argv[0], argv[1]
    kw = dict(a.split("=", 1) for a in argv[2:])
    cycles = int(kw.get("cycles", 20))
    bot = robots.load(robot_arg)
    gait = load_gait(gait_file, bot)
    sim, traj = simulate(gait, bot, cycles)
    verdict = evaluate(traj, gait, sim, keep_trajectory=False)
    m = verdict.metrics
    print(f"# {bot.name} {gait.gait_label} T {gait.period_s:.3f} s, N {gait.n_knots}; "
          f"{'PASS' if verdict.passed else 'FAIL'} {list(verdict.reasons)}; "
          f"peak τ {m.peak_torque_fraction:.3f}, speed {m.achieved_speed_m_s:.3f}")
    stall = np.asarray(sim.stall_torque_nm, dtype=float)
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in bot.joints])
    drive_lim = np.array([sp.drive_limit_nm for sp in sim.servos])
    arm = np.asarray(sim.model.dof_armature[sim.dof_adr], dtype=float)
    margin = float(gait.planner.get("torque_margin", 0.8))
    w = steady_mask(traj, 2)
    dt = traj.dt_s
    qdd = np.gradient(traj.qd_rad_s, dt, axis=0)
    tau = traj.torque_nm
    frac = np.abs(tau) / stall
    phase = np.mod(traj.gait_phase(), 1.0)
    n = gait.n_knots
    assert gait.joint_torques_nm is not None
    tau_plan = gait.joint_torques_nm
    q_exp = gait.expected_joint_angles_rad if gait.expected_joint_angles_rad is not None \
        else gait.joint_angles_rad[:-1]
    h = gait.period_s / n
    qd_plan = (np.roll(q_exp, -1, 0) - np.roll(q_exp, 1, 0)) / (2 * h)
    qdd_plan = (np.roll(q_exp, -1, 0) - 2 * q_exp + np.roll(q_exp, 1, 0)) / h**2
    env_plan = margin * (1 - np.abs(qd_plan) / omega0)
    leg_of = {}
    for f, leg in enumerate(bot.legs):
        for jn in leg.joints:
            leg_of[jn] = f
    sched = gait.schedule
    print(f"armature per joint: {np.unique(np.round(arm, 5))} kg·m²; plan margin {margin}")
    print("\n## per joint: simulated peak in the steady window")
    print("joint        peak  phase knot contact(plan)    plan τ k,k+1 (env)    q̇/ω₀   duty   "
          "I·q̈/st  rest/st  err[deg]")
    for j, jt in enumerate(bot.joints):
        idx = np.flatnonzero(w)
        i = idx[np.argmax(frac[idx, j])]
        ph = phase[i]
        k = int(np.floor(ph * n)) % n
        f = leg_of.get(jt.name)
        if f is not None:
            td, duty = sched.touchdown_phase[f], sched.duty_factor[f]
            s = np.mod(ph - td, 1.0)
            where = (f"stance {s / duty:4.2f}" if s < duty
                     else f"swing {(s - duty) / (1 - duty):4.2f}")
        else:
            where = "-"
        err = np.degrees(traj.q_rad[i, j] - traj.expected_rad[i, j])
        print(f"{jt.name:11s} {frac[i, j]:5.3f}  {ph:5.3f} {k:3d}  {where:16s} "
              f"{tau_plan[k, j] / stall[j]:+.2f} {tau_plan[(k + 1) % n, j] / stall[j]:+.2f} "
              f"({env_plan[k, j]:.2f} {env_plan[(k + 1) % n, j]:.2f})  "
              f"{traj.qd_rad_s[i, j] / omega0[j]:+.2f}  {traj.drive_nm[i, j] / drive_lim[j]:+.2f}  "
              f"{arm[j] * qdd[i, j] / stall[j]:+.2f}   "
              f"{(tau[i, j] - arm[j] * qdd[i, j]) / stall[j]:+.2f}"
              f"   {err:+.1f}")
    sat = np.abs(traj.drive_nm[w]) >= drive_lim * (1 - 1e-6)
    print("\nfull-duty share of the steady window per joint: "
          + ", ".join(f"{jt.name} {100 * sat[:, j].mean():.1f}%"
                      for j, jt in enumerate(bot.joints)))
    over = frac[w] > 0.8
    print("share of steady samples above 0.8 of stall per joint: "
          + ", ".join(f"{jt.name} {100 * over[:, j].mean():.2f}%"
                      for j, jt in enumerate(bot.joints)))
    if np.any(over):
        sat_over = sat[over]
        print(f"  of those samples, loop at full duty: {100 * sat_over.mean():.0f}%; "
              f"joint speed opposite to the torque (braking): "
              f"{100 * np.mean((tau[w] * traj.qd_rad_s[w] < 0)[over]):.0f}%")
    # per-phase mean of the worst joint
    jw = int(np.argmax(frac[w].max(axis=0)))
    print(f"\n## worst joint {bot.joints[jw].name}: per sub-knot phase, mean over steady cycles")
    print("phase  knot  plan τ/st  sim τ/st (max)  plan I·q̈/st  sim I·q̈/st  q̇/ω₀ plan sim  "
          "duty  err[deg]")
    bins = 4 * n
    b = np.floor(phase * bins).astype(int) % bins
    wi = np.flatnonzero(w)
    for bb in range(bins):
        sel = wi[b[wi] == bb]
        if len(sel) == 0:
            continue
        x = (bb + 0.5) / bins * n
        k0 = int(np.floor(x)) % n
        a = x - np.floor(x)
        tp = ((1 - a) * tau_plan[k0, jw] + a * tau_plan[(k0 + 1) % n, jw]) / stall[jw]
        ip = arm[jw] * ((1 - a) * qdd_plan[k0, jw] + a * qdd_plan[(k0 + 1) % n, jw]) / stall[jw]
        vp = ((1 - a) * qd_plan[k0, jw] + a * qd_plan[(k0 + 1) % n, jw]) / omega0[jw]
        print(f"{(bb + 0.5) / bins:5.3f} {x:5.2f}  {tp:+.2f}      "
              f"{np.mean(tau[sel, jw]) / stall[jw]:+.2f} "
              f"({np.max(frac[sel, jw]):.2f})    {ip:+.2f}       "
              f"{np.mean(arm[jw] * qdd[sel, jw]) / stall[jw]:+.2f}      {vp:+.2f} "
              f"{np.mean(traj.qd_rad_s[sel, jw]) / omega0[jw]:+.2f}  "
              f"{np.mean(traj.drive_nm[sel, jw]) / drive_lim[jw]:+.2f}  "
              f"{np.degrees(np.mean(traj.q_rad[sel, jw] - traj.expected_rad[sel, jw])):+.1f}")
    # the played spline's rotor torque between knots against the knots' second differences
    t = np.linspace(0, gait.period_s, 40 * n, endpoint=False)
    qs = gait.expected_joint_angles(t)
    qdd_s = (np.roll(qs, -1, 0) - 2 * qs + np.roll(qs, 1, 0)) / (t[1] - t[0]) ** 2
    print("\nrotor torque I·q̈ / stall, max over the cycle: knots (NLP) vs played spline: "
          + ", ".join(f"{jt.name} {np.max(np.abs(arm[j] * qdd_plan[:, j])) / stall[j]:.2f}/"
                      f"{np.max(np.abs(arm[j] * qdd_s[:, j])) / stall[j]:.2f}"
                      for j, jt in enumerate(bot.joints)))


if __name__ == "__main__":
    main(sys.argv[1:])

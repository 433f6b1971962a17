"""matplotlib (Agg) figures of a run: joints planned vs simulated, footfall (Hildebrand) diagram
planned vs simulated, servo torque against the torque–speed envelope, base motion.

Every function returns PNG bytes, so the report can embed them and nothing needs a display.
"""

from __future__ import annotations

import io
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from robots.gait import Gait
from sim.metrics import foot_down, roll_pitch_of
from sim.model import SimModel
from sim.rollout import Trajectory

SHOW_CYCLES = 2


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()


def _last_cycles(traj: Trajectory, n: int = SHOW_CYCLES) -> np.ndarray:
    """Mask of the last `n` whole gait cycles of the run (or the whole gait if shorter)."""
    end_cycle = math.floor((traj.time_s[-1] - traj.gait_start_s) / traj.period_s + 1e-9)
    start_cycle = max(0, end_cycle - n)
    t0 = traj.gait_start_s + start_cycle * traj.period_s
    t1 = traj.gait_start_s + max(end_cycle, start_cycle + 1) * traj.period_s
    mask = (traj.time_s > t0) & (traj.time_s <= t1 + 1e-9)
    return mask if np.any(mask) else np.ones_like(traj.time_s, dtype=bool)


def joints_plot(traj: Trajectory, sim: SimModel) -> bytes:
    """One panel per joint: planned motion (and the servo goals, where they differ) vs simulated
    angle over the last cycles."""
    names = sim.robot.joint_names
    cols = max(1, min(len(sim.robot.legs), 6))
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(2.6 * cols, 1.9 * rows), sharex=True, squeeze=False
    )
    w = _last_cycles(traj)
    phase = traj.gait_phase()[w]
    for j, name in enumerate(names):
        ax = axes[j % rows][j // rows]
        ax.plot(
            phase, np.degrees(traj.expected_rad[w, j]), "--", color="0.35", lw=1.2, label="planned"
        )
        if not np.allclose(traj.expected_rad[w, j], traj.planned_rad[w, j]):
            ax.plot(phase, np.degrees(traj.planned_rad[w, j]), ":", color="tab:orange", lw=1.0,
                    label="servo goal")
        ax.plot(phase, np.degrees(traj.q_rad[w, j]), color="tab:blue", lw=1.2, label="simulated")
        ax.set_title(name, fontsize=8)
        ax.tick_params(labelsize=7)
    for k in range(len(names), rows * cols):
        axes[k % rows][k // rows].axis("off")
    axes[0][0].legend(fontsize=7)
    fig.supxlabel("gait cycles", fontsize=8)
    fig.supylabel("joint angle [°]", fontsize=8)
    fig.tight_layout()
    return _png(fig)


def footfall_plot(traj: Trajectory, sim: SimModel, gait: Gait) -> bytes:
    """Hildebrand diagram: stance bars per foot, planned schedule above simulated contact."""
    feet = sim.robot.foot_names
    w = _last_cycles(traj)
    phase = traj.gait_phase()[w]
    down = foot_down(traj, sim)[w]
    fig, axes = plt.subplots(2, 1, figsize=(8, 0.45 * len(feet) * 2 + 1.2), sharex=True)
    sched = gait.schedule
    for f in range(len(feet)):
        planned = np.array([sched.in_stance(f, p % 1.0) for p in phase])
        for ax, on, color in ((axes[0], planned, "0.3"), (axes[1], down[:, f], "tab:green")):
            edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(np.int8), [0]])))
            spans = [
                (phase[a], phase[min(b, len(phase) - 1)] - phase[a])
                for a, b in zip(edges[0::2], edges[1::2], strict=True)
            ]
            ax.broken_barh(spans, (f - 0.35, 0.7), color=color)
    for ax, title in ((axes[0], "planned stance"), (axes[1], "simulated contact")):
        ax.set_yticks(range(len(feet)), feet, fontsize=8)
        ax.set_ylim(-0.6, len(feet) - 0.4)
        ax.invert_yaxis()
        ax.set_title(title, fontsize=9)
        ax.grid(axis="x", alpha=0.3)
    axes[1].set_xlabel("gait cycles")
    fig.tight_layout()
    return _png(fig)


def torque_envelope_plot(traj: Trajectory, sim: SimModel, limit_fraction: float = 0.8) -> bytes:
    """Servo torque vs speed (normalised by stall torque and no-load speed) on the envelope."""
    w = traj.time_s > traj.gait_start_s
    if not np.any(w):
        w = np.ones_like(traj.time_s, dtype=bool)
    stall = sim.stall_torque_nm
    omega = np.array([s.no_load_speed_rad_s for s in sim.servos])
    x = traj.qd_rad_s[w] / omega
    y = traj.torque_nm[w] / stall
    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    for leg in sim.robot.legs:
        cols = [sim.robot.joint_names.index(j) for j in leg.joints]
        ax.scatter(x[::4, cols].ravel(), y[::4, cols].ravel(), s=2, alpha=0.35, label=leg.name)
    s = np.linspace(-1.2, 1.2, 200)
    strength = sim.conditions.strength
    ax.plot(s, strength * (1 - s), color="k", lw=1.2, label="DC-motor band (full duty)")
    ax.plot(s, strength * (-1 - s), color="k", lw=1.2)
    u = np.linspace(-1.0, 1.0, 101)
    ax.plot(u, 1 - np.abs(u), ":", color="tab:red", lw=1.2, label="planner envelope τ_s(1−|q̇|/ω₀)")
    ax.plot(u, np.abs(u) - 1, ":", color="tab:red", lw=1.2)
    for sign in (1, -1):
        ax.axhline(sign * limit_fraction, color="tab:orange", lw=0.8, ls="--")
    ax.set_xlim(-1.2, 1.2)
    ax.set_ylim(-2.0, 2.0)
    ax.set_xlabel("joint speed / no-load speed")
    ax.set_ylabel("servo torque / stall torque")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, markerscale=4, loc="upper right")
    fig.tight_layout()
    return _png(fig)


def base_plot(traj: Trajectory) -> bytes:
    """Base height, roll and pitch, forward position over the whole run."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 5.5), sharex=True)
    t = traj.time_s
    roll, pitch = roll_pitch_of(traj.base_quat)
    axes[0].plot(t, traj.base_pos_m[:, 2] * 100)
    axes[0].set_ylabel("height [cm]")
    axes[1].plot(t, np.degrees(roll), label="roll")
    axes[1].plot(t, np.degrees(pitch), label="pitch")
    axes[1].set_ylabel("[°]")
    axes[1].legend(fontsize=7)
    axes[2].plot(t, traj.base_pos_m[:, 0], label="x")
    axes[2].plot(t, traj.base_pos_m[:, 1], label="y")
    axes[2].set_ylabel("position [m]")
    axes[2].legend(fontsize=7)
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        ax.axvline(traj.gait_start_s, color="0.5", lw=0.8, ls="--")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return _png(fig)

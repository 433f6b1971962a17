"""The fit against the record: per excited joint, measured vs simulated angle and the goal."""

from __future__ import annotations

import io
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from robots.files import atomic_write_bytes
from robots.robot import Robot
from sim.identify.fit import IdentifyResult

MAX_PANELS = 24


def plot_fit(result: IdentifyResult, robot: Robot, out_path: str | Path, title: str = "") -> Path:
    """PNG: one panel per excited joint (at most `MAX_PANELS`), its held-back part shaded,
    the held-back RMS in the panel's title."""
    fits = {f.name: f for f in result.fits}
    panels = [(tr, n) for tr in result.traces for n in range(len(tr.joints))][:MAX_PANELS]
    cols = min(3, len(panels))
    rows = math.ceil(len(panels) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 2.4 * rows), squeeze=False)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax, (tr, n) in zip(axes.flat, panels, strict=False):
        name = robot.joints[tr.joints[n]].name
        t = tr.t_s - tr.t_s[0]
        ax.plot(t, np.degrees(tr.goal_rad[n]), color="0.6", lw=0.8, label="goal sent")
        ax.plot(t, np.degrees(tr.measured_rad[n]), color="C0", lw=1.2, label="measured")
        ax.plot(t, np.degrees(tr.simulated_rad[n]), color="C3", lw=0.9, ls="--", label="fit")
        if np.any(tr.held_out):
            ax.axvspan(t[tr.held_out][0], t[-1], color="C2", alpha=0.08, label="held back")
        f = fits[name]
        s = f.setting
        ax.set_title(
            f"{name}: gain ×{s.gain_scale:.3f}, {s.latency_ms:.1f} ms, strength "
            f"×{s.strength:.3f}; held-back RMS {math.degrees(f.held_out_rms_rad):.3f}°",
            fontsize=8,
        )
        ax.set_xlabel("t in window [s]", fontsize=7)
        ax.set_ylabel("angle [deg]", fontsize=7)
        ax.tick_params(labelsize=7)
    axes.flat[0].legend(fontsize=6, loc="upper right")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=72)
    plt.close(fig)
    atomic_write_bytes(out_path, buf.getvalue())
    return Path(out_path)

"""The run report's figures (matplotlib, Agg), each returned as PNG bytes.

Every figure draws measured series from the telemetry beside the plan / prediction the report
computed (`hardware.play.run_report.RunReport`); the departure, when there is one, is a red line.
"""

from __future__ import annotations

import io
import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from hardware.play.run_report import RunReport

PHASE_COLOURS = {"ramp_in": "#e3f2fd", "blend_in": "#e8f5e9", "ramp_out": "#f3e5f5"}


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    _plt().close(fig)
    return buf.getvalue()


def _grid(n: int, row_h: float = 2.1) -> tuple[Any, list[Any]]:
    plt = _plt()
    ncols = 3 if n > 4 else max(1, n)
    nrows = math.ceil(n / ncols)
    height = row_h * nrows + 0.6
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.3 * ncols, height), squeeze=False,
                             sharex=True)
    # fixed margins: constrained_layout costs seconds on a dozen axes
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.35 / height, top=1 - 0.55 / height,
                        wspace=0.22, hspace=0.38)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.set_visible(False)
    return fig, flat[:n]


def _shade_phases(ax: Any, rep: RunReport) -> None:
    t, phase = rep.series.t_s, rep.series.phase
    start = 0
    for k in range(1, len(phase) + 1):
        if k == len(phase) or phase[k] != phase[start]:
            colour = PHASE_COLOURS.get(phase[start])
            if colour is not None and k - 1 > start:
                ax.axvspan(t[start], t[k - 1], color=colour, lw=0)
            start = k


def _mark_departure(ax: Any, rep: RunReport) -> None:
    if rep.departure is not None:
        ax.axvline(rep.departure.t_s, color="C3", lw=1.0)


def tracking_figure(rep: RunReport) -> bytes:
    """Per joint: planned (expected) angle, the logged target, the present position."""
    s = rep.series
    fig, axes = _grid(len(rep.joints))
    for j, (ax, jr) in enumerate(zip(axes, rep.joints, strict=True)):
        _shade_phases(ax, rep)
        ax.plot(s.t_s, s.planned_expected_rad[:, j], color="0.55", lw=2.2, label="planned")
        ax.plot(s.t_s, s.target_rad[:, j], color="C0", lw=0.9, label="target")
        ax.plot(s.t_s, s.present_rad[:, j], color="C1", lw=0.9, ls="--", label="present")
        _mark_departure(ax, rep)
        colour = "C3" if rep.departure and rep.departure.joint == jr.joint else "black"
        ax.set_title(jr.joint, fontsize=9, color=colour)
        ax.tick_params(labelsize=7)
        if j == 0:
            ax.legend(fontsize=7)
            ax.set_ylabel("angle [rad]", fontsize=8)
    fig.suptitle("tracking: planned vs target vs present (shaded: ramp_in / blend_in / "
                 "ramp_out; red: departure)", fontsize=10)
    return _png(fig)


def error_figure(rep: RunReport) -> bytes:
    """|present − planned| per joint over the gait ticks, each with its departure threshold."""
    s = rep.series
    fig, axes = _grid(len(rep.joints), row_h=1.7)
    for j, (ax, jr) in enumerate(zip(axes, rep.joints, strict=True)):
        ax.plot(s.t_s, s.plan_error_rad[:, j], color="C2", lw=0.9)
        if math.isfinite(jr.threshold_rad):
            ax.axhline(jr.threshold_rad, color="C3", ls=":", lw=1.0)
        _mark_departure(ax, rep)
        ax.set_title(jr.joint, fontsize=9)
        ax.tick_params(labelsize=7)
        if j == 0:
            ax.set_ylabel("|present − planned| [rad]", fontsize=8)
    fig.suptitle("plan tracking error in the gait phase (dotted: threshold)", fontsize=10)
    return _png(fig)


def load_figure(rep: RunReport) -> bytes:
    """Per joint: the measured load (N·m with a robot, else %) on status ticks, the planned
    torque, and the servo envelope at the measured speed."""
    s = rep.series
    fig, axes = _grid(len(rep.joints))
    newton = s.torque_nm is not None
    for j, (ax, jr) in enumerate(zip(axes, rep.joints, strict=True)):
        _shade_phases(ax, rep)
        y = s.torque_nm[:, j] if s.torque_nm is not None else s.load_pct[:, j]
        have = np.isfinite(y)
        ax.plot(s.t_s[have], y[have], color="C0", lw=0.9, marker=".", ms=2, label="measured")
        if newton and s.planned_torque_nm is not None:
            ax.plot(s.t_s, s.planned_torque_nm[:, j], color="0.55", lw=1.6, label="planned")
        if s.envelope_nm is not None:
            ax.plot(s.t_s, s.envelope_nm[:, j], color="C3", lw=0.8, ls="--", label="envelope")
            ax.plot(s.t_s, -s.envelope_nm[:, j], color="C3", lw=0.8, ls="--")
        else:
            for lim in (100.0, -100.0):
                ax.axhline(lim, color="C3", lw=0.8, ls="--")
        _mark_departure(ax, rep)
        ax.set_title(jr.joint, fontsize=9)
        ax.tick_params(labelsize=7)
        if j == 0:
            ax.legend(fontsize=7)
            ax.set_ylabel("torque [N·m]" if newton else "load [% of max]", fontsize=8)
    fig.suptitle("load vs the servo envelope", fontsize=10)
    return _png(fig)


def temperature_figure(rep: RunReport) -> bytes:
    """Measured temperatures (one line per joint) and each prediction from its first reading."""
    plt = _plt()
    s = rep.series
    fig, ax = plt.subplots(figsize=(9, 3.6), constrained_layout=True)
    for j, jr in enumerate(rep.joints):
        y = s.temperature_c[:, j]
        have = np.flatnonzero(np.isfinite(y))
        if not have.size:
            continue
        colour = f"C{j % 10}"
        ax.step(s.t_s[have], y[have], where="post", color=colour, lw=0.9, label=jr.joint)
        rise, tau = jr.predicted_steady_rise_k, jr.thermal_tau_s
        if rise is not None and tau is not None and jr.temp_span_s > 0:
            t = np.linspace(0.0, jr.temp_span_s, 60)
            ax.plot(s.t_s[have[0]] + t, jr.temp_first_c + rise * (1.0 - np.exp(-t / tau)),
                    color=colour, lw=0.8, ls=":")
    _mark_departure(ax, rep)
    ax.set_xlabel("time [s]", fontsize=8)
    ax.set_ylabel("temperature [°C]", fontsize=8)
    ax.set_title("servo temperature (solid: measured; dotted: predicted from the first reading)",
                 fontsize=10)
    if rep.joints:
        ax.legend(fontsize=6, ncols=4)
    ax.grid(alpha=0.3)
    return _png(fig)


def timing_figure(rep: RunReport) -> bytes:
    """Wake-up jitter and tick work per tick; overruns in red."""
    plt = _plt()
    s = rep.series
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 3.2), constrained_layout=True,
                                 gridspec_kw={"width_ratios": [3, 1]})
    a1.plot(s.t_s, s.jitter_s * 1e3, lw=0.7, label="jitter")
    a1.plot(s.t_s, s.loop_s * 1e3, lw=0.7, label="tick work")
    if np.any(s.overrun):
        a1.plot(s.t_s[s.overrun], s.jitter_s[s.overrun] * 1e3, "r.", ms=3, label="overrun")
    period_ms = 1e3 / rep.timing.requested_hz if math.isfinite(rep.timing.requested_hz) else None
    if period_ms is not None:
        a1.axhline(period_ms, color="C3", ls="--", lw=0.8, label="tick period")
    a1.set_xlabel("time [s]", fontsize=8)
    a1.set_ylabel("[ms]", fontsize=8)
    a1.legend(fontsize=7)
    j = s.jitter_s[np.isfinite(s.jitter_s)] * 1e3
    if j.size:
        a2.hist(j, bins=40, color="C0")
    a2.set_xlabel("jitter [ms]", fontsize=8)
    a2.set_ylabel("ticks", fontsize=8)
    fig.suptitle("loop timing", fontsize=10)
    return _png(fig)

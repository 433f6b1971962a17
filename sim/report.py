"""One self-contained HTML report of a validation: verdict, checks, metrics, per-joint table and
the plots as base64-embedded PNGs (no external files). Written atomically."""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path

from robots.gait import Gait, atomic_write_text
from sim import plots
from sim.errors import ReportError
from sim.model import SimModel
from sim.robustness import RobustnessResult
from sim.validate import ValidationResult

_CSS = """
body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1100px;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;
font-size:13px;text-align:left}th{background:#f3f3f3}.pass{color:#0a7d2c}.fail{color:#b3261e}
img{max-width:100%;border:1px solid #ddd;margin:.5em 0}h1{margin-bottom:.2em}
"""

# (metric key, label, unit scale, unit)
_ROWS: tuple[tuple[str, str, float, str], ...] = (
    ("commanded_speed_m_s", "commanded speed", 1.0, "m/s"),
    ("achieved_speed_m_s", "achieved speed", 1.0, "m/s"),
    ("speed_error_fraction", "speed error", 100.0, "%"),
    ("distance_m", "distance (steady cycles)", 1.0, "m"),
    ("lateral_drift_per_m", "lateral drift", 1.0, "m/m"),
    ("yaw_drift_rad_per_m", "yaw drift", 180.0 / math.pi, "°/m"),
    ("base_height_min_m", "base height min", 100.0, "cm"),
    ("base_height_max_m", "base height max", 100.0, "cm"),
    ("tilt_max_rad", "max tilt", 180.0 / math.pi, "°"),
    ("slip_mean_m", "foot slip per stance (mean)", 1000.0, "mm"),
    ("slip_max_m", "foot slip per stance (max)", 1000.0, "mm"),
    ("peak_torque_fraction", "peak torque / stall", 100.0, "%"),
    ("rms_torque_fraction", "RMS torque / stall (worst joint)", 100.0, "%"),
    ("saturation_fraction", "time at full duty", 100.0, "%"),
    ("tracking_rms_rad", "tracking error RMS", 180.0 / math.pi, "°"),
    ("tracking_max_rad", "tracking error max", 180.0 / math.pi, "°"),
    ("mechanical_power_w", "mechanical power Σ|τ·q̇|", 1.0, "W"),
    ("cost_of_transport", "cost of transport", 1.0, ""),
)


def _fmt(v: object, scale: float = 1.0) -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float)):
        return f"{float(v) * scale:.3g}"
    return html.escape(str(v))


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"/>'


def _robustness_html(sweep: RobustnessResult) -> list[str]:
    """The robustness sweep as a table: one row per perturbed run."""
    parts = [
        f"<h2>Robustness</h2><p>{sweep.pass_fraction:.0%} of {len(sweep.runs)} perturbed runs "
        "pass.</p><table><tr><th>factor</th><th>value</th><th>verdict</th>"
        "<th>speed [m/s]</th><th>peak τ/stall</th><th>fell</th><th>why</th></tr>"
    ]
    for r in sweep.runs:
        cls = "pass" if r.passed else "fail"
        parts.append(
            f"<tr><td>{html.escape(r.factor)}</td><td>{r.value:g}</td>"
            f"<td class='{cls}'>{'pass' if r.passed else 'FAIL'}</td>"
            f"<td>{r.achieved_speed_m_s:.3f}</td><td>{r.peak_torque_fraction:.0%}</td>"
            f"<td>{'yes' if r.fell else 'no'}</td>"
            f"<td>{html.escape('; '.join(r.reasons)) or '—'}</td></tr>"
        )
    parts.append("</table>")
    return parts


def render_html(
    result: ValidationResult, gait: Gait, sim: SimModel, *, title: str | None = None,
    robustness: RobustnessResult | None = None,
) -> str:
    """The report as an HTML string (needs `result.trajectory`); with `robustness`, the
    perturbed runs of the robustness sweep as a table after the per-joint one."""
    traj = result.trajectory
    if traj is None:
        raise ReportError(
            "the report needs the run's trajectory (validate(..., keep_trajectory=True))"
        )
    verdict = "PASS" if result.passed else "FAIL"
    cls = "pass" if result.passed else "fail"
    m = result.metrics.to_dict()
    name = title or f"{gait.robot} · {gait.gait_label} · {gait.velocity.vx_m_s:.3g} m/s"
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>{html.escape(name)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(name)}</h1>",
        f"<p>Verdict: <b class='{cls}'>{verdict}</b> — robot {html.escape(gait.robot)}@"
        f"{html.escape(gait.robot_fingerprint)}, period {gait.period_s:.3f} s, "
        f"{result.metrics.cycles_run} cycles simulated.</p>",
        "<h2>Checks</h2><table><tr><th>check</th><th>result</th><th>detail</th></tr>",
    ]
    for check, ok, detail in result.checks:
        parts.append(
            f"<tr><td>{html.escape(check)}</td><td class='{'pass' if ok else 'fail'}'>"
            f"{'ok' if ok else 'FAIL'}</td><td>{html.escape(detail)}</td></tr>"
        )
    parts.append(
        "</table><h2>Metrics</h2><table><tr><th>metric</th><th>value</th><th>unit</th></tr>"
    )
    for key, label, scale, unit in _ROWS:
        parts.append(f"<tr><td>{label}</td><td>{_fmt(m.get(key), scale)}</td><td>{unit}</td></tr>")
    parts.append("</table><h2>Conditions</h2><table>")
    for key, value in result.conditions.items():
        parts.append(f"<tr><td>{html.escape(key)}</td><td>{_fmt(value)}</td></tr>")
    parts.append(
        "</table><h2>Joints</h2><table><tr><th>joint</th><th>peak τ/stall</th>"
        "<th>RMS τ/stall</th><th>tracking RMS [°]</th><th>peak speed [rad/s]</th></tr>"
    )
    for j in result.joints:
        parts.append(
            f"<tr><td>{html.escape(j.name)}</td><td>{j.peak_torque_fraction:.0%}</td>"
            f"<td>{j.rms_torque_fraction:.0%}</td><td>{math.degrees(j.tracking_rms_rad):.2f}</td>"
            f"<td>{j.peak_speed_rad_s:.2f}</td></tr>"
        )
    parts.append("</table>")
    if robustness is not None:
        parts.extend(_robustness_html(robustness))
    try:
        figures = (
            ("Joint angles: planned vs simulated (last cycles)", plots.joints_plot(traj, sim)),
            ("Footfall (Hildebrand) diagram", plots.footfall_plot(traj, sim, gait)),
            (
                "Servo torque against the torque–speed envelope",
                plots.torque_envelope_plot(traj, sim, result.criteria.max_peak_torque_fraction),
            ),
            ("Base motion", plots.base_plot(traj)),
        )
    except Exception as exc:  # matplotlib errors are not user errors, but must not be tracebacks
        raise ReportError(f"cannot draw the report's plots: {exc}") from exc
    for caption, png in figures:
        parts.append(f"<h2>{html.escape(caption)}</h2>{_img(png, caption)}")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(path: str | Path, result: ValidationResult, gait: Gait, sim: SimModel, *,
                 robustness: RobustnessResult | None = None) -> Path:
    """Write the HTML report atomically (with the robustness table if given)."""
    p = Path(path)
    text = render_html(result, gait, sim, robustness=robustness)
    atomic_write_text(p, text)  # a failed write is an OutputWriteError naming the file
    return p

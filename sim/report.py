"""One self-contained HTML report of a validation: verdict, checks, metrics, per-joint table and
the plots as base64-embedded PNGs (no external files). Written atomically. `write_drive_report`
does the same for a drive-sim run (`sim.path`)."""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path

from robots.gait import Gait, atomic_write_text
from robots.voltage import VoltageMargin
from sim import plots
from sim.errors import ReportError
from sim.model import SimModel
from sim.path.follow import FollowLog
from sim.path.metrics import DriveResult
from sim.robustness import RobustnessResult
from sim.thermal_report import ThermalPrediction, temperature_plot
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


def _thermal_html(pred: ThermalPrediction, voltage: VoltageMargin | None) -> list[str]:
    """The heating prediction per joint (hottest first), and the supply margin if given."""
    parts = []
    if voltage is not None:
        parts.append(f"<h2>Supply voltage</h2><p>{html.escape(voltage.summary())}; the "
                     "torque–speed envelope scales ∝ V/V<sub>nominal</sub>.</p>")
    parts.append(
        f"<h2>Predicted servo heating</h2><p>{html.escape(pred.summary())}. First-order model "
        "(robots.thermal): winding heat I²R with current ∝ |τ|, thermal resistance and time "
        "constant estimated from a measured servo test — check against the servos' "
        "temperature readings.</p><table><tr><th>joint</th><th>servo</th>"
        "<th>mean heat [W]</th><th>rise after bout [K]</th><th>after bout [°C]</th>"
        "<th>steady [°C]</th><th>limit [°C]</th><th>minutes to limit</th></tr>"
    )
    for h in pred.hottest:
        mins = "never" if h.minutes_to_limit is None else f"{h.minutes_to_limit:.1f}"
        cls = " class='fail'" if h.minutes_to_limit is not None else ""
        parts.append(
            f"<tr><td>{html.escape(h.joint)}</td><td>{html.escape(h.servo)}</td>"
            f"<td>{h.mean_power_w:.2f}</td><td>{h.rise_after_bout_k:.1f}</td>"
            f"<td>{h.temperature_after_bout_c:.1f}</td>"
            f"<td>{pred.ambient_c + h.steady_rise_k:.1f}</td><td>{h.max_temperature_c:.0f}</td>"
            f"<td{cls}>{mins}</td></tr>"
        )
    parts.append("</table>")
    if pred.unmodelled:
        parts.append("<p>No thermal data (no published stall current): "
                     f"{html.escape(', '.join(pred.unmodelled))}.</p>")
    return parts


def _planned_clearance_rad(gait: Gait) -> dict[str, tuple[float, float]]:
    """Per joint from the planner's metadata (`planner.nlp.metadata.joint_limit_clearance`):
    (closest approach of the planned angles and servo goals to a limit, the margin the planner
    kept), both in rad; empty for gaits without that block (older files, synthetic gaits)."""
    block = (gait.planner or {}).get("joint_limit_clearance")
    out: dict[str, tuple[float, float]] = {}
    if not isinstance(block, dict):
        return out
    for name, entry in block.items():
        try:
            out[str(name)] = (float(entry["closest_rad"]), float(entry["margin_rad"]))
        except (KeyError, TypeError, ValueError):
            continue  # a hand-edited or partial block: show "—" for that joint
    return out


def _deg(v: float | None) -> str:
    return "—" if v is None or not math.isfinite(v) else f"{math.degrees(v):.1f}"


def _joints_html(result: ValidationResult, gait: Gait) -> list[str]:
    """The per-joint table: torque, tracking, speed and each joint's closest approach to its
    limits, planned (from the gait's planner metadata, with the margin the planner kept) and
    simulated (over the steady cycles). A simulated approach inside the planner's margin is
    marked: the joint ran closer to its stop than the plan allowed."""
    planned = _planned_clearance_rad(gait)
    parts = [
        "<h2>Joints</h2><p>Closest approach to a joint limit: the smallest distance of the "
        "joint's angle to the nearer end of its range (the MJCF range narrowed to the servo's), "
        "planned (angles and servo goals, with the margin the planner kept) and simulated "
        "(steady cycles).</p><table><tr><th>joint</th><th>peak τ/stall</th>"
        "<th>RMS τ/stall</th><th>tracking RMS [°]</th><th>peak speed [rad/s]</th>"
        "<th>closest to limit, planned [°] (margin)</th>"
        "<th>closest to limit, simulated [°]</th><th>of range</th></tr>"
    ]
    for j in result.joints:
        plan, margin = planned.get(j.name, (None, None))
        sim_c = j.limit_clearance_rad
        cls = " class='fail'" if margin is not None and sim_c < margin else ""
        parts.append(
            f"<tr><td>{html.escape(j.name)}</td><td>{j.peak_torque_fraction:.0%}</td>"
            f"<td>{j.rms_torque_fraction:.0%}</td><td>{math.degrees(j.tracking_rms_rad):.2f}</td>"
            f"<td>{j.peak_speed_rad_s:.2f}</td>"
            f"<td>{_deg(plan)} ({_deg(margin)})</td><td{cls}>{_deg(sim_c)}</td>"
            f"<td>{j.limit_clearance_fraction:.0%}</td></tr>"
        )
    parts.append("</table>")
    return parts


def render_html(
    result: ValidationResult, gait: Gait, sim: SimModel, *, title: str | None = None,
    robustness: RobustnessResult | None = None, thermal: ThermalPrediction | None = None,
    voltage: VoltageMargin | None = None,
) -> str:
    """The report as an HTML string (needs `result.trajectory`); with `robustness`, the
    perturbed runs of the robustness sweep as a table after the per-joint one; with `thermal`
    (and `voltage`), the predicted heating per joint and its plot, and the supply margin."""
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
    parts.append("</table>")
    parts.extend(_joints_html(result, gait))
    if robustness is not None:
        parts.extend(_robustness_html(robustness))
    if thermal is not None:
        parts.extend(_thermal_html(thermal, voltage))
    try:
        figures = (
            ("Joint angles: planned vs simulated (last cycles)", plots.joints_plot(traj, sim)),
            ("Footfall (Hildebrand) diagram", plots.footfall_plot(traj, sim, gait)),
            (
                "Servo torque against the torque–speed envelope",
                plots.torque_envelope_plot(traj, sim, result.criteria.max_peak_torque_fraction),
            ),
            ("Base motion", plots.base_plot(traj)),
        ) + (
            (("Predicted servo temperature over the bout", temperature_plot(thermal)),)
            if thermal is not None and thermal.joints else ()
        )
    except Exception as exc:  # matplotlib errors are not user errors, but must not be tracebacks
        raise ReportError(f"cannot draw the report's plots: {exc}") from exc
    for caption, png in figures:
        parts.append(f"<h2>{html.escape(caption)}</h2>{_img(png, caption)}")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(path: str | Path, result: ValidationResult, gait: Gait, sim: SimModel, *,
                 robustness: RobustnessResult | None = None,
                 thermal: ThermalPrediction | None = None,
                 voltage: VoltageMargin | None = None) -> Path:
    """Write the HTML report atomically (with the robustness, heating and supply sections if
    given)."""
    p = Path(path)
    text = render_html(result, gait, sim, robustness=robustness, thermal=thermal,
                       voltage=voltage)
    atomic_write_text(p, text)  # a failed write is an OutputWriteError naming the file
    return p


# ---------------------------------------------------------------------------------------------
# drive-sim (`gaitsmith drive-sim`): a path followed through a gait library


def render_drive_html(result: DriveResult, log: FollowLog, robot: str, *, library: str,
                      plot_png: bytes, conditions: dict[str, object]) -> str:
    """The drive-sim report: verdict, checks, metrics, conditions, per-joint peak torque and the
    planned vs driven path plot (embedded)."""
    m = result.metrics
    name = f"{robot} · drive-sim · {log.path.spec}" + (f" × {log.laps}" if log.laps > 1 else "")
    cls = "pass" if result.passed else "fail"
    deg = 180.0 / math.pi
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>{html.escape(name)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(name)}</h1>",
        f"<p>Verdict: <b class='{cls}'>{'PASS' if result.passed else 'FAIL'}</b> — library "
        f"{html.escape(library)}, path {log.total_length_m:.2f} m.</p>",
        "<h2>Checks</h2><table><tr><th>check</th><th>result</th><th>detail</th></tr>",
    ]
    for check, ok, detail in result.checks:
        parts.append(f"<tr><td>{html.escape(check)}</td><td class='{'pass' if ok else 'fail'}'>"
                     f"{'ok' if ok else 'FAIL'}</td><td>{html.escape(detail)}</td></tr>")
    rows = (
        ("cross-track error mean / max", f"{m.cross_track_mean_m * 100:.2f} / "
         f"{m.cross_track_max_m * 100:.2f} cm"),
        ("heading error mean / max", f"{m.heading_error_mean_rad * deg:.1f} / "
         f"{m.heading_error_max_rad * deg:.1f}°"),
        ("time (first command → standing at the end)", f"{m.time_s:.1f} s"),
        ("distance driven / planned", f"{m.distance_m:.2f} / {m.planned_distance_m:.2f} m"),
        ("mean speed", f"{m.mean_speed_m_s:.3f} m/s"),
        ("servo peak torque", f"{m.peak_torque_fraction:.0%} of stall ({m.peak_torque_joint})"),
        ("fall", "no" if not m.fell else f"at {m.fall_time_s:.2f} s ({m.fall_reason})"),
        ("footprints", str(m.footprints)),
        ("requests clipped into the command box", f"{m.clipped_fraction:.1%} of ticks"),
    )
    parts.append("</table><h2>Metrics</h2><table><tr><th>metric</th><th>value</th></tr>")
    parts += [f"<tr><td>{k}</td><td>{html.escape(v)}</td></tr>" for k, v in rows]
    parts.append("</table><h2>Conditions</h2><table>")
    parts += [f"<tr><td>{html.escape(k)}</td><td>{_fmt(v)}</td></tr>"
              for k, v in conditions.items()]
    parts.append("</table><h2>Peak torque per joint</h2><table><tr><th>joint</th>"
                 "<th>peak |τ| / stall</th></tr>")
    parts += [f"<tr><td>{html.escape(j)}</td><td>{f:.0%}</td></tr>"
              for j, f in result.joint_peak_fraction]
    caption = "Planned vs driven path, footprints; cross-track error and commands"
    parts.append(f"</table><h2>{caption}</h2>{_img(plot_png, caption)}</body></html>")
    return "\n".join(parts)


def write_drive_report(path: str | Path, result: DriveResult, log: FollowLog, robot: str, *,
                       library: str, plot_png: bytes, conditions: dict[str, object]) -> Path:
    """Write the drive-sim report atomically."""
    p = Path(path)
    atomic_write_text(p, render_drive_html(result, log, robot, library=library,
                                           plot_png=plot_png, conditions=conditions))
    return p

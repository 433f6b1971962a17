"""Planned vs measured after a run: `gaitsmith-play report TELEMETRY.csv GAIT.json -o run.html`.

"It walked in sim but not on the robot — why?" The report puts three things side by side:

- the real run: the player's telemetry (`hardware.play.telemetry`: targets, present positions,
  load, temperature, voltage, loop timing, phases ``ramp_in`` / ``blend_in`` / ``gait`` /
  ``ramp_out``, the stop row);
- the plan: the gait file's joint samples (the servo goals), the angles the robot is expected
  to reach (``expected_joint_angles_rad``, else the samples), its planned torques;
- the MuJoCo prediction: the gait's ``validation`` block (`gaitsmith simulate
  --write-validation`): the verdict, per-joint tracking and peak torque, and ``thermal`` (the
  predicted heating, `sim.thermal_report`); with ``--robot`` and no ``thermal`` block the heating
  is predicted from the planned torques (`hardware.play.thermal_watch.predicted_heating`).

Alignment: a gait tick's gait time is ``speed_scale · (t_sched − t_sched of the first gait
tick)``, exactly how the player sampled the gait (`Player._play`); the plan is evaluated there.
The telemetry does not record the speed scale: give the run's ``--speed-scale``; when the logged
targets do not follow the gait at that scale (median |target − plan| above
`PLAN_MISMATCH_RAD` on some joint) the report says so.

Per joint (gait ticks): servo tracking |present − target|, plan tracking |present − expected|
(RMS, max, median), next to the simulator's tracking RMS; load: peak |load| [% of max] and, with
``--robot``, the torque it means (load % × the joint servo's stall torque as the robot
configures it) against the servo's torque–speed envelope |τ| ≤ τ_stall·(1 − |q̇|/ω₀) at the
measured speed (q̇ from successive present positions) and against the planned / simulated peak;
temperature: the rise from the first to the last reading against the predicted rise over the
same span from the first reading, ΔT = P̄·R_th·(1 − e^(−t/τ_th)) (`robots.thermal`; the
register counts whole degrees, so short runs read 0–1 K). Loop timing: achieved rate, jitter
p50 / p99 / max, overruns, tick work p50 / p99, stop latency.

Where the run departed from the plan (`DepartureRule`): joint j departs at the first gait tick
where |present − expected| exceeds its threshold

    threshold_j = min(abs_rad, max(factor · median_j, floor_rad))

for `ticks` consecutive gait ticks (defaults: factor 3 × the joint's own median error in the
gait phase, capped at an absolute 0.1 rad, never below 0.02 rad so that a near-perfect joint's
quantisation does not count, 3 ticks so that one noisy read does not); the earliest joint is
named. Missing reads never count as exceeding.

No sim import (`hardware` never imports sim): without ``--robot`` the report reads files only and
never loads mujoco; with ``--robot``, `robots.load` parses the robot's MJCF with mujoco, as
every player command that loads a robot does.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hardware.play.errors import RunReportError
from hardware.play.telemetry import Telemetry, read_telemetry

if TYPE_CHECKING:
    from robots.gait import Gait
    from robots.robot import Robot

GAIT_PHASE = "gait"
PLAN_MISMATCH_RAD = 0.05  # median |target − plan| above this: the plan is not what was played


@dataclass(frozen=True)
class DepartureRule:
    """When a joint's plan tracking error counts as a departure (see the module docstring)."""

    factor: float = 3.0
    abs_rad: float = 0.1
    floor_rad: float = 0.02
    ticks: int = 3

    def __post_init__(self) -> None:
        for name in ("factor", "abs_rad", "floor_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise RunReportError(f"departure rule {name}", f"must be positive, got {v!r}")
        if self.floor_rad > self.abs_rad:
            raise RunReportError("departure rule", "floor_rad must not exceed abs_rad")
        if self.ticks < 1:
            raise RunReportError("departure rule ticks", f"must be ≥ 1, got {self.ticks}")

    def threshold_rad(self, median_rad: float) -> float:
        m = median_rad if math.isfinite(median_rad) else 0.0
        return min(self.abs_rad, max(self.factor * m, self.floor_rad))

    def describe(self) -> str:
        return (
            f"|present − planned| above min({self.abs_rad:g} rad, max({self.factor:g} × the "
            f"joint's median in the gait phase, {self.floor_rad:g} rad)) for {self.ticks} "
            "consecutive gait ticks"
        )


@dataclass(frozen=True)
class Departure:
    """The first departure from the plan."""

    joint: str
    t_s: float  # scheduled run time of the first exceeding tick
    tick: int
    cycle: int
    gait_phase: float  # 0..1 within the cycle
    error_rad: float
    threshold_rad: float

    def line(self) -> str:
        return (
            f"the run departed from the plan at t = {self.t_s:.3f} s (tick {self.tick}, cycle "
            f"{self.cycle + 1}, gait phase {self.gait_phase:.2f}): joint {self.joint} |present − "
            f"planned| = {self.error_rad:.3f} rad > its threshold {self.threshold_rad:.3f} rad"
        )


@dataclass(frozen=True)
class JointRun:
    """One joint over the run: tracking, load, heating — measured beside planned / predicted."""

    joint: str
    servo_rms_rad: float  # |present − target| over gait ticks (NaN: no gait ticks)
    servo_max_rad: float
    plan_rms_rad: float  # |present − expected| over gait ticks
    plan_max_rad: float
    plan_median_rad: float
    threshold_rad: float
    sim_tracking_rms_rad: float | None
    missed_reads: int
    load_peak_pct: float  # max |load| over the status ticks (NaN: none)
    stall_torque_nm: float | None  # with --robot
    torque_peak_nm: float | None
    envelope_peak_fraction: float | None  # max |τ| / τ_limit(q̇) (> 1: beyond the envelope)
    over_envelope_samples: int
    planned_peak_nm: float | None
    sim_peak_torque_fraction: float | None
    temp_first_c: float
    temp_last_c: float
    temp_span_s: float
    predicted_rise_k: float | None  # over temp_span_s from the first reading
    predicted_steady_rise_k: float | None  # P̄·R_th
    thermal_tau_s: float | None
    thermal_source: str | None  # "sim" / "plan"
    max_temperature_c: float | None

    @property
    def temp_rise_k(self) -> float:
        return self.temp_last_c - self.temp_first_c


@dataclass(frozen=True)
class LoopTiming:
    ticks: int
    requested_hz: float  # from the schedule's median step
    rate_hz: float
    jitter_p50_s: float
    jitter_p99_s: float
    jitter_max_s: float
    overruns: int
    work_p50_s: float
    work_p99_s: float
    stop_latency_s: float


@dataclass(frozen=True, eq=False)
class RunSeries:
    """The aligned series the figures draw (K ticks × J joints; NaN off gait ticks for plan)."""

    t_s: np.ndarray
    phase: tuple[str, ...]
    gait_mask: np.ndarray
    planned_goal_rad: np.ndarray
    planned_expected_rad: np.ndarray
    planned_torque_nm: np.ndarray | None
    target_rad: np.ndarray
    present_rad: np.ndarray
    plan_error_rad: np.ndarray
    load_pct: np.ndarray
    torque_nm: np.ndarray | None
    envelope_nm: np.ndarray | None
    temperature_c: np.ndarray
    jitter_s: np.ndarray
    loop_s: np.ndarray
    overrun: np.ndarray


@dataclass(frozen=True, eq=False)
class RunReport:
    telemetry_path: str
    gait_path: str
    robot: str | None
    gait_label: str
    period_s: float
    speed_scale: float
    stop_reason: str | None
    stop_message: str | None
    ticks_by_phase: Mapping[str, int]
    joints: tuple[JointRun, ...]
    departure: Departure | None
    rule: DepartureRule
    timing: LoopTiming
    sim_verdict: str | None
    warnings: tuple[str, ...]
    series: RunSeries

    def departure_line(self) -> str:
        if self.departure is not None:
            return self.departure.line()
        if not np.any(self.series.gait_mask):
            return (
                "no departure can be judged: the run has no gait-phase ticks (it stopped "
                f"before the gait began: {self.stop_reason or 'no stop row'})"
            )
        return (
            "the run never departed from the plan: no joint's |present − planned| exceeded its "
            f"threshold for {self.rule.ticks} consecutive gait ticks"
        )


# ---------------------------------------------------------------------------------------------
# inputs


def load_inputs(
    telemetry_path: str | Path, gait_path: str | Path, robot_name: str | None = None
) -> tuple[Telemetry, Gait, Robot | None]:
    """The telemetry, the gait and (with `robot_name`) the robot, or one RunReportError."""
    from robots.errors import RobotsError
    from robots.gait import load as load_gait
    from robots.gait import robot_for

    tp, gp = Path(telemetry_path), Path(gait_path)
    try:
        tel = read_telemetry(tp)
    except FileNotFoundError:
        raise RunReportError(str(tp), "no such telemetry file (write one with `gaitsmith-play "
                                      "run … --telemetry FILE`)") from None
    except (OSError, ValueError) as exc:  # UnicodeDecodeError is a ValueError
        text = str(exc)
        prefix = f"{tp}: "
        raise RunReportError(
            str(tp), text[len(prefix):] if text.startswith(prefix) else " ".join(text.split())
        ) from None
    if len(tel.tick) == 0:
        raise RunReportError(str(tp), "has no tick rows (the run never started streaming)")
    try:
        gait = load_gait(gp)
        robot = robot_for(gait, gp, robot_name) if robot_name is not None else None
    except RobotsError as exc:
        raise RunReportError(str(gp), str(exc).removeprefix(f"{gp}: ")) from None
    if tel.joint_names != gait.joint_names:
        raise RunReportError(
            str(tp),
            f"joints {list(tel.joint_names)} do not match the gait's {list(gait.joint_names)}: "
            "is this the telemetry of a run of that gait?",
        )
    return tel, gait, robot


def _validation(gait: Gait) -> dict[str, Any]:
    v = gait.validation
    return v if isinstance(v, dict) else {}


def _finite(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v) if math.isfinite(v) else None


def _sim_joints(gait: Gait) -> dict[str, dict[str, Any]]:
    rows = _validation(gait).get("joints")
    if not isinstance(rows, list):
        return {}
    return {r["name"]: r for r in rows if isinstance(r, dict) and isinstance(r.get("name"), str)}


def _thermal_predictions(gait: Gait, robot: Robot | None) -> dict[str, tuple[float, float, str]]:
    """{joint: (steady rise [K], τ_th [s], source)} from the validation block (or, with a robot,
    `predicted_heating`, which falls back to the planned torques)."""
    if robot is not None:
        from hardware.play.thermal_watch import predicted_heating

        return {
            p.joint: (p.steady_rise_k, p.model.tau_th_s, p.source)
            for p in predicted_heating(robot, gait).values()
        }
    block = _validation(gait).get("thermal")
    out: dict[str, tuple[float, float, str]] = {}
    if isinstance(block, dict) and isinstance(block.get("joints"), list):
        for j in block["joints"]:
            if not isinstance(j, dict) or not isinstance(j.get("joint"), str):
                continue
            rise, tau = _finite(j.get("steady_rise_k")), _finite(j.get("tau_th_s"))
            if rise is not None and tau is not None and tau > 0:
                out[j["joint"]] = (rise, tau, "sim")
    return out


def _sim_verdict(gait: Gait) -> str | None:
    v = _validation(gait)
    if "passed" not in v:
        return None
    if v.get("passed") is True:
        return "PASS"
    reasons = v.get("reasons")
    why = "; ".join(str(r) for r in reasons) if isinstance(reasons, list) else ""
    return "FAIL" + (f" — {why}" if why else "")


# ---------------------------------------------------------------------------------------------
# analysis


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else math.nan


def _max(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.max(x)) if x.size else math.nan


def _pct(x: np.ndarray, q: float) -> float:
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if x.size else math.nan


def _periodic_interp(knots: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """Per-knot values (N × J at phases k/N) linearly interpolated at `phase` (cycles)."""
    n = knots.shape[0]
    closed = np.vstack([knots, knots[:1]])
    x = (np.asarray(phase) % 1.0) * n
    grid = np.arange(n + 1)
    return np.column_stack([np.interp(x, grid, closed[:, j]) for j in range(knots.shape[1])])


def first_departure(
    t_s: np.ndarray,
    tick: np.ndarray,
    gait_time_s: np.ndarray,
    period_s: float,
    error_rad: np.ndarray,
    thresholds_rad: Sequence[float],
    joint_names: Sequence[str],
    ticks: int,
) -> Departure | None:
    """The earliest start of `ticks` consecutive exceeding gait ticks over all joints
    (`error_rad`: gait ticks × J, NaN = missed read, never exceeding)."""
    best: Departure | None = None
    for j, name in enumerate(joint_names):
        over = np.nan_to_num(error_rad[:, j], nan=0.0) > thresholds_rad[j]
        run = 0
        for k, o in enumerate(over):
            run = run + 1 if o else 0
            if run == ticks:
                start = k - ticks + 1
                if best is None or t_s[start] < best.t_s:
                    cyc = float(gait_time_s[start]) / period_s
                    whole = math.floor(cyc + 1e-9)
                    best = Departure(
                        name, float(t_s[start]), int(tick[start]), whole,
                        max(0.0, cyc - whole), float(error_rad[start, j]),
                        float(thresholds_rad[j]),
                    )
                break
    return best


def _timing(tel: Telemetry) -> LoopTiming:
    steps = np.diff(tel.t_sched_s)
    steps = steps[np.isfinite(steps) & (steps > 0)]
    requested = 1.0 / float(np.median(steps)) if steps.size else math.nan
    span = float(tel.t_actual_s[-1] - tel.t_actual_s[0]) if len(tel.tick) > 1 else 0.0
    rate = (len(tel.tick) - 1) / span if span > 0 else math.nan
    return LoopTiming(
        ticks=len(tel.tick),
        requested_hz=requested,
        rate_hz=rate,
        jitter_p50_s=_pct(tel.jitter_s, 50),
        jitter_p99_s=_pct(tel.jitter_s, 99),
        jitter_max_s=_max(tel.jitter_s),
        overruns=int(np.sum(tel.overrun)),
        work_p50_s=_pct(tel.loop_s, 50),
        work_p99_s=_pct(tel.loop_s, 99),
        stop_latency_s=tel.stop_done_s - tel.stop_requested_s,
    )


def analyse(
    tel: Telemetry,
    gait: Gait,
    robot: Robot | None = None,
    *,
    speed_scale: float = 1.0,
    rule: DepartureRule | None = None,
    telemetry_path: str = "<telemetry>",
    gait_path: str = "<gait>",
) -> RunReport:
    """Align the run with the plan and the prediction (see the module docstring)."""
    if not (math.isfinite(speed_scale) and speed_scale > 0):
        raise RunReportError("--speed-scale", f"must be a positive number, got {speed_scale!r}")
    rule = rule or DepartureRule()
    names = tel.joint_names
    n_t, n_j = tel.target_rad.shape
    gait_mask = np.array([p == GAIT_PHASE for p in tel.phase], dtype=bool)
    gidx = np.flatnonzero(gait_mask)
    gait_time = np.full(n_t, math.nan)
    if gidx.size:
        gait_time[gidx] = (tel.t_sched_s[gidx] - tel.t_sched_s[gidx[0]]) * speed_scale
    goal = np.full((n_t, n_j), math.nan)
    expected = np.full((n_t, n_j), math.nan)
    planned_tau = None
    if gidx.size:
        goal[gidx] = gait.joint_targets(gait_time[gidx])
        expected[gidx] = gait.expected_joint_angles(gait_time[gidx])
        if gait.joint_torques_nm is not None:
            planned_tau = np.full((n_t, n_j), math.nan)
            planned_tau[gidx] = _periodic_interp(
                gait.joint_torques_nm, gait_time[gidx] / gait.period_s
            )
    servo_err = np.abs(tel.present_rad - tel.target_rad)
    plan_err = np.abs(tel.present_rad - expected)
    warnings: list[str] = []
    if gidx.size:
        off = np.nanmedian(np.abs(tel.target_rad[gidx] - goal[gidx]), axis=0)
        worst = int(np.nanargmax(off)) if np.any(np.isfinite(off)) else 0
        if np.isfinite(off[worst]) and off[worst] > PLAN_MISMATCH_RAD:
            warnings.append(
                f"the logged targets do not follow this gait at speed scale {speed_scale:g} "
                f"(median |target − plan| {off[worst]:.3f} rad on {names[worst]}): give the "
                "run's --speed-scale, or check that this is the gait that was played"
            )
    else:
        warnings.append("no gait-phase ticks: the run stopped before the gait began")

    # the torque a load reading means, and the envelope at the measured speed
    torque = envelope = None
    stall: list[float | None] = [None] * n_j
    if robot is not None:
        stall = [j.servo.stall_torque_nm for j in robot.joints]
        torque = tel.load_pct / 100.0 * np.array(stall, dtype=float)
        dt = np.gradient(tel.t_actual_s) if n_t > 1 else np.ones(n_t)
        dt = np.where(dt > 0, dt, math.nan)
        speed = np.abs(np.gradient(tel.present_rad, axis=0) / dt[:, None]) if n_t > 1 else (
            np.zeros((n_t, n_j)))
        omega0 = np.array([j.servo.no_load_speed_rad_s for j in robot.joints])
        envelope = np.array(stall, dtype=float) * np.clip(1.0 - np.nan_to_num(speed) / omega0,
                                                           0.0, 1.0)
    sim_j = _sim_joints(gait)
    thermal = _thermal_predictions(gait, robot)
    medians = [
        float(np.nanmedian(plan_err[gidx, j])) if gidx.size and np.any(
            np.isfinite(plan_err[gidx, j])) else math.nan
        for j in range(n_j)
    ]
    thresholds = [rule.threshold_rad(m) for m in medians]
    departure = (
        first_departure(tel.t_sched_s[gidx], tel.tick[gidx], gait_time[gidx], gait.period_s,
                        plan_err[gidx], thresholds, names, rule.ticks)
        if gidx.size else None
    )
    joints = []
    for j, name in enumerate(names):
        temps = tel.temperature_c[:, j]
        have_t = np.flatnonzero(np.isfinite(temps))
        t_first = float(temps[have_t[0]]) if have_t.size else math.nan
        t_last = float(temps[have_t[-1]]) if have_t.size else math.nan
        span = float(tel.t_actual_s[have_t[-1]] - tel.t_actual_s[have_t[0]]) if have_t.size \
            else 0.0
        pred = thermal.get(name)
        predicted = None if pred is None else pred[0] * (1.0 - math.exp(-span / pred[1]))
        sim = sim_j.get(name, {})
        env_frac = over = None
        if torque is not None and envelope is not None:
            ratio = np.abs(torque[:, j]) / np.where(envelope[:, j] > 0, envelope[:, j], math.nan)
            env_frac = _max(ratio)
            over = int(np.sum(np.nan_to_num(ratio, nan=0.0) > 1.0))
        joints.append(JointRun(
            joint=name,
            servo_rms_rad=_rms(servo_err[gidx, j]) if gidx.size else math.nan,
            servo_max_rad=_max(servo_err[gidx, j]) if gidx.size else math.nan,
            plan_rms_rad=_rms(plan_err[gidx, j]) if gidx.size else math.nan,
            plan_max_rad=_max(plan_err[gidx, j]) if gidx.size else math.nan,
            plan_median_rad=medians[j],
            threshold_rad=thresholds[j],
            sim_tracking_rms_rad=_finite(sim.get("tracking_rms_rad")),
            missed_reads=int(np.sum(~np.isfinite(tel.present_rad[:, j]))),
            load_peak_pct=_max(np.abs(tel.load_pct[:, j])),
            stall_torque_nm=stall[j],
            torque_peak_nm=None if torque is None else _max(np.abs(torque[:, j])),
            envelope_peak_fraction=env_frac,
            over_envelope_samples=over or 0,
            planned_peak_nm=None if gait.joint_torques_nm is None else float(
                np.max(np.abs(gait.joint_torques_nm[:, j]))),
            sim_peak_torque_fraction=_finite(sim.get("peak_torque_fraction")),
            temp_first_c=t_first,
            temp_last_c=t_last,
            temp_span_s=span,
            predicted_rise_k=predicted,
            predicted_steady_rise_k=None if pred is None else pred[0],
            thermal_tau_s=None if pred is None else pred[1],
            thermal_source=None if pred is None else pred[2],
            max_temperature_c=None if robot is None else robot.joints[j].servo.max_temperature_c,
        ))
    by_phase: dict[str, int] = {}
    for p in tel.phase:
        by_phase[p] = by_phase.get(p, 0) + 1
    series = RunSeries(
        t_s=tel.t_sched_s, phase=tel.phase, gait_mask=gait_mask, planned_goal_rad=goal,
        planned_expected_rad=expected, planned_torque_nm=planned_tau, target_rad=tel.target_rad,
        present_rad=tel.present_rad, plan_error_rad=plan_err, load_pct=tel.load_pct,
        torque_nm=torque, envelope_nm=envelope, temperature_c=tel.temperature_c,
        jitter_s=tel.jitter_s, loop_s=tel.loop_s, overrun=tel.overrun,
    )
    return RunReport(
        telemetry_path=telemetry_path, gait_path=gait_path,
        robot=None if robot is None else robot.name, gait_label=gait.gait_label,
        period_s=gait.period_s, speed_scale=speed_scale, stop_reason=tel.stop_reason,
        stop_message=tel.stop_message, ticks_by_phase=by_phase, joints=tuple(joints),
        departure=departure, rule=rule, timing=_timing(tel), sim_verdict=_sim_verdict(gait),
        warnings=tuple(warnings), series=series,
    )


# ---------------------------------------------------------------------------------------------
# HTML


def _f(v: float | None, fmt: str, scale: float = 1.0) -> str:
    if v is None or not math.isfinite(v):
        return "—"
    return format(v * scale, fmt)


def _table(head: Sequence[str], rows: Sequence[Sequence[str]], cls: str) -> str:
    h = "".join(f"<th>{html.escape(c)}</th>" for c in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in rows
    )
    return f'<table class="{cls}"><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>'


def _img(png: bytes, alt: str) -> str:
    import base64

    data = base64.b64encode(png).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def render_html(rep: RunReport) -> str:
    """The self-contained HTML page (figures inline as base64 PNGs)."""
    from hardware.play import run_report_plots as plots

    esc = html.escape
    dep_name = rep.departure.joint if rep.departure else None
    tracking = _table(
        ["joint", "servo RMS [rad]", "servo max [rad]", "plan RMS [rad]", "plan max [rad]",
         "plan median [rad]", "threshold [rad]", "sim RMS [rad]", "missed reads"],
        [[j.joint + (" ← departed" if j.joint == dep_name else ""), _f(j.servo_rms_rad, ".4f"),
          _f(j.servo_max_rad, ".4f"), _f(j.plan_rms_rad, ".4f"), _f(j.plan_max_rad, ".4f"),
          _f(j.plan_median_rad, ".4f"), _f(j.threshold_rad, ".3f"),
          _f(j.sim_tracking_rms_rad, ".4f"), str(j.missed_reads)] for j in rep.joints],
        "tracking",
    )
    load = _table(
        ["joint", "peak |load| [% max]", "stall τ [N·m]", "peak |τ| [N·m]",
         "peak τ / envelope", "samples beyond envelope", "planned peak |τ| [N·m]",
         "sim peak τ / stall"],
        [[j.joint, _f(j.load_peak_pct, ".0f"), _f(j.stall_torque_nm, ".2f"),
          _f(j.torque_peak_nm, ".2f"), _f(j.envelope_peak_fraction, ".0%"),
          str(j.over_envelope_samples) if j.envelope_peak_fraction is not None else "—",
          _f(j.planned_peak_nm, ".2f"), _f(j.sim_peak_torque_fraction, ".0%")]
         for j in rep.joints],
        "load",
    )
    thermal = _table(
        ["joint", "first [°C]", "last [°C]", "measured rise [K]", "over [s]",
         "predicted rise [K]", "prediction from", "limit [°C]"],
        [[j.joint, _f(j.temp_first_c, ".0f"), _f(j.temp_last_c, ".0f"), _f(j.temp_rise_k, ".0f"),
          _f(j.temp_span_s, ".1f"), _f(j.predicted_rise_k, ".2f"), j.thermal_source or "—",
          _f(j.max_temperature_c, ".0f")] for j in rep.joints],
        "thermal",
    )
    t = rep.timing
    timing = _table(
        ["ticks", "requested [Hz]", "achieved [Hz]", "jitter p50 [ms]", "jitter p99 [ms]",
         "jitter max [ms]", "overruns", "tick work p50 [ms]", "tick work p99 [ms]",
         "stop latency [ms]"],
        [[str(t.ticks), _f(t.requested_hz, ".1f"), _f(t.rate_hz, ".1f"),
          _f(t.jitter_p50_s, ".3f", 1e3), _f(t.jitter_p99_s, ".3f", 1e3),
          _f(t.jitter_max_s, ".3f", 1e3), str(t.overruns), _f(t.work_p50_s, ".3f", 1e3),
          _f(t.work_p99_s, ".3f", 1e3), _f(t.stop_latency_s, ".1f", 1e3)]],
        "timing",
    )
    phases = ", ".join(f"{k} {v}" for k, v in rep.ticks_by_phase.items())
    load_unit = "N·m (load % × stall torque)" if rep.robot else "% of max (give --robot for N·m)"
    warn = "".join(f'<p class="warn">WARNING: {esc(w)}</p>' for w in rep.warnings)
    figures = [
        ("tracking", plots.tracking_figure(rep)),
        ("plan error", plots.error_figure(rep)),
        ("load", plots.load_figure(rep)),
        ("temperature", plots.temperature_figure(rep)),
        ("loop timing", plots.timing_figure(rep)),
    ]
    figs = {name: _img(png, name) for name, png in figures}
    generated = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>gaitsmith run report — {esc(Path(rep.telemetry_path).name)}</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; max-width: 1300px; }}
table {{ border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.9em; }}
th, td {{ border: 1px solid #bbb; padding: 2px 8px; text-align: right; }}
th:first-child, td:first-child {{ text-align: left; }}
.departure {{ font-size: 1.15em; font-weight: bold; padding: 0.5em; background: #fff3e0; }}
.warn {{ color: #a60; }} img {{ max-width: 100%; }} .small {{ color: #555; font-size: 0.85em; }}
</style></head><body>
<h1>Run report: planned vs measured</h1>
<p>telemetry <code>{esc(rep.telemetry_path)}</code> · gait <code>{esc(rep.gait_path)}</code>
({esc(rep.gait_label)}, period {rep.period_s:.3f} s, played at speed scale {rep.speed_scale:g})
· robot {esc(rep.robot or "not given")} · generated {generated}</p>
<p>stop: <b>{esc(rep.stop_reason or "no stop row (log cut short?)")}</b>
— {esc(rep.stop_message or "")} · ticks by phase: {esc(phases)}
· MuJoCo verdict: {esc(rep.sim_verdict or "no validation block (never simulated)")}</p>
{warn}
<h2>Where the run departed from the plan</h2>
<p class="departure" id="departure">{esc(rep.departure_line())}</p>
<p class="small">Rule: {esc(rep.rule.describe())}. "planned" is the angle the plan expects the
joint to reach (expected_joint_angles_rad, else the samples) at the tick's gait time
(speed scale · time since the first gait tick).</p>
<h2>Tracking (gait phase)</h2>
<p class="small">servo: |present − target| (how the servo followed its goal); plan: |present −
planned|; sim: the MuJoCo rollout's tracking RMS from the validation block.</p>
{tracking}
{figs["tracking"]}
{figs["plan error"]}
<h2>Load vs the servo envelope</h2>
<p class="small">Load in {esc(load_unit)}; envelope |τ| ≤ τ_stall·(1 − |q̇|/ω₀) at the measured
speed.</p>
{load}
{figs["load"]}
<h2>Temperature vs the thermal prediction</h2>
<p class="small">Predicted rise from the first reading over the same span:
P̄·R_th·(1 − e^(−t/τ_th)) (robots.thermal). The temperature register counts whole degrees.</p>
{thermal}
{figs["temperature"]}
<h2>Loop timing</h2>
{timing}
{figs["loop timing"]}
</body></html>
"""


def write_report(
    telemetry_path: str | Path,
    gait_path: str | Path,
    output: str | Path,
    *,
    robot_name: str | None = None,
    speed_scale: float = 1.0,
    rule: DepartureRule | None = None,
) -> RunReport:
    """Read, analyse, render and write the report atomically; RunReportError on bad inputs,
    OutputWriteError when the page cannot be written."""
    from robots.files import atomic_write_text

    tel, gait, robot = load_inputs(telemetry_path, gait_path, robot_name)
    rep = analyse(tel, gait, robot, speed_scale=speed_scale, rule=rule,
                  telemetry_path=str(telemetry_path), gait_path=str(gait_path))
    atomic_write_text(output, render_html(rep))
    return rep

"""`gaitsmith simulate gait.json`: prove a gait in MuJoCo with servo actuators.

Prints the metrics and the verdict; exit code 0 when the gait passes, 1 when it fails (2 for a
usage or input error, via `gaitsmith.cli.main`). Optional outputs: a video (MP4/GIF, offscreen),
one HTML report with the plots, the verdict written back into the gait file, a robustness sweep.
"""

from __future__ import annotations

import math
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco creates a GL context (headless video)

from pathlib import Path

import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

import robots.gait as gait_io
from gaitsmith.attitude_options import (
    attitude_gain_option,
    attitude_settings,
    check_attitude_gain,
    check_imu_options,
    imu_latency_option,
    imu_noise_option,
    resolved_gain,
)
from gaitsmith.console import console
from gaitsmith.errors import OptionError
from gaitsmith.options import (
    MAX_LATENCY_MS,
    RATE_HZ_RANGE,
    check_cycles,
    check_friction,
    check_number,
    check_output_file,
    check_supply_v,
)
from robots.thermal import DEFAULT_AMBIENT_C, DEFAULT_BOUT_S
from robots.voltage import nominal_supply_v, robot_at_voltage, voltage_margin
from sim.metrics import steady_mask
from sim.render import VIDEO_SUFFIXES
from sim.thermal_report import (
    AMBIENT_RANGE_C,
    MAX_BOUT_S,
    ThermalPrediction,
    predict_from_trajectory,
)
from sim.validate import PassCriteria, ValidationResult, evaluate, simulate

MAX_PAYLOAD_KG = 1000.0
MAX_STRENGTH = 100.0
MAX_VIDEO_S = 3600.0
MAX_STAND_S = 60.0  # sim.rollout.RunSettings' own bound


def _closest_limit(result: ValidationResult) -> str:
    """The joint that came closest to one of its limits in the steady cycles (the report has
    every joint, planned and simulated)."""
    if not result.joints:
        return "—"
    j = min(result.joints, key=lambda jm: jm.limit_clearance_fraction)
    return (f"{j.name} {math.degrees(j.limit_clearance_rad):.1f}° "
            f"({j.limit_clearance_fraction:.0%} of its range)")


def _metrics_table(result: ValidationResult) -> Table:
    m = result.metrics
    table = Table(title="simulation metrics (steady cycles; heading and drift over the run)")
    table.add_column("metric")
    table.add_column("value", justify="right")
    deg = 180.0 / math.pi

    def opt(v: float | None, fmt: str) -> str:
        return "—" if v is None else format(v, fmt)

    rows = (
        (
            "speed commanded / achieved",
            f"{m.commanded_speed_m_s:.3f} / {m.achieved_speed_m_s:.3f} m/s",
        ),
        ("speed error", opt(m.speed_error_fraction, ".1%")),
        (
            "heading change (run / ramp-in)",
            f"{m.heading_change_rad * deg:+.1f}° / {m.ramp_yaw_rad * deg:+.1f}°",
        ),
        (
            "lateral drift (run)",
            opt(m.lateral_drift_per_m, ".3f") + f" m/m ({m.lateral_drift_m:+.3f} m)",
        ),
        (
            "yaw drift (steady)",
            opt(None if m.yaw_drift_rad_per_m is None else m.yaw_drift_rad_per_m * deg, ".1f")
            + " °/m",
        ),
        ("base height", f"{m.base_height_min_m * 100:.1f} … {m.base_height_max_m * 100:.1f} cm"),
        ("max tilt", f"{m.tilt_max_rad * deg:.1f}°"),
        ("fall", "no" if not m.fell else f"at {m.fall_time_s:.2f} s ({m.fall_reason})"),
        (
            "foot slip per stance",
            f"mean {m.slip_mean_m * 1000:.1f} mm, max {m.slip_max_m * 1000:.1f} mm",
        ),
        (
            "peak / RMS torque",
            f"{m.peak_torque_fraction:.0%} / {m.rms_torque_fraction:.0%} of stall",
        ),
        ("time at full duty", f"{m.saturation_fraction:.1%}"),
        (
            "tracking error",
            f"RMS {m.tracking_rms_rad * deg:.2f}°, max {m.tracking_max_rad * deg:.1f}°",
        ),
        ("mechanical power", f"{m.mechanical_power_w:.2f} W"),
        ("cost of transport", opt(m.cost_of_transport, ".2f")),
        ("closest to a joint limit", _closest_limit(result)),
    )
    for k, v in rows:
        table.add_row(k, v)
    return table


def _thermal_table(pred: ThermalPrediction) -> Table:
    table = Table(title=f"predicted servo heating over {pred.bout_s / 60:g} min of walking "
                  f"({pred.ambient_c:g} °C ambient; first-order model, R_th/τ_th estimated)")
    for col in ("joint", "servo", "mean heat [W]", "rise [K]", "after bout [°C]",
                "steady [°C]", "limit [°C]", "minutes to limit"):
        table.add_column(col, justify="left" if col in ("joint", "servo") else "right")
    for h in pred.hottest:
        mins = "never" if h.minutes_to_limit is None else f"{h.minutes_to_limit:.1f}"
        hot = h.minutes_to_limit is not None and h.minutes_to_limit * 60.0 <= pred.bout_s
        style = "red" if hot else ""
        steady_c = pred.ambient_c + h.steady_rise_k
        table.add_row(h.joint, h.servo, f"{h.mean_power_w:.2f}", f"{h.rise_after_bout_k:.1f}",
                      f"{h.temperature_after_bout_c:.1f}", f"{steady_c:.1f}",
                      f"{h.max_temperature_c:.0f}", mins, style=style)
    return table


def simulate_command(
    gait_path: Path = typer.Argument(
        ..., help="gait file (gaitsmith.gait/1 JSON)", metavar="GAIT.json"
    ),
    robot: str | None = typer.Option(
        None, "--robot", help="robot name or folder (default: the gait's robot)"
    ),
    cycles: int = typer.Option(20, "--cycles", help="gait cycles to simulate (≥ 3)"),
    video: Path | None = typer.Option(None, "--video", help="write a video: out.mp4 or out.gif"),
    report: Path | None = typer.Option(None, "--report", help="write an HTML report with plots"),
    write_validation: bool = typer.Option(
        False, "--write-validation", help="store the verdict in the gait file"
    ),
    rate_hz: float = typer.Option(100.0, "--rate-hz", help="target stream rate [Hz]"),
    latency_ms: float = typer.Option(0.0, "--latency-ms", help="bus + servo latency [ms]"),
    friction: float | None = typer.Option(
        None, "--friction", help="ground friction µ (default: MJCF)"
    ),
    payload_kg: float = typer.Option(0.0, "--payload-kg", help="extra mass on the body [kg]"),
    strength: float = typer.Option(1.0, "--strength", help="servo strength scale (1 = datasheet)"),
    robustness: bool = typer.Option(False, "--robustness", help="also run the robustness sweep"),
    hq_video: bool = typer.Option(
        False, "--hq-video", help="shadows, reflections, anti-aliasing (≈10× slower)"
    ),
    video_seconds: float = typer.Option(
        10.0, "--video-seconds", help="video length from the gait start [s]"
    ),
    supply_v: float | None = typer.Option(
        None, "--supply-v",
        help="servo supply voltage [V]: the torque–speed envelope scales ∝ V/V_nominal "
        "(default: the gait's planned supply, else the servos' nominal voltage)",
    ),
    bout_min: float = typer.Option(
        DEFAULT_BOUT_S / 60.0, "--bout-min", help="walking bout of the heating prediction [min]"
    ),
    ambient_c: float = typer.Option(
        DEFAULT_AMBIENT_C, "--ambient-c", help="ambient temperature of the prediction [°C]"
    ),
    stand_s: float = typer.Option(
        0.0, "--stand-s", help="hold the gait's stand (mean pose) this long [s] after the "
        "ramp-in and, with --end-at-stand, at the end (as gaitsmith-play run --stand-s)"),
    end_at_stand: bool = typer.Option(
        False, "--end-at-stand", help="after the cycles, blend the gait out to its stand the "
        "way a completed gaitsmith-play run ends"),
    servo_params_path: Path | None = typer.Option(
        None, "--servo-params",
        help="identified servos (servo_params.toml of `gaitsmith identify`): each joint's gain, "
        "strength and goal latency instead of the catalogue's",
    ),
    attitude_gain: float | None = attitude_gain_option(),
    imu_latency_ms: float = imu_latency_option(),
    imu_noise_deg: float = imu_noise_option(),
) -> None:
    """Simulate a gait in MuJoCo with servo actuators; exit 0 if it passes, 1 if it fails."""
    check_cycles("--cycles", cycles)
    check_number("--rate-hz", rate_hz, *RATE_HZ_RANGE, unit="Hz")
    check_number("--latency-ms", latency_ms, 0.0, MAX_LATENCY_MS, unit="ms")
    check_friction("--friction", friction)
    check_number("--payload-kg", payload_kg, 0.0, MAX_PAYLOAD_KG, unit="kg")
    check_number("--strength", strength, 0.0, MAX_STRENGTH, lo_open=True)
    check_number("--video-seconds", video_seconds, 0.0, MAX_VIDEO_S, lo_open=True, unit="s")
    check_number("--bout-min", bout_min, 0.0, MAX_BOUT_S / 60.0, lo_open=True, unit="min")
    check_number("--ambient-c", ambient_c, *AMBIENT_RANGE_C, unit="°C")
    check_number("--stand-s", stand_s, 0.0, MAX_STAND_S, unit="s")
    check_attitude_gain("--attitude-gain", attitude_gain)
    check_imu_options(imu_latency_ms, imu_noise_deg)
    if video is not None and video.suffix.lower() not in VIDEO_SUFFIXES:
        raise OptionError(f"--video {video}: must end in .mp4 or .gif")
    for option, path in (("--video", video), ("--report", report)):
        if path is not None:
            check_output_file(option, path)
    if write_validation:
        check_output_file("--write-validation", gait_path)
    gait = gait_io.load(gait_path)
    bot = gait_io.robot_for(gait, gait_path, robot)  # --robot > robot_dir > built-in name
    gait.check_robot(bot, str(gait_path))
    planned_v = gait.planner.get("supply_v")
    source = "--supply-v"
    if supply_v is None and isinstance(planned_v, (int, float)) and not isinstance(planned_v, bool):
        supply_v = float(planned_v)  # a gait planned at a supply voltage is simulated at it
        source = f"{gait_path}: planner.supply_v"
        console.print(f"supply {supply_v:g} V (the voltage the gait was planned at)")
    check_supply_v(source, supply_v, bot)
    bot = robot_at_voltage(bot, supply_v)
    servo_settings = None
    if servo_params_path is not None:
        from robots import servo_params

        servo_settings = servo_params.load(servo_params_path).for_robot(bot)
        console.print(f"servos: as identified in {servo_params_path}", highlight=False)
    attitude = attitude_settings(resolved_gain(attitude_gain, bot, gait), imu_latency_ms,
                                 imu_noise_deg)
    criteria = PassCriteria()
    with Progress(
        TextColumn("[bold]simulating"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task("sim", total=1.0)
        sim, traj = simulate(
            gait,
            bot,
            cycles,
            rate_hz=rate_hz,
            latency_s=latency_ms / 1000.0,
            friction=friction,
            payload_kg=payload_kg,
            strength=strength,
            progress=lambda done, total: bar.update(task, completed=done / total),
            criteria=criteria,
            stand_s=stand_s,
            end_at_stand=end_at_stand,
            servo_settings=servo_settings,
            attitude=attitude,
        )
    result = evaluate(traj, gait, sim, criteria, rate_hz=rate_hz, latency_s=latency_ms / 1000.0)
    console.print(_metrics_table(result))
    thermal = predict_from_trajectory(
        traj, bot, warmup_cycles=criteria.warmup_cycles, bout_s=bout_min * 60.0,
        ambient_c=ambient_c,
    )
    console.print(_thermal_table(thermal))
    console.print(f"  heating: {thermal.summary()}")
    if thermal.unmodelled:
        console.print(f"  no thermal data (no published stall current): "
                      f"{', '.join(thermal.unmodelled)}")
    margin = voltage_margin(bot, traj.torque_nm[steady_mask(traj, criteria.warmup_cycles)],
                            nominal_supply_v(bot) if supply_v is None else supply_v)
    console.print(f"  supply: {margin.summary()}")
    for name, ok, detail in result.checks:
        console.print(f"  {'[green]ok  [/]' if ok else '[red]FAIL[/]'} {name}: {detail}")
    if video is not None:
        from sim.render import render_video

        with console.status("rendering video…"):
            gif = video.suffix.lower() == ".gif"  # GIFs get small: palette files grow fast
            render_video(
                video,
                sim,
                traj,
                start_s=max(0.0, traj.gait_start_s - 0.5),
                duration_s=video_seconds,
                width=320 if gif else 640,
                height=240 if gif else 480,
                fps=15.0 if gif else 30.0,
                high_quality=hq_video,
            )
        console.print(f"video → {video}")
    sweep = None
    if robustness:
        from sim.robustness import robustness_sweep

        with console.status("robustness sweep…"):
            sweep = robustness_sweep(
                gait,
                bot,
                max(cycles // 2, criteria.warmup_cycles + 2),
                rate_hz=rate_hz,
                criteria=criteria,
                attitude=attitude,
            )
        table = Table(title=f"robustness: {sweep.pass_fraction:.0%} of perturbed runs pass")
        for col in ("factor", "value", "verdict", "speed [m/s]", "peak τ/stall", "why"):
            table.add_column(col)
        for r in sweep.runs:
            table.add_row(
                r.factor,
                f"{r.value:g}",
                "pass" if r.passed else "FAIL",
                f"{r.achieved_speed_m_s:.3f}",
                f"{r.peak_torque_fraction:.0%}",
                "; ".join(r.reasons)[:80],
            )
        console.print(table)
    if report is not None:
        from sim.report import write_report

        with console.status("writing report…"):
            write_report(report, result, gait, sim, robustness=sweep, thermal=thermal,
                         voltage=margin)
        console.print(f"report → {report}")
    if write_validation:
        block = result.to_dict()
        block["thermal"] = thermal.to_dict()
        block["supply"] = margin.to_dict()  # the simulated peak torques, for pre-flight
        if servo_params_path is not None:
            block["servo_params"] = str(servo_params_path)
        gait_io.save(gait.with_validation(block), gait_path)
        console.print(f"validation written to {gait_path}")
    verdict = "[bold green]PASS[/]" if result.passed else "[bold red]FAIL[/]"
    console.print(
        f"verdict: {verdict}" + ("" if result.passed else " — " + "; ".join(result.reasons))
    )
    if not result.passed:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    app.command("simulate")(simulate_command)

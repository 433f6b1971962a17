"""`gaitsmith drive-sim lib.json --path SPEC`: follow a path in MuJoCo through a gait library.

A pure-pursuit controller on the measured base pose picks the command each tick, the gait
blender turns it into servo targets (`sim.path`). Prints the metrics and the verdict; exit 0 when
the run passes (arrived, no fall, mean cross-track error and peak torque within limits), 1 when
it fails, 2 for a usage or input error. Optional outputs: video with the path and footprints,
plot of planned vs driven path, HTML report, JSON summary.
"""

from __future__ import annotations

import json
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco creates a GL context (headless video)

import math
from pathlib import Path

import numpy as np
import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from gaitsmith.attitude_options import (
    attitude_gain_option,
    attitude_settings,
    check_attitude_gain,
    check_imu_options,
    imu_latency_option,
    imu_noise_option,
    resolved_library_gain,
)
from gaitsmith.console import console
from gaitsmith.errors import OptionError
from gaitsmith.options import (
    MAX_LATENCY_MS,
    RATE_HZ_RANGE,
    check_integer,
    check_number,
    check_output_file,
)
from robots import library as library_io
from robots.files import atomic_write_text
from sim.path.follow import FollowSettings, blend_limits, follow
from sim.path.metrics import DriveCriteria, DriveResult, judge
from sim.path.pursuit import PursuitSettings
from sim.path.spec import parse_path
from sim.render import VIDEO_SUFFIXES

MAX_LAPS = 100
LOOKAHEAD_RANGE = (0.5, 20.0)  # leg lengths
MAX_VIDEO_SPEED = 20.0


def _metrics_table(result: DriveResult, gain: float, offset_max_rad: float,
                   clipped_ticks: int) -> Table:
    m = result.metrics
    deg = 180.0 / math.pi
    table = Table(title="drive-sim metrics (while steering along the path)")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for k, v in (
        ("cross-track error mean / max",
         f"{m.cross_track_mean_m * 100:.2f} / {m.cross_track_max_m * 100:.2f} cm"),
        ("heading error mean / max",
         f"{m.heading_error_mean_rad * deg:.1f} / {m.heading_error_max_rad * deg:.1f}°"),
        ("time", f"{m.time_s:.1f} s"),
        ("distance driven / planned", f"{m.distance_m:.2f} / {m.planned_distance_m:.2f} m"),
        ("mean speed", f"{m.mean_speed_m_s:.3f} m/s"),
        ("servo peak torque", f"{m.peak_torque_fraction:.0%} of stall ({m.peak_torque_joint})"),
        ("fall", "no" if not m.fell else f"at {m.fall_time_s:.2f} s ({m.fall_reason})"),
        ("footprints", str(m.footprints)),
        ("requests clipped into the box", f"{m.clipped_fraction:.1%} of ticks"),
        ("attitude feedback", "open loop" if not gain else
         f"gain {gain:g}: largest offset {offset_max_rad:.3f} rad, at the clip on "
         f"{clipped_ticks} tick(s)"),
    ):
        table.add_row(k, v)
    return table


def drive_sim_command(
    library_path: Path = typer.Argument(
        ..., help="gait library (gaitsmith.library/1 JSON, from `gaitsmith library`)",
        metavar="LIB.json"),
    path_spec: str = typer.Option(
        ..., "--path",
        help="circle:R, figure8:R (R in m; negative turns right first), waypoints "
        "'x,y;x,y;...' or a .json/.csv file of x,y waypoints (centripetal Catmull-Rom spline)"),
    laps: int = typer.Option(1, "--laps", help="laps of a closed path"),
    robot: str | None = typer.Option(
        None, "--robot", help="robot name or folder (default: the library's robot)"),
    speed: float | None = typer.Option(
        None, "--speed", help="cruise speed [m/s] (default: the library's top vx)"),
    lookahead: float = typer.Option(
        PursuitSettings().lookahead_leg_lengths, "--lookahead",
        help="pure-pursuit look-ahead [leg lengths] (at least 2 s of travel at the cruise speed)"),
    max_cross_track_cm: float | None = typer.Option(
        None, "--max-cross-track-cm",
        help="verdict limit on the mean cross-track error [cm] (default: 0.3 leg lengths)"),
    rate_hz: float = typer.Option(100.0, "--rate-hz", help="control / target stream rate [Hz]"),
    latency_ms: float = typer.Option(0.0, "--latency-ms", help="bus + servo latency [ms]"),
    video: Path | None = typer.Option(None, "--video", help="write a video: out.mp4 or out.gif"),
    video_speed: float = typer.Option(2.0, "--video-speed", help="video time-lapse factor"),
    plot: Path | None = typer.Option(None, "--plot", help="write the planned vs driven path PNG"),
    report: Path | None = typer.Option(None, "--report", help="write an HTML report"),
    json_out: Path | None = typer.Option(None, "--json", help="write the metrics as JSON"),
    attitude_gain: float | None = attitude_gain_option(),
    imu_latency_ms: float = imu_latency_option(),
    imu_noise_deg: float = imu_noise_option(),
    servo_params_path: Path | None = typer.Option(
        None, "--servo-params",
        help="identified servos (servo_params.toml of `gaitsmith identify`): gain, strength "
        "and delay per joint (default: the catalogue servos)"),
) -> None:
    """Follow a path in MuJoCo with a gait library; exit 0 if the run passes, 1 if it fails."""
    check_integer("--laps", laps, 1, MAX_LAPS)
    check_number("--speed", speed, 0.0, 10.0, lo_open=True, unit="m/s")
    check_number("--lookahead", lookahead, *LOOKAHEAD_RANGE, unit="leg lengths")
    check_number("--max-cross-track-cm", max_cross_track_cm, 0.0, 1000.0, lo_open=True,
                 unit="cm")
    check_number("--rate-hz", rate_hz, *RATE_HZ_RANGE, unit="Hz")
    check_number("--latency-ms", latency_ms, 0.0, MAX_LATENCY_MS, unit="ms")
    check_number("--video-speed", video_speed, 0.0, MAX_VIDEO_SPEED, lo_open=True)
    check_attitude_gain("--attitude-gain", attitude_gain)
    check_imu_options(imu_latency_ms, imu_noise_deg)
    if video is not None and video.suffix.lower() not in VIDEO_SUFFIXES:
        raise OptionError(f"--video {video}: must end in .mp4 or .gif")
    if plot is not None and plot.suffix.lower() != ".png":
        raise OptionError(f"--plot {plot}: must end in .png")
    for option, out in (("--video", video), ("--plot", plot), ("--report", report),
                        ("--json", json_out)):
        if out is not None:
            check_output_file(option, out)
    lib = library_io.load(library_path)
    bot = library_io.robot_for(lib, library_path, robot)
    path = parse_path(path_spec, bot.leg_length_m, "--path")
    servo_settings = None
    if servo_params_path is not None:
        from robots import servo_params

        servo_settings = servo_params.load(servo_params_path).for_robot(bot)
        console.print(f"servos: as identified in {servo_params_path}", highlight=False)
    if laps > 1 and not path.closed:
        raise OptionError(f"--laps {laps}: {path_spec!r} is an open path (its last waypoint "
                          "does not repeat the first); use --laps 1")

    gain = resolved_library_gain(attitude_gain, bot, [e.gait for e in lib.entries])
    settings = FollowSettings(
        rate_hz=rate_hz, latency_s=latency_ms / 1000.0, laps=laps,
        pursuit=PursuitSettings(lookahead_leg_lengths=lookahead, speed_m_s=speed),
        attitude=attitude_settings(gain, imu_latency_ms, imu_noise_deg))
    lo, hi = lib.command_bounds()
    limits = blend_limits(bot, settings)
    cruise = hi.vx_m_s if speed is None else min(speed, hi.vx_m_s)
    console.print(
        f"{bot.name}: {len(lib.entries)} gaits ({lib.family}), command box vx "
        f"[{lo.vx_m_s:g}, {hi.vx_m_s:g}] m/s, vy [{lo.vy_m_s:g}, {hi.vy_m_s:g}] m/s, yaw rate "
        f"[{lo.yaw_rate_rad_s:g}, {hi.yaw_rate_rad_s:g}] rad/s; path {path.length_m:.2f} m"
        + (f" × {laps} laps" if laps > 1 else ""))
    with Progress(TextColumn("[bold]driving"), BarColumn(),
                  TextColumn("{task.fields[done]:.2f}/{task.total:.2f} m, "
                             "t = {task.fields[t]:.0f} s"),
                  TimeElapsedColumn(), console=console, transient=True) as bar:
        task = bar.add_task("drive", total=path.length_m * laps, done=0.0, t=0.0)
        sim, log = follow(
            lib, bot, path, settings, servo_settings=servo_settings,
            progress=lambda t, s, total: bar.update(task, completed=s, done=s, t=t))
    period = float(np.mean([e.gait.period_s for e in lib.entries]))
    criteria = DriveCriteria(
        max_mean_cross_track_m=None if max_cross_track_cm is None else max_cross_track_cm / 100)
    result = judge(log, bot.joint_names, period, criteria)
    console.print(_metrics_table(result, gain, log.attitude_offset_max_rad,
                                 log.attitude_clipped_ticks))
    for name, ok, detail in result.checks:
        console.print(f"  {'[green]ok  [/]' if ok else '[red]FAIL[/]'} {name}: {detail}")
    conditions: dict[str, object] = {
        "library": str(library_path), "path": path_spec, "laps": laps,
        "lookahead_leg_lengths": lookahead,
        "lookahead_m": settings.pursuit.lookahead_m(bot.leg_length_m, cruise),
        "cruise_m_s": cruise, "rate_hz": rate_hz,
        "latency_s": latency_ms / 1000.0,
        "servo_params": None if servo_params_path is None else str(servo_params_path),
        "timestep_s": float(sim.model.opt.timestep),
        "command_accel_m_s2": limits.accel_m_s2,
        "yaw_accel_rad_s2": limits.yaw_accel_rad_s2,
        "attitude_gain": gain,
        "imu_latency_s": imu_latency_ms / 1000.0 if gain else None,
        "imu_noise_rad": math.radians(imu_noise_deg) if gain else None,
    }
    png: bytes | None = None
    if plot is not None or report is not None:
        from sim.path.draw import path_plot

        png = path_plot(log, bot.foot_names, f"{bot.name} · {path_spec}")
    if plot is not None and png is not None:
        from robots.files import atomic_write_bytes

        atomic_write_bytes(plot, png)
        console.print(f"plot → {plot}")
    if video is not None:
        from sim.path.draw import render_drive_video

        gif = video.suffix.lower() == ".gif"
        with console.status("rendering video…"):
            render_drive_video(video, sim, log, speed=video_speed, fps=15.0 if gif else 30.0,
                               width=320 if gif else 640, height=240 if gif else 480)
        console.print(f"video → {video}")
    if report is not None and png is not None:
        from sim.report import write_drive_report

        write_drive_report(report, result, log, bot.name, library=str(library_path),
                           plot_png=png, conditions=conditions)
        console.print(f"report → {report}")
    if json_out is not None:
        doc = {"schema": "gaitsmith.drive_sim/1", "robot": bot.name, "passed": result.passed,
               "checks": [{"name": n, "ok": ok, "detail": d} for n, ok, d in result.checks],
               "metrics": result.metrics.to_dict(),
               "joint_peak_torque_fraction": dict(result.joint_peak_fraction),
               "attitude": {"gain": gain, "offset_max_rad": log.attitude_offset_max_rad,
                            "clipped_ticks": log.attitude_clipped_ticks},
               "conditions": conditions}
        atomic_write_text(json_out, json.dumps(doc, indent=2) + "\n")
        console.print(f"metrics → {json_out}")
    verdict = "[bold green]PASS[/]" if result.passed else "[bold red]FAIL[/]"
    console.print(f"verdict: {verdict}" + ("" if result.passed else " — "
                                           + "; ".join(result.reasons)))
    if not result.passed:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    app.command("drive-sim")(drive_sim_command)

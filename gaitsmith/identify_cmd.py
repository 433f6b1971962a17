"""`gaitsmith identify RECORD.csv --robot R -o servo_params.toml [--plot fit.png]`.

Fits each excited joint's servo — position gain, goal latency, strength (torque saturation) —
to the telemetry of a `gaitsmith-play identify` run (`sim.identify.fit`), on the record's
training part, and reports the fit on the held-back part. The file it writes
(`robots.servo_params`) is what `gaitsmith plan/simulate --servo-params FILE` read.
"""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

import robots
from gaitsmith.console import console, err_console
from gaitsmith.options import check_output_file
from robots import servo_params
from sim.errors import SimConfigError


def identify_command(
    record: Path = typer.Argument(..., help="telemetry CSV of `gaitsmith-play identify`"),
    robot: str = typer.Option(..., "--robot", help="robot it was recorded on (name or folder)"),
    output: Path = typer.Option(..., "--output", "-o", help="servo_params.toml to write"),
    plot: Path | None = typer.Option(None, "--plot", help="PNG of the fit against the record"),
) -> None:
    """Fit each servo's gain, latency and strength to an excitation record."""
    from sim.identify.fit import identify

    check_output_file("--output", output)
    if plot is not None:
        check_output_file("--plot", plot)
    rob = robots.load(robot)
    result = identify(record, rob)
    trusted = [f for f in result.fits if f.trusted]
    params = servo_params.ServoParamsFile(
        robot=rob.name, joints={f.name: f.setting for f in trusted}
    )
    servos = {j.name: j.servo.name for j in rob.joints}
    info = {f.name: f.info(servos[f.name]) for f in trusted}
    left_out = [f.name for f in result.fits if not f.trusted]
    header = (
        f"servo parameters of {rob.name}, fitted by `gaitsmith identify {record.name}`\n"
        "gain_scale × factory position gain; latency_ms of the goal; strength × stall torque"
        + (f"\nleft out (fit not trusted, factory servo kept): {', '.join(left_out)}"
           if left_out else "")
    )  # fmt: skip
    table = Table(title=f"servo identification: {rob.name} ({record.name})")
    for col in ("joint", "gain ×", "kp N·m/rad", "latency ms", "strength ×", "limit N·m",
                "train RMS °", "held-back RMS °", "s.e. gain/latency/strength"):  # fmt: skip
        table.add_column(col, justify="left" if col == "joint" else "right")
    for f in result.fits:
        s = f.setting
        table.add_row(
            f.name, f"{s.gain_scale:.3f}", f"{f.kp_nm_per_rad:.2f}", f"{s.latency_ms:.1f}",
            f"{s.strength:.3f}", f"{f.drive_limit_nm:.3f}",
            f"{math.degrees(f.train_rms_rad):.3f}", f"{math.degrees(f.held_out_rms_rad):.3f}",
            f"{f.sd[0]:.3f} / {f.sd[1]:.2f} ms / {f.sd[2]:.3f}",
        )  # fmt: skip
    console.print(table)
    for f in result.fits:
        for warning in f.warnings:
            err_console.print(f"[bold yellow]WARNING: {escape(warning)}[/]", highlight=False)
    if not trusted:
        raise SimConfigError(
            f"{record}: no joint's fit can be trusted (see the warnings); nothing written"
        )
    servo_params.save(output, params, info, header)
    if left_out:
        err_console.print(
            f"[bold yellow]left out of {escape(str(output))} (factory servo kept): "
            f"{escape(', '.join(left_out))}[/]",
            highlight=False,
        )
    console.print(f"servo parameters: {output}", highlight=False, soft_wrap=True)
    if plot is not None:
        from sim.identify.plot import plot_fit

        plot_fit(result, rob, plot, title=f"{rob.name}: fit vs {record.name}")
        console.print(f"plot: {plot}", highlight=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    app.command("identify")(identify_command)

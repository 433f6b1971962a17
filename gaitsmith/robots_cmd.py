"""`gaitsmith robots`, `robots show NAME`, `robots init MODEL -o DIR` and `robots check DIR`."""

from __future__ import annotations

import math
import sys
from collections import Counter
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

import robots
from gaitsmith.console import console
from robots.robot import Leg

robots_app = typer.Typer(help="List the built-in robots or show one.", invoke_without_command=True)


def _foot_text(leg: Leg) -> str:
    """`name (site)`, or for a flat foot `name (site, flat sole L × W mm)`."""
    if leg.is_flat and leg.sole_half_extents_m is not None:
        hx, hy = leg.sole_half_extents_m
        return f"{leg.name} ({leg.foot_site}, flat sole {2e3 * hx:.0f} × {2e3 * hy:.0f} mm)"
    return f"{leg.name} ({leg.foot_site})"


@robots_app.callback()
def list_robots(ctx: typer.Context) -> None:
    """List the built-in robots (legs, DOF, mass, servos)."""
    if ctx.invoked_subcommand is not None:
        return
    table = Table(title="built-in robots")
    for col in ("name", "legs", "DOF", "mass [kg]", "servos", "stance height [m]", "description"):
        table.add_column(col)
    for name in robots.builtin_names():
        r = robots.load(name)
        servos = ", ".join(f"{n}× {m}" for m, n in Counter(j.servo.name for j in r.joints).items())
        table.add_row(
            r.name,
            str(len(r.legs)),
            str(r.dof),
            f"{r.mass_kg:.2f}",
            servos,
            f"{r.stance_base_height_m:.3f}",
            r.description,
        )
    console.print(table)


@robots_app.command("show")
def show(
    robot: str = typer.Argument(..., help="built-in name or a folder with robot.xml + robot.toml"),
) -> None:
    """Print a robot's joints, limits and servos."""
    r = robots.load(robot)
    console.print(f"[bold]{r.name}[/] — {r.description}")
    console.print(
        f"MJCF {r.mjcf_path}\nfingerprint {r.fingerprint}  mass {r.mass_kg:.3f} kg  "
        f"stance base height {r.stance_base_height_m:.3f} m  leg length {r.leg_length_m:.3f} m  "
        f"bus {r.servo_protocol} @ {r.bus_baud} baud"
    )
    for notice in r.notices:
        console.print(f"note: {notice}", markup=False, highlight=False)
    table = Table()
    for col in (
        "joint",
        "leg",
        "lower [°]",
        "upper [°]",
        "stance [°]",
        "servo",
        "id",
        "dir",
        "zero [tick]",
        "stall [N·m]",
        "ω₀ [rad/s]",
    ):
        table.add_column(col)
    leg_of = {j: leg.name for leg in r.legs for j in leg.joints}
    for j in r.joints:
        table.add_row(
            j.name,
            leg_of.get(j.name, "(held)"),
            f"{math.degrees(j.lower_rad):.1f}",
            f"{math.degrees(j.upper_rad):.1f}",
            f"{math.degrees(j.stance_rad):.1f}",
            j.servo.name,
            str(j.bus_id),
            f"{j.direction:+d}",
            str(j.zero_offset_ticks),
            f"{j.servo.stall_torque_nm:.2f}",
            f"{j.servo.no_load_speed_rad_s:.2f}",
        )
    console.print(table)
    console.print("feet: " + ", ".join(_foot_text(leg) for leg in r.legs))
    if r.imu is not None:
        from robots.attitude import default_attitude_gain

        gain, why = default_attitude_gain(r)
        console.print(f"imu: {r.imu.description or 'declared'}; attitude feedback gain {gain:g} "
                      f"on walks by default ({why})", markup=False, highlight=False)


def _parse_limit(text: str) -> tuple[str, tuple[float, float]]:
    from robots.scaffold import ScaffoldError

    name, _, rng = text.partition("=")
    parts = rng.split(",")
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise ScaffoldError(
            "--limit", text, "expected JOINT=LOWER,UPPER in degrees, e.g. wheel=-90,90"
        ) from None
    if not name:
        raise ScaffoldError("--limit", text, "expected JOINT=LOWER,UPPER in degrees")
    return name, (lo, hi)


def _terminal_questions() -> object:
    from robots.scaffold import Questions

    def servo(known: list[str]) -> str | None:
        console.print("servo models in the catalogue: " + ", ".join(known))
        answer = typer.prompt("which servo drives the joints?")
        return str(answer).strip() or None

    def limits(joint: str) -> tuple[float, float] | None:
        answer = typer.prompt(f"joint {joint} has no limits (continuous): range LOWER,UPPER [deg]")
        return _parse_limit(f"{joint}={answer}")[1]

    return Questions(servo=servo, limits_deg=limits)


@robots_app.command("init")
def init(
    model: Path = typer.Argument(..., help="the robot's URDF (.urdf) or MJCF (.xml)"),
    out: Path = typer.Option(..., "-o", "--out", help="new robot folder to write"),
    servo: str | None = typer.Option(None, "--servo", help="servo model (robots/servos.toml)"),
    name: str | None = typer.Option(None, "--name", help="robot name (default: the model's)"),
    limit: list[str] | None = typer.Option(
        None, "--limit", help="JOINT=LOWER,UPPER [deg] for a joint without limits (repeatable)"
    ),
    yes: bool = typer.Option(False, "--yes", "-y", help="never ask; stop if something is unknown"),
) -> None:
    """Scaffold a robot folder (robot.xml + commented robot.toml) from a URDF or MJCF."""
    from robots.scaffold import Questions, init_robot

    interactive = not yes and sys.stdin.isatty()
    questions = _terminal_questions() if interactive else Questions()
    assert isinstance(questions, Questions)
    limits = dict(_parse_limit(t) for t in (limit or []))
    result = init_robot(model, out, servo=servo, name=name, limits_deg=limits, questions=questions)
    console.print(
        f"[bold green]wrote[/] {result.out_dir}/robot.xml + robot.toml: [bold]{result.name}[/], "
        f"{len(result.legs)} legs, servo {result.servo}, stance base {result.base_height_m:.3f} m"
    )
    table = Table(title="legs (bus ids follow this order)")
    table.add_column("leg")
    table.add_column("joints, body → foot")
    for leg, joints in result.legs:
        table.add_row(leg, ", ".join(joints))
    if result.held:
        table.add_row("[dim]held[/]", ", ".join(result.held))
    console.print(table)
    for note in result.notes:
        console.print(f"  • {escape(note)}")
    console.print(f"next: gaitsmith robots check {result.out_dir}")


@robots_app.command("check")
def check(
    robot: str = typer.Argument(..., help="built-in name or a folder with robot.xml + robot.toml"),
    duration: float = typer.Option(2.0, "--duration", help="seconds to stand [s]"),
) -> None:
    """Stand the robot on its servos in MuJoCo; report height, tilt and each servo's load."""
    from sim.stand_check import check_stand

    loaded = robots.load(robot)
    report = check_stand(loaded, duration_s=duration)
    leg_of = {j: leg.name for leg in loaded.legs for j in leg.joints}
    role = {j.name: leg_of.get(j.name, "hold") for j in loaded.joints}
    verdict = "[bold green]stands[/]" if report.stands else "[bold red]does not stand[/]"
    console.print(
        f"[bold]{report.robot}[/] ({report.mass_kg:.3f} kg, {report.legs} legs) after "
        f"{report.duration_s:.1f} s: {verdict} — base {report.base_height_m:.3f} m "
        f"(stance {report.stance_base_height_m:.3f} m), tilt {report.tilt_deg:.1f}°"
    )
    table = Table(title="holding load and torque budget (typical gait speed ½·ω₀)")
    for col in (
        "joint",
        "leg",
        "servo",
        "holding [N·m]",
        "% of stall",
        "damping [N·m·s/rad]",
        "back-EMF [N·m·s/rad]",
        "armature [kg·m²]",
        "damping % of stall",
        "armature % of stall",
    ):
        table.add_column(
            escape(col), justify="left" if col in ("joint", "leg", "servo") else "right"
        )
    worst = report.worst.name
    for j in report.joints:
        style = "bold yellow" if j.name == worst else None
        table.add_row(
            j.name,
            role[j.name],
            j.servo,
            f"{j.holding_torque_nm:+.3f}",
            f"{100 * j.load_fraction:.0f}",
            f"{j.damping_nm_s_per_rad:.3f}",
            f"{j.back_emf_nm_s_per_rad:.3f}",
            f"{j.armature_kg_m2:.4f}",
            f"{100 * j.damping_share:.1f}",
            f"{100 * j.armature_share:.1f}",
            style=style,
        )
    console.print(table)
    w = report.worst
    console.print(
        f"least margin: {w.name} at {100 * w.load_fraction:.0f} % of its {w.servo} stall torque"
    )
    for notice in report.notices:
        console.print(f"[dim]note: {escape(notice)}[/]")
    for warning in report.warnings:
        console.print(f"[yellow]warning:[/] {escape(warning)}")
    for reason in report.reasons:
        console.print(f"[red]✗[/] {escape(reason)}")
    if not report.stands:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    app.add_typer(robots_app, name="robots")

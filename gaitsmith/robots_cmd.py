"""`gaitsmith robots` and `gaitsmith robots show NAME`."""

from __future__ import annotations

import math
from collections import Counter

import typer
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


def register(app: typer.Typer) -> None:
    app.add_typer(robots_app, name="robots")

"""`gaitsmith plan ROBOT --gait trot --speed 0.25 -o trot.json`: one spacetime solve → gait file."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

import robots
from planner.config import PlannerOptions
from planner.errors import InfeasibleGaitError, PlannerConfigError
from planner.spacetime import GaitPlanner, PlanResult
from planner.templates import TEMPLATES, make_schedule

console = Console()


def plan(
    robot: str = typer.Argument(
        ..., help="built-in robot name or a folder with robot.xml + robot.toml"
    ),
    gait: str = typer.Option("trot", "--gait", "-g", help=f"gait template: {', '.join(TEMPLATES)}"),
    speed: float = typer.Option(0.25, "--speed", help="forward speed [m/s]"),
    output: Path = typer.Option(..., "--output", "-o", help="gait file to write (JSON)"),
    knots: int = typer.Option(30, "--knots", help="knots per cycle (N)"),
    period: float | None = typer.Option(
        None, "--period", help="cycle period [s] (default: template)"
    ),
    duty: float | None = typer.Option(None, "--duty", help="duty factor (default: template)"),
    mu: float = typer.Option(0.5, "--mu", help="friction coefficient of the contact cone"),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="show IPOPT's iteration log live"),
) -> None:
    """Plan one efficient cyclic gait (W&P 2009 spacetime optimisation) and write the gait file."""
    bot = robots.load(robot)
    if period is not None and not (math.isfinite(period) and period > 0):
        raise PlannerConfigError(f"--period must be positive, got {period}")
    schedule = make_schedule(bot, gait, period_s=period, duty_factor=duty)
    options = PlannerOptions(mu=mu, print_level=5 if verbose else 0)
    console.print(
        f"planning [bold]{gait}[/] for [bold]{bot.name}[/] at {speed:.3f} m/s, period "
        f"{schedule.period_s:.3f} s, duty {schedule.duty_factor[0]:.2f}, N={knots}, µ={mu}"
    )
    with console.status("building the NLP (CasADi)…"):
        planner = GaitPlanner(bot, n_knots=knots, options=options)
    console.print(f"NLP built in {planner.build_time_s:.1f} s ({planner.layout.size} variables)")
    if verbose:
        result = planner.solve(schedule, speed)
    else:
        with console.status("solving (IPOPT)…"):
            result = planner.solve(schedule, speed)
        _print_progress(result)
    _print_summary(planner, result)
    if not result.feasible:
        raise InfeasibleGaitError(
            f"{bot.name} {gait} at {speed} m/s: {result.message}; no gait file written",
            result.binding,
        )
    gait_obj = planner.to_gait(result, gait)
    robots.gait.save(gait_obj, output)
    console.print(f"wrote [bold]{output}[/]")


def _print_progress(result: PlanResult) -> None:
    log = result.stats.get("iterations", {})
    obj, inf_pr = log.get("obj", []), log.get("inf_pr", [])
    step = max(1, len(obj) // 10)
    for i in range(0, len(obj), step):
        console.print(
            f"  iter {i:4d}  objective {obj[i]:.6g}  constraint violation {inf_pr[i]:.2e}"
        )


def _print_summary(planner: GaitPlanner, result: PlanResult) -> None:
    head = Table(title="solve", show_header=False)
    head.add_row("status", result.status + ("" if result.feasible else "  [red](infeasible)[/]"))
    head.add_row("iterations", str(result.iterations))
    head.add_row("solve time [s]", f"{result.solve_time_s:.3f}")
    head.add_row("objective", f"{result.cost:.6g}")
    weights = planner.options.weights.as_dict()
    for name, value in result.cost_terms.items():
        head.add_row(
            f"  {name}", f"{value:.4g} × w {weights[name]:g} = {weights[name] * value:.4g}"
        )
    head.add_row("max violation", f"{result.max_violation:.2e}")
    head.add_row("active limits", ", ".join(f"{n} {v:.2g}" for n, v in result.binding[:4]) or "-")
    console.print(head)
    table = Table(title="servo load (peak over the cycle)")
    for col in ("joint", "|τ|/stall", "|q̇|/ω₀"):
        table.add_column(col)
    for j, joint in enumerate(planner.robot.joints):
        tau = float(np.max(np.abs(result.joint_torques_nm[:, j]))) / joint.servo.stall_torque_nm
        qd = (
            float(np.max(np.abs(result.joint_speeds_rad_s[:, j]))) / joint.servo.no_load_speed_rad_s
        )
        table.add_row(joint.name, f"{tau:.2f}", f"{qd:.2f}")
    console.print(table)


def register(app: typer.Typer) -> None:
    app.command("plan")(plan)

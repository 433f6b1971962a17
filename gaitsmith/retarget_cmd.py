"""`gaitsmith retarget GAIT.json --to ROBOT [--steps K] -o OUT.json [--simulate]`.

Carries a planned gait over to another body at the same Froude number (Murphy, Carr & O'Neill
2008; `planner.retarget`), solves the target's spacetime NLP from it (through K − 1 hybrid
bodies when the trees match), and — measured in the same run — plans the target from scratch
(the same schedule and speed, cold start) to show what retargeting bought.
"""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

import robots
import robots.gait as gait_io
from gaitsmith.console import console
from gaitsmith.errors import OptionError
from gaitsmith.options import (
    check_cycles,
    check_friction,
    check_integer,
    check_knots,
    check_output_file,
)
from planner.errors import InfeasibleGaitError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.retarget import (
    RetargetResult,
    SolveRecord,
    froude_factor,
    froude_number,
    match_legs,
    motion_from_gait,
    plan_from_scratch,
    retarget,
)
from robots.errors import RobotsError

MAX_STEPS = 20


def retarget_command(
    gait_file: Path = typer.Argument(..., help="gait file planned for the source robot"),
    to: str = typer.Option(..., "--to", help="target robot: built-in name or a robot folder"),
    output: Path = typer.Option(..., "--output", "-o", help="gait file to write (JSON)"),
    source: str | None = typer.Option(
        None, "--from", help="source robot (default: the robot named in the gait file)"
    ),
    steps: int = typer.Option(
        1, "--steps", help="solves in the series: K−1 hybrid bodies, then the target"
    ),
    knots: int | None = typer.Option(None, "--knots", help="knots per cycle (default: the file's)"),
    mu: float = typer.Option(0.5, "--mu", help="friction coefficient of the contact cone"),
    compare: bool = typer.Option(
        True, "--compare/--no-compare",
        help="also plan the target from scratch (same schedule, cold start) and print both",
    ),
    simulate: bool = typer.Option(
        False, "--simulate", help="validate in MuJoCo and write the verdict into the gait file"
    ),
    cycles: int = typer.Option(20, "--cycles", help="cycles to simulate (--simulate)"),
) -> None:
    """Retarget a gait to another body at equal Froude number and re-plan it there."""
    check_integer("--steps", steps, 1, MAX_STEPS)
    if knots is not None:
        check_knots("--knots", knots)
    check_friction("--mu", mu)
    if simulate:
        check_cycles("--cycles", cycles)
    check_output_file("--output", output)
    gait = gait_io.load(gait_file)
    src = _source_robot(gait, gait_file, source)
    if source is None and gait.robot_fingerprint != src.fingerprint:
        raise OptionError(
            f"{gait_file} was planned for {gait.robot}@{gait.robot_fingerprint}, but "
            f"'{gait.robot}' loads build {src.fingerprint}; pass its folder with --from"
        )
    gait.check_robot(src, str(gait_file))
    dst = robots.load(to)
    match = match_legs(src, dst)  # refuses different leg counts in one line
    n_knots = knots or gait.n_knots
    check_knots("--knots (the gait file's)", n_knots)
    factor = froude_factor(src, dst)
    speed_src = gait.velocity.vx_m_s
    console.print(
        f"retargeting [bold]{gait.gait_label}[/] of [bold]{src.name}[/] (leg {src.leg_length_m:.3f}"
        f" m, {speed_src:.3f} m/s, period {gait.period_s:.3f} s, Froude "
        f"{froude_number(speed_src, src.leg_length_m):.4f}) to [bold]{dst.name}[/] (leg "
        f"{dst.leg_length_m:.3f} m): speed and period × √(L_to/L_from) = {factor:.4f}, N={n_knots}"
    )
    legs = ", ".join(
        f"{src.legs[s].name}→{dst.legs[t].name}" for s, t in enumerate(match.target_foot)
    )
    held = [dst.joint_names[j] for j, s in enumerate(match.joint_source) if s < 0]
    console.print(f"legs by position: {legs}"
                  + (f"; joints held at stance: {held}" if held else ""))
    motion = motion_from_gait(gait, src, n_knots)
    options = PlannerOptions(mu=mu)
    with console.status("building the target's NLP (CasADi)…"):
        planner = GaitPlanner(dst, n_knots=n_knots, options=options)
    console.print(f"target NLP built in {planner.build_time_s:.1f} s")

    def progress(rec: SolveRecord) -> None:
        console.print(
            f"  solve α={rec.alpha:.2f} ({rec.robot}): {rec.speed_m_s:.3f} m/s, period "
            f"{rec.period_s:.3f} s, {rec.iterations} iterations, {rec.solve_time_s:.1f} s, cost "
            f"{rec.cost:.5g}" + ("" if rec.feasible else " [red](infeasible)[/]")
        )

    outcome = retarget(motion, dst, n_knots=n_knots, options=options, steps=steps,
                       progress=progress, target_planner=planner)
    if outcome.hybrid_note:
        console.print(f"[yellow]{outcome.hybrid_note}; the target starts from the mapped motion[/]")
    result = outcome.result
    scratch = plan_from_scratch(planner, result.schedule, result.speed_m_s) if compare else None
    console.print(_table(outcome, scratch))
    if not result.feasible:
        raise InfeasibleGaitError(
            f"{dst.name} retargeted {gait.gait_label} at {result.speed_m_s:.3f} m/s: "
            f"{result.message}; no gait file written", result.binding)
    meta = {"retarget": {
        "method": "dynamic similarity (Murphy, Carr & O'Neill 2008), equal Froude number",
        "source_robot": src.name, "source_fingerprint": src.fingerprint,
        "source_gait": str(gait_file), "source_speed_m_s": speed_src,
        "source_period_s": gait.period_s, "froude_factor": factor,
        "froude": froude_number(result.speed_m_s, dst.leg_length_m),
        "target_foot": list(match.target_foot), "joint_source": list(match.joint_source),
        "joint_sign": list(match.joint_sign), "steps": steps,
        "hybrid_note": outcome.hybrid_note, "solves": outcome.n_solves,
        "iterations": outcome.iterations, "solve_time_s": outcome.solve_time_s,
        "scratch": None if scratch is None else {
            "iterations": scratch.iterations, "solve_time_s": scratch.solve_time_s,
            "cost": scratch.cost if math.isfinite(scratch.cost) else None,
            "feasible": scratch.feasible},
    }}
    gait_obj = planner.to_gait(result, gait.gait_label, extra_metadata=meta)
    if simulate:
        from sim.validate import validate_and_annotate  # lazy: MuJoCo rollout only on request

        with console.status(f"validating in MuJoCo ({cycles} cycles)…"):
            gait_obj = validate_and_annotate(gait_obj, dst, cycles)
        v = gait_obj.validation or {}
        verdict = "[bold green]PASS[/]" if v.get("passed") else "[bold red]FAIL[/]"
        console.print(f"simulation verdict: {verdict} " + "; ".join(v.get("reasons", [])))
    gait_io.save(gait_obj, output)
    console.print(f"wrote [bold]{output}[/]")


def _source_robot(gait: gait_io.Gait, gait_file: Path, source: str | None) -> robots.Robot:
    if source is not None:
        return robots.load(source)
    try:
        return robots.load(gait.robot)
    except RobotsError as exc:
        raise OptionError(
            f"{gait_file} was planned for {gait.robot!r}, which is not a built-in robot ({exc}); "
            "pass its folder with --from"
        ) from None


def _table(outcome: RetargetResult, scratch: PlanResult | None) -> Table:
    table = Table(title="what retargeting bought (same NLP, schedule and speed)")
    for col in ("plan", "solves", "IPOPT iterations", "solve time [s]", "final cost", "feasible"):
        table.add_column(col, justify="right" if col != "plan" else "left")
    r = outcome.result
    label = "retarget" + (f" ({outcome.n_solves - 1} hybrids + target)"
                          if outcome.n_solves > 1 else " (warm start)")
    table.add_row(label, str(outcome.n_solves), str(outcome.iterations),
                  f"{outcome.solve_time_s:.2f}", f"{r.cost:.5g}", "yes" if r.feasible else "no")
    if scratch is not None:
        table.add_row("from scratch (cold start)", "1", str(scratch.iterations),
                      f"{scratch.solve_time_s:.2f}", f"{scratch.cost:.5g}",
                      "yes" if scratch.feasible else "no")
    return table


def register(app: typer.Typer) -> None:
    app.command("retarget")(retarget_command)

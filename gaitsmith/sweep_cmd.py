"""`gaitsmith sweep ROBOT --speeds 0.05,0.1,0.2,0.3 -o out/`: the best gait vs speed."""

from __future__ import annotations

from pathlib import Path

import typer

import robots
from gaitsmith.console import console
from gaitsmith.search_options import (
    check_executor,
    executor_option,
    search_knots_option,
    sim_accept_option,
    sim_acceptance,
    tipping_weight_option,
    workers_option,
)
from planner.config import PlannerOptions
from planner.errors import PlannerConfigError
from planner.gait_search import GaitSearchResult, SearchLogRow
from planner.speed_sweep import SweepRow, Validator, sweep_speeds, to_markdown, write_sweep


def sweep(
    robot: str = typer.Argument(..., help="built-in robot name or a robot folder"),
    speeds: str = typer.Option("0.05,0.1,0.2,0.3", "--speeds", help="comma-separated speeds [m/s]"),
    output: Path = typer.Option(..., "--output", "-o", help="folder for sweep.csv/.md/.png"),
    knots: int = typer.Option(30, "--knots", help="knots per cycle (N)"),
    generations: int = typer.Option(6, "--generations", help="basin-CMA generations per speed"),
    popsize: int | None = typer.Option(None, "--popsize", help="basin-CMA λ"),
    seed: int = typer.Option(0, "--seed"),
    symmetric: bool = typer.Option(True, "--symmetric/--no-symmetric"),
    mu: float = typer.Option(0.5, "--mu", help="friction coefficient"),
    executor: str = executor_option(),
    workers: int | None = workers_option(),
    search_knots: int = search_knots_option(),
    tipping_weight: float = tipping_weight_option(),
    sim_accept: bool = sim_accept_option(),
    simulate: bool = typer.Option(
        False, "--simulate", help="validate each speed's gait in MuJoCo (pass/fail column)"),
    cycles: int = typer.Option(12, "--cycles", help="cycles to simulate (--simulate)"),
) -> None:
    """Search the best gait at each speed; table + plot of gait, duty factor and CoT vs Froude."""
    bot = robots.load(robot)
    try:
        values = [float(v) for v in speeds.split(",") if v.strip()]
    except ValueError:
        raise PlannerConfigError(
            f"--speeds must be numbers separated by commas, got {speeds!r}"
        ) from None
    if not values or any(not 0 < v <= 10 for v in values):
        raise PlannerConfigError(f"--speeds must be in (0, 10] m/s, got {speeds!r}")

    def on_row(row: SweepRow) -> None:
        sim = "" if row.sim_passed is None else \
            f", sim {'pass' if row.sim_passed else 'FAIL'} at {row.sim_speed_m_s:.3f} m/s"
        console.print(f"[bold]{row.speed_m_s:.3f} m/s[/] (Fr {row.froude:.3f}): {row.gait_label}, "
                      f"duty {row.mean_duty_factor:.2f}, period {row.period_s:.3f} s, search cost "
                      f"{row.search_cost:.4g} vs template {row.best_template} "
                      f"{row.best_template_cost:.4g}, tipping {row.tipping_amplification:.3g}, "
                      f"CoT {row.cost_of_transport:.3f}{sim} ({row.elapsed_s:.0f} s)")

    def progress(row: SearchLogRow) -> None:
        if row.generation >= 0:
            console.print(f"    gen {row.generation}: best {row.best_cost:.4g}, mean "
                          f"{row.gait_label} {row.period_s:.3f} s", highlight=False)

    check_executor(executor)
    console.print(f"gait-from-speed sweep for [bold]{bot.name}[/] over {values} m/s")
    rows = sweep_speeds(bot, values, n_knots=knots, options=PlannerOptions(mu=mu),
                        symmetric=symmetric, max_generations=generations, popsize=popsize,
                        seed=seed, executor=executor, workers=workers,
                        search_knots=search_knots, tipping_weight=tipping_weight,
                        **sim_acceptance(bot, sim_accept, cycles),
                        validator=_sim_validator(cycles) if simulate else None,
                        on_row=on_row, progress=progress)
    paths = write_sweep(rows, output, bot)
    console.print(to_markdown(rows))
    console.print("wrote " + ", ".join(str(p) for p in paths.values()))


def _sim_validator(cycles: int) -> Validator:
    def validate_result(result: GaitSearchResult) -> tuple[bool, float]:
        from sim.validate import validate  # lazy: MuJoCo rollouts only on request

        gait = result.planner.to_gait(result.best, result.label)
        v = validate(gait, result.robot, cycles, keep_trajectory=False)
        return v.passed, v.metrics.achieved_speed_m_s

    return validate_result


def register(app: typer.Typer) -> None:
    app.command("sweep")(sweep)

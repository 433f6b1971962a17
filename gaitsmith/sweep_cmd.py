"""`gaitsmith sweep ROBOT --speeds 0.05,0.1,0.2,0.3 -o out/`: the best gait vs speed."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import typer

import robots
from gaitsmith.attitude_options import attitude_gain_option, check_attitude_judged
from gaitsmith.console import console
from gaitsmith.errors import OptionError, OutputError
from gaitsmith.options import (
    check_cycles,
    check_friction,
    check_knots,
    check_output_dir,
    check_speed,
)
from gaitsmith.plan_options import (
    planner_options,
    search_final_half_cycle,
    search_planner_options,
    template_half_cycle,
)
from gaitsmith.plan_output import DEFAULT_CYCLES
from gaitsmith.search_options import (
    check_final_templates,
    check_search_options,
    executor_option,
    final_templates_option,
    search_half_cycle_option,
    search_knots_option,
    sim_accept_option,
    sim_acceptance,
    tipping_weight_option,
    workers_option,
)
from gaitsmith.stance_options import stance_shaped
from planner.nlp.config import PlannerOptions, default_speeds_m_s
from planner.search.defaults import DEFAULT_GENERATIONS
from planner.search.gait_search import GaitSearchResult, SearchLogRow
from planner.search.speed_sweep import (
    SimOutcome,
    SweepRow,
    Validator,
    sweep_speeds,
    to_markdown,
    write_sweep,
)
from robots.errors import OutputWriteError


def sweep(
    robot: str = typer.Argument(..., help="built-in robot name or a robot folder"),
    speeds: str | None = typer.Option(
        None, "--speeds", help="comma-separated speeds [m/s] (default: Froude numbers "
        "0.002, 0.01, 0.03, 0.06 for the robot's leg length, ≈ 0.05-0.3 m/s at 18 cm)"),
    output: Path = typer.Option(..., "--output", "-o", help="folder for sweep.csv/.md/.png"),
    knots: int = typer.Option(30, "--knots", help="knots per cycle (N)"),
    generations: int = typer.Option(DEFAULT_GENERATIONS, "--generations",
                                    help="basin-CMA generations per speed"),
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
    cycles: int = typer.Option(
        DEFAULT_CYCLES, "--cycles",
        help=f"cycles to simulate (--simulate, --sim-accept; default {DEFAULT_CYCLES}, as plan)"),
    attitude_gain: float | None = attitude_gain_option(),
    search_half_cycle: bool = search_half_cycle_option(),
    final_templates: str = final_templates_option(),
    half_cycle: bool | None = typer.Option(
        None, "--half-cycle/--full-cycle",
        help="the final re-solves on the first half of a symmetric timing's knots, or on all "
        "of them. Default: half-cycle for the searched candidates (one that fails the MuJoCo "
        "check narrowly re-solved on all knots) and for the templates (as plan --gait plans "
        "them); given, it sets both"),
) -> None:
    """Search the best gait at each speed; table + plot of gait, duty factor and CoT vs Froude."""
    values = None if speeds is None else parse_speeds(speeds)
    check_knots("--knots", knots)
    check_friction("--mu", mu)
    check_search_options(executor, generations, popsize, workers, search_knots, tipping_weight)
    check_final_templates(final_templates)
    if simulate or sim_accept:
        check_cycles("--cycles", cycles)
    check_attitude_judged(attitude_gain, simulate or sim_accept, "--simulate or --sim-accept")
    check_output_dir("--output", output)
    bot = robots.load(robot)
    if values is None:  # speeds at fixed Froude numbers, v = √(Fr·g·L)
        values = default_speeds_m_s(bot.leg_length_m)
    clock = SweepClock(len(values))

    def on_row(row: SweepRow) -> None:
        clock.finish_speed()
        loop = (f", attitude gain {row.sim_attitude_gain:g}" if row.sim_attitude_gain > 0
                else "")
        sim = "" if row.sim_passed is None else \
            f", sim {'pass' if row.sim_passed else 'FAIL'} at {row.sim_speed_m_s:.3f} m/s{loop} " \
            f"({row.sim_gait}: flight {100 * row.sim_flight_fraction:.1f} %, double support " \
            f"{100 * row.sim_double_support_fraction:.1f} %)"
        console.print(f"[bold]{row.speed_m_s:.3f} m/s[/] (Fr {row.froude:.3f}): {row.gait_label}, "
                      f"duty {row.mean_duty_factor:.2f}, period {row.period_s:.3f} s, search cost "
                      f"{row.search_cost:.4g} vs template {row.best_template} "
                      f"{row.best_template_cost:.4g}, tipping {row.tipping_amplification:.3g}, "
                      f"CoT {row.cost_of_transport:.3f}{sim} ({row.elapsed_s:.0f} s)")

    def progress(row: SearchLogRow) -> None:
        if row.generation < 0:  # every speed's search starts by seeding with the templates
            console.print(clock.start_speed(values), highlight=False)
        else:
            console.print(f"    gen {row.generation}: best {row.best_cost:.4g}, mean "
                          f"{row.gait_label} {row.period_s:.3f} s", highlight=False)

    console.print(f"gait-from-speed sweep for [bold]{bot.name}[/] over {values} m/s")
    # the stance-compliance rule, as `plan` applies it (`gaitsmith.stance_options`)
    shaped = stance_shaped(bot, None, None, None, None)
    options = search_planner_options(planner_options(mu, PlannerOptions.derivatives, shaped,
                                                     rotor_reserve=None, swing_clearance=None,
                                                     half_cycle=template_half_cycle(half_cycle)))
    entry = shaped.entry or 1
    rows = sweep_speeds(bot, values, n_knots=knots, options=options,
                        symmetric=symmetric, max_generations=generations, popsize=popsize,
                        seed=seed, executor=executor, workers=workers,
                        search_knots=search_knots, tipping_weight=tipping_weight,
                        **sim_acceptance(bot, sim_accept, cycles, entry, attitude_gain),
                        validator=(_sim_validator(cycles, entry, attitude_gain) if simulate
                                   else None),
                        on_row=on_row, progress=progress,
                        final_half_cycle=search_final_half_cycle(half_cycle),
                        search_half_cycle=search_half_cycle, final_templates=final_templates)
    try:
        paths = write_sweep(rows, output, bot)
    except OutputWriteError:
        raise
    except OSError as exc:  # e.g. the folder vanished or became read-only during the sweep
        raise OutputError(f"--output {output}: cannot write the sweep: {exc.strerror or exc}"
                          ) from None
    console.print(to_markdown(rows))
    console.print(f"{len(values)} speeds in {format_duration(clock.elapsed_s())}")
    console.print("wrote " + ", ".join(str(p) for p in paths.values()))


def parse_speeds(text: str) -> list[float]:
    """`--speeds 0.05,0.1`: comma-separated speeds, each finite and in (0, 10] m/s."""
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise OptionError(
            f"--speeds must be numbers separated by commas, got {text!r}") from None
    if not values:
        raise OptionError("--speeds needs at least one speed, e.g. --speeds 0.1,0.2")
    for v in values:
        check_speed("--speeds", v, allow_zero=False)
    return values


def format_duration(seconds: float) -> str:
    """12 s, 3 min 05 s, 1 h 02 min."""
    s = round(max(seconds, 0.0))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class SweepClock:
    """Which speed of the sweep runs, time elapsed, and an ETA from the speeds done so far
    (the mean time per finished speed times the speeds left, minus the current one's time)."""

    def __init__(self, n_speeds: int, clock: Callable[[], float] = time.monotonic) -> None:
        self.n_speeds = n_speeds
        self._clock = clock
        self._t0 = clock()
        self._started_at: float | None = None
        self.started = 0
        self.finished = 0
        self._finished_time_s = 0.0

    def elapsed_s(self) -> float:
        return self._clock() - self._t0

    def start_speed(self, speeds: list[float]) -> str:
        """Mark the next speed as started; the progress line to print."""
        self.started += 1
        self._started_at = self._clock()
        speed = speeds[min(self.started, len(speeds)) - 1]
        line = (f"speed {self.started}/{self.n_speeds}: {speed:.3f} m/s — "
                f"{format_duration(self.elapsed_s())} elapsed")
        eta = self.eta_s()
        return line + (f", ETA {format_duration(eta)}" if eta is not None else
                       ", ETA after the first speed")

    def finish_speed(self) -> None:
        self.finished += 1
        if self._started_at is not None:
            self._finished_time_s += self._clock() - self._started_at
            self._started_at = None

    def eta_s(self) -> float | None:
        """Seconds left, or None before a speed has finished."""
        if not self.finished:
            return None
        per_speed = self._finished_time_s / self.finished
        running = 0.0 if self._started_at is None else self._clock() - self._started_at
        left = self.n_speeds - self.finished
        return max(per_speed * left - running, 0.0)


def _sim_validator(cycles: int, entry_cycles: int = 1,
                   attitude_gain: float | None = None) -> Validator:
    """Each speed's gait in MuJoCo, started with at least `entry_cycles` entry blend cycles,
    with the attitude feedback it gets (`attitude_gain`, else the robot's rule per gait)."""
    def validate_result(result: GaitSearchResult) -> SimOutcome:
        import numpy as np

        from robots.attitude import ATTITUDE_GAIN_KEY
        from sim.acceptance import validate_as_played, with_entry_cycles

        gait = with_entry_cycles(result.planner.to_gait(result.best, result.label), entry_cycles)
        v = validate_as_played(gait, result.robot, cycles, attitude_gain)
        traj = v.trajectory
        assert traj is not None  # keep_trajectory=True
        # the steady steps, as `Trajectory.flight_fraction` counts them (cycle 2 to the end)
        steady = (traj.gait_phase() >= 2.0) & (traj.time_s <= traj.gait_end_s)
        down = traj.foot_contacts[steady] > 0
        double = float(np.mean(np.all(down, axis=1))) if down.size else float("nan")
        gain = float(v.conditions.get(ATTITUDE_GAIN_KEY) or 0.0)
        return SimOutcome(v.passed, v.metrics.achieved_speed_m_s, traj.flight_fraction(), double,
                          gain)

    return validate_result


def register(app: typer.Typer) -> None:
    app.command("sweep")(sweep)

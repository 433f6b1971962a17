"""`gaitsmith library ROBOT -o lib.json`: plan and validate a grid of commands → gait library.

Wiring only: `planner.library.build_library` plans (warm-started waves on the process pool or
Ray), `SimValidator` validates each entry in MuJoCo (`sim.validate`, the same block
`gaitsmith plan --simulate` writes), `robots.library.save` writes the file atomically. Every
option is checked before any solve; an entry that fails is reported and left out.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import typer
from rich.table import Table

import robots
from gaitsmith.attitude_options import attitude_gain_option, check_attitude_gain
from gaitsmith.console import console
from gaitsmith.errors import OptionError
from gaitsmith.gait_choice import check_gait_fits, default_gait, grid_gait
from gaitsmith.options import (
    check_cycles,
    check_integer,
    check_knots,
    check_output_file,
    check_velocity,
    check_yaw_rate,
)
from gaitsmith.search_options import MAX_WORKERS
from gaitsmith.validation_record import validation_record
from planner.errors import TemplateError
from planner.library import (
    EntryOutcome,
    GridSpec,
    LibraryBuildError,
    build_library,
    check_grid,
    default_grid,
)
from planner.nlp.config import PlannerOptions
from planner.templates import make_schedule
from robots import Gait, Robot
from robots import library as libfile
from robots.attitude import validated_attitude_gain
from robots.library import velocity_tuple

MAX_AXIS_VALUES = 15


def _values(option: str, text: str | None) -> tuple[float, ...] | None:
    """A comma-separated list of numbers, e.g. "-0.1,0,0.1" (None: not given)."""
    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise OptionError(
            f"{option} must be a comma-separated list of numbers, got {text!r}") from None
    if len(values) > MAX_AXIS_VALUES:
        raise OptionError(f"{option}: at most {MAX_AXIS_VALUES} values, got {len(values)}")
    if len(set(values)) != len(values):
        raise OptionError(f"{option}: repeats a value ({text})")
    for v in values:
        if not math.isfinite(v):
            raise OptionError(f"{option}: {v} is not a finite number")
    return values


@dataclass
class _SimCheck:
    robot: Robot
    cycles: int
    attitude_gain: float | None = None

    def __call__(self, gait: Gait) -> dict[str, Any]:
        from sim.acceptance import validate_as_played

        result = validate_as_played(gait, self.robot, self.cycles, self.attitude_gain)
        return validation_record(result, gait, self.robot)[0]


@dataclass(frozen=True)
class SimValidator:
    """Picklable factory (built once per worker) of the MuJoCo validation of one gait, with
    the attitude feedback each gait gets (`attitude_gain`, i.e. ``--attitude-gain``; None: the
    robot's rule per gait, `robots.attitude.gait_attitude_gain`), recorded in its verdict's
    conditions as `gaitsmith plan --simulate` records it."""

    robot_dir: str
    cycles: int
    attitude_gain: float | None = None

    def __call__(self) -> _SimCheck:
        return _SimCheck(robots.load(self.robot_dir), self.cycles, self.attitude_gain)


def _fmt(v: robots.Velocity) -> str:
    return "vx {:+.3f} vy {:+.3f} yaw {:+.3f}".format(*velocity_tuple(v))


def _progress(i: int, n: int, o: EntryOutcome) -> None:
    head = f"  [{i:2d}/{n}] {_fmt(o.command)}"
    warm = " (warm)" if o.warm_started else ""
    gain = validated_attitude_gain(None if o.gait is None else o.gait.validation)
    times = (f"plan {o.plan_s:5.1f} s{warm}, sim {o.validate_s:4.1f} s"
             + (f" closed loop, attitude gain {gain:g}" if gain else ""))
    if o.passed and o.achieved is not None:
        console.print(f"{head}  [green]PASS[/]  achieved {_fmt(o.achieved)}  ({times})")
    else:
        console.print(f"{head}  [red]FAIL[/]  {o.reason}  ({times}); left out",
                      highlight=False, markup=True)


AUTO_FAMILY = "auto"  # --family auto: the family `plan` would choose for the grid's turns


def library(
    robot: str = typer.Argument(
        ..., help="built-in robot name or a folder with robot.xml + robot.toml"),
    output: Path = typer.Option(..., "--output", "-o", help="library file to write (JSON)"),
    vx: str | None = typer.Option(
        None, "--vx", help="forward speeds [m/s], comma-separated (default: −v/2,0,v/2,v with "
        "v the Froude-law speed of the leg length)"),
    vy: str | None = typer.Option(None, "--vy", help="lateral speeds [m/s] (default: 0)"),
    yaw_rate: str | None = typer.Option(
        None, "--yaw-rate", help="yaw rates [rad/s] (default: −w,0,w with the feet sweeping "
        "at v/2 about the body centre)"),
    family: str | None = typer.Option(
        None, "--family", help="schedule family shared by every entry (default: the robot's "
        "default gait, e.g. trot on 4 legs, tripod on 6); 'auto': as `gaitsmith plan` chooses "
        "for turns — a grid that turns or side-steps on a robot whose default stands on a "
        "support line, such as a trot, uses the static walk for every entry"),
    knots: int = typer.Option(30, "--knots", help="knots per cycle (N)"),
    cycles: int = typer.Option(20, "--cycles", help="cycles simulated per entry"),
    workers: int | None = typer.Option(
        None, "--workers", help="parallel workers (default: one per core; 1: in-process)"),
    ray: bool = typer.Option(False, "--ray", help="run the entries on Ray instead of a "
                             "process pool (needs gaitsmith[ray])"),
    address: str | None = typer.Option(None, "--address", help="Ray cluster address (--ray)"),
    warm: bool = typer.Option(
        True, "--warm/--cold", help="warm-start each entry from a solved neighbour (waves from "
        "the command nearest zero), or solve all from the template's guess in one batch"),
    attitude_gain: float | None = attitude_gain_option(),
) -> None:
    """Plan a gait library: one schedule family over a grid of (vx, vy, yaw rate) commands,
    each entry validated in MuJoCo, with the stand; blended live by `gaitsmith-play drive`."""
    axes = (_values("--vx", vx), _values("--vy", vy), _values("--yaw-rate", yaw_rate))
    for option, values in zip(("--vx", "--vy"), axes[:2], strict=True):
        for v in values or ():
            check_velocity(option, v)
    check_knots("--knots", knots)
    check_cycles("--cycles", cycles)
    check_attitude_gain("--attitude-gain", attitude_gain)
    check_integer("--workers", workers, 1, MAX_WORKERS)
    if address is not None and not ray:
        raise OptionError("--address is for Ray: add --ray")
    check_output_file("--output", output)
    bot = robots.load(robot)
    for v in axes[2] or ():
        check_yaw_rate("--yaw-rate", v, bot)
    auto = family == AUTO_FAMILY
    fam = default_gait(bot) if family is None or auto else family
    try:
        check_gait_fits(bot, fam)
    except TemplateError as exc:  # worded for `plan --gait`; here the option is --family
        raise OptionError(str(exc).replace("--gait ", "--family ", 1)) from None
    base = default_grid(bot, fam)
    vy_values, yaw_values = axes[1] or base.vy_m_s, axes[2] or base.yaw_rate_rad_s
    # one family for the whole grid, chosen as `plan` chooses it for its turns (issue #15)
    # (`--family auto`): measured on quad12, its static walk turns in place and walks slowly
    # but plans no arc, while the default trot grid turns on arcs at trotting speed
    # (docs/results/gait_library.md), so the default keeps the robot's default gait
    choice = grid_gait(bot, None if auto else fam, vy_values, yaw_values, PlannerOptions())
    fam = choice.gait
    schedule = make_schedule(bot, fam, choice.period_s, choice.duty_factor)
    if axes[2] is None and choice.period_s is not None:  # the yaw cap of the chosen period
        yaw_values = default_grid(bot, fam, schedule.period_s).yaw_rate_rad_s
    try:
        grid = GridSpec(axes[0] or base.vx_m_s, vy_values, yaw_values)
        check_grid(bot, grid, schedule, knots)
    except LibraryBuildError as exc:
        raise OptionError(f"--vx/--vy/--yaw-rate: {exc}") from None
    executor = "ray" if ray else ("serial" if workers == 1 else "process")
    n_workers = workers or (None if ray else max(1, min(os.cpu_count() or 1, grid.size)))
    console.print(
        f"gait library for [bold]{bot.name}[/]: {fam}, {grid.size} commands "
        f"(vx {list(grid.vx_m_s)} m/s, vy {list(grid.vy_m_s)} m/s, yaw rate "
        f"{list(grid.yaw_rate_rad_s)} rad/s), N={knots}, {cycles} cycles in MuJoCo each, "
        f"executor {executor}" + (f" × {n_workers}" if n_workers else "")
        + ("" if warm else ", cold starts"))
    console.print(f"family for every entry: {fam} (duty {schedule.duty_factor[0]:g}, period "
                  f"{schedule.period_s:.3f} s) — {choice.reason}", highlight=False)
    validator = SimValidator(str(bot.root_dir), cycles, attitude_gain)
    with console.status("validating the stand in MuJoCo…"):
        stand_check = validator()
    build = build_library(
        bot, grid, family=fam, period_s=choice.period_s, duty_factor=choice.duty_factor,
        family_reason=choice.reason, n_knots=knots, options=choice.options, validator=validator,
        stand_validator=stand_check, executor=executor, workers=n_workers, address=address,
        on_entry=_progress, warm_start=warm)
    lib = build.library
    _summary(build.outcomes)
    libfile.save(lib, output)
    failed = len(build.outcomes) - len(lib.entries)
    console.print(
        f"wrote [bold]{output}[/]: {len(lib.entries)} entries + the stand"
        + (f" ({failed} failed, left out)" if failed else "")
        + f", built in {build.time_s:.1f} s")


def _summary(outcomes: tuple[EntryOutcome, ...]) -> None:
    table = Table(title="library entries")
    for col in ("vx", "vy", "yaw", "verdict", "achieved vx", "vy", "yaw", "plan s", "sim s"):
        table.add_column(col)
    for o in outcomes:
        a = velocity_tuple(o.achieved) if o.achieved is not None else (math.nan,) * 3
        table.add_row(*(f"{x:+.3f}" for x in velocity_tuple(o.command)),
                      "[green]pass[/]" if o.passed else "[red]FAIL[/]",
                      *(f"{x:+.3f}" for x in a), f"{o.plan_s:.1f}", f"{o.validate_s:.1f}")
    console.print(table)


def register(app: typer.Typer) -> None:
    app.command("library")(library)

"""`gaitsmith cache` (what the cache holds, what is compiling) and `gaitsmith cache build ROBOT`.

`cache build` compiles one knot's Jacobian and Lagrangian Hessian to C
(`planner.nlp.compiled_knot`, about a minute of CPU once per robot) into the planner's disk cache
(``$GAITSMITH_CACHE`` or ``~/.cache/gaitsmith``); every later `gaitsmith plan` with the default
``--solver knot`` then loads them in milliseconds and solves faster. A plan that finds no compiled
entry starts the same compile in the background by itself (`planner.nlp.background_compile`);
`gaitsmith cache` shows those compiles, their logs and any that failed.
"""

from __future__ import annotations

import time

import typer
from rich.markup import escape

import robots
from gaitsmith.console import console
from gaitsmith.errors import CliError

cache_app = typer.Typer(help="The planner's disk cache of per-robot knot derivatives.",
                        invoke_without_command=True)


class CacheBuildError(CliError):
    """The knot derivatives could not be compiled (no compiler, compiler failed, not writable)."""


def _say(text: str) -> None:
    console.print(escape(text), highlight=False, soft_wrap=True)


@cache_app.callback()
def cache_command(ctx: typer.Context) -> None:
    """Show the cache folder, the C compiler, the compiled robots and the compiles running."""
    if ctx.invoked_subcommand is None:
        show_status()


@cache_app.command("status")
def status_command() -> None:
    """The same as `gaitsmith cache`."""
    show_status()


def show_status() -> None:
    """Print what `gaitsmith cache` shows."""
    from planner.nlp import background_compile
    from planner.nlp.compiled_knot import find_compiler
    from planner.nlp.solver_cache import cache_dir

    folder = cache_dir()
    _say(f"cache folder: {folder}")
    compiler = find_compiler()
    _say(f"C compiler: {compiler.path} ({compiler.version}), flags "
         f"{' '.join(compiler.flags)}" if compiler is not None else
         "C compiler: none found (gcc, cc or $GAITSMITH_CC): plans use the uncompiled knot "
         "derivatives")
    switch = "on" if background_compile.enabled() else "off"
    _say(f"background compile after a plan: {switch} (${background_compile.ENV_SWITCH})")
    state = background_compile.cache_status(folder)
    for manifest, label, size, flags in state.compiled:
        _say(f"compiled: {label or '(robot not recorded)'} {' '.join(flags)}, "
             f"{size / 1e6:.1f} MB  {manifest.with_suffix('.so').name}")
    running_logs = {run.log for run in state.running}
    for run in state.running:
        _say(f"compiling: {run.label or '(robot not recorded)'} (pid {run.pid}, since "
             f"{run.started_utc}), log: {run.log}")
    for path, record in state.attempts:
        if path.with_suffix("").with_suffix(".log") in running_logs:
            continue  # the running one's own attempt
        label = record.label or "(robot not recorded)"
        if record.gave_up:
            _say(f"not compiling again: {label} ({record.attempts} attempts, "
                 f"{record.failures} failed: {record.last_error or 'interrupted'}); "
                 f"`gaitsmith cache build {record.label or 'ROBOT'}` compiles it in the "
                 "foreground")
        else:
            _say(f"unfinished: {label} ({record.attempts} attempts, {record.failures} failed"
                 f"{': ' + record.last_error if record.last_error else ''}); the next plan "
                 "tries again")
    if not (state.compiled or state.running or state.attempts):
        _say("no compiled knot derivatives yet")


@cache_app.command("build")
def build_command(
    robot: str = typer.Argument(..., help="robot name or folder (robot.toml + MJCF/URDF)"),
) -> None:
    """Compile ROBOT's knot derivatives into the cache (minutes; planning is faster after)."""
    from planner.nlp.compiled_knot import CompileError
    from planner.nlp.constraints import knot_function
    from planner.nlp.model import RobotModel
    from planner.nlp.solver_cache import compiled_jacobian_and_hessian
    from robots.errors import OutputWriteError

    rob = robots.load(robot)
    t0 = time.perf_counter()
    knot = knot_function(RobotModel(rob))
    try:
        _, _, outcome = compiled_jacobian_and_hessian(knot, label=rob.name)
    except (CompileError, OutputWriteError) as exc:
        raise CacheBuildError(f"{rob.name}: {exc}") from exc
    done = "already compiled" if outcome.status == "hit" else (
        f"compiled in {time.perf_counter() - t0:.0f} s")
    console.print(f"{escape(rob.name)}: knot derivatives {done}: {escape(str(outcome.path))}",
                  highlight=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    app.add_typer(cache_app, name="cache")

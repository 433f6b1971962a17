"""`gaitsmith cache build ROBOT`: compile the robot's knot derivatives ahead of time (issue #16).

Compiles one knot's Jacobian and Lagrangian Hessian to C (`planner.nlp.compiled_knot`, minutes
once per robot) into the planner's disk cache (``$GAITSMITH_CACHE`` or ``~/.cache/gaitsmith``);
every later `gaitsmith plan` with the default ``--solver knot`` then loads them in milliseconds
and solves faster. Nothing else waits for the compiler.
"""

from __future__ import annotations

import time

import typer
from rich.markup import escape

import robots
from gaitsmith.console import console
from gaitsmith.errors import CliError

cache_app = typer.Typer(help="The planner's disk cache of per-robot knot derivatives.")


class CacheBuildError(CliError):
    """The knot derivatives could not be compiled (no compiler, compiler failed, not writable)."""


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
        _, _, outcome = compiled_jacobian_and_hessian(knot)
    except (CompileError, OutputWriteError) as exc:
        raise CacheBuildError(f"{rob.name}: {exc}") from exc
    done = "already compiled" if outcome.status == "hit" else (
        f"compiled in {time.perf_counter() - t0:.0f} s")
    console.print(f"{escape(rob.name)}: knot derivatives {done}: {escape(str(outcome.path))}",
                  highlight=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    app.add_typer(cache_app, name="cache")

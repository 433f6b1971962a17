"""`gaitsmith`: plan gaits, simulate them, inspect robots.

Each subcommand lives in its own module and registers itself here; `main` turns the packages'
typed errors into one clear line and exit code 2 — never a traceback.
"""

from __future__ import annotations

import importlib
import sys

import typer
from rich.markup import escape

from gaitsmith.console import err_console
from gaitsmith.errors import CliError
from robots.cli_usage import run_app
from robots.errors import RobotsError

app = typer.Typer(
    name="gaitsmith",
    help="Plan efficient cyclic gaits for servo-legged robots and prove them in MuJoCo.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)

# subcommand modules: each defines `register(app)`
_COMMAND_MODULES = (
    "gaitsmith.robots_cmd",
    "gaitsmith.plan_cmd",
    "gaitsmith.simulate_cmd",
    "gaitsmith.sweep_cmd",
    "gaitsmith.retarget_cmd",
    "gaitsmith.identify_cmd",
    "gaitsmith.library_cmd",
    "gaitsmith.drive_sim_cmd",
    "gaitsmith.design_cmd",
    "gaitsmith.cache_cmd",
)
for _name in _COMMAND_MODULES:
    try:
        _module = importlib.import_module(_name)
    except ModuleNotFoundError as _exc:
        if _exc.name != _name:
            raise
        continue
    _module.register(app)


def user_error_types() -> tuple[type[BaseException], ...]:
    """The error base classes whose message is meant for the user (no traceback)."""
    errors: list[type[BaseException]] = [CliError, RobotsError]
    for module, cls in (("planner.errors", "PlannerError"), ("sim.errors", "SimError")):
        try:
            errors.append(getattr(importlib.import_module(module), cls))
        except (ImportError, AttributeError):
            continue
    return tuple(errors)


def _print_error(message: str) -> None:
    """One line on stderr (no wrapping, no rich markup taken from the message)."""
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)


def _print_interrupted() -> None:
    err_console.print("[yellow]interrupted[/]")


def main(argv: list[str] | None = None) -> int:
    """Run `gaitsmith`; every user mistake is one line on stderr and a non-zero exit code:
    2 for usage and input errors, 1 for a failed check, 130 for Ctrl-C
    (`robots.cli_usage.run_app`)."""
    return run_app(app, argv, user_error_types(), _print_error, _print_interrupted)


if __name__ == "__main__":
    sys.exit(main())

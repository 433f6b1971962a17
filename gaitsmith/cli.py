"""`gaitsmith`: plan gaits, simulate them, inspect robots.

Each subcommand lives in its own module and registers itself here; `main` turns the packages'
typed errors into one clear line and exit code 2 — never a traceback.
"""

from __future__ import annotations

import importlib
import sys

import typer

from gaitsmith.console import err_console
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
    errors: list[type[BaseException]] = [RobotsError]
    for module, cls in (("planner.errors", "PlannerError"), ("sim.errors", "SimError")):
        try:
            errors.append(getattr(importlib.import_module(module), cls))
        except (ImportError, AttributeError):
            continue
    return tuple(errors)


def main(argv: list[str] | None = None) -> int:
    try:
        code = app(args=argv, standalone_mode=False)  # click returns typer.Exit's code here
    except user_error_types() as exc:
        err_console.print(f"[bold red]error:[/] {exc}")
        return 2
    except KeyboardInterrupt:
        err_console.print("[yellow]interrupted[/]")
        return 130
    except typer.Exit as exc:
        return int(exc.exit_code or 0)
    except typer.Abort:
        return 1
    except Exception as exc:  # click usage errors
        import click

        if isinstance(exc, click.ClickException):
            exc.show()
            return exc.exit_code
        raise
    return code if isinstance(code, int) else 0


if __name__ == "__main__":
    sys.exit(main())

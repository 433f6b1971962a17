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


def usage_error_type() -> type[Exception]:
    """The class of click's usage errors as this typer raises them.

    typer ≤ 0.1x raises `click.ClickException`s; typer 0.2x vendors click as `typer._click` and
    does not depend on click at all. Both make `typer.BadParameter` a subclass of the one they
    use, so it is found there — no `import click`, which a plain install may not have.
    """
    for cls in typer.BadParameter.__mro__:
        if cls.__name__ == "ClickException" and issubclass(cls, Exception):
            return cls
    return typer.BadParameter


def usage_message(exc: Exception) -> str:
    """click's usage error in one line: its message plus where to find help."""
    format_message = getattr(exc, "format_message", None)
    text = format_message() if callable(format_message) else str(exc)
    text = " ".join(str(text).split())  # one line, whatever click wrapped
    ctx = getattr(exc, "ctx", None)
    command_path = getattr(ctx, "command_path", None)
    return f"{text} (see '{command_path} --help')" if command_path else text


INTERRUPTED_EXIT_CODE = 130  # 128 + SIGINT, what shells report for Ctrl-C


def _print_error(message: str) -> None:
    """One line on stderr (no wrapping, no rich markup taken from the message)."""
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)


def _interrupted() -> int:
    err_console.print("[yellow]interrupted[/]")
    return INTERRUPTED_EXIT_CODE


def main(argv: list[str] | None = None) -> int:
    """Run `gaitsmith`; every user mistake is one line on stderr and a non-zero exit code:
    2 for usage and input errors, 1 for a failed check, 130 for Ctrl-C."""
    try:
        code = app(args=argv, standalone_mode=False)
    except user_error_types() as exc:
        _print_error(str(exc))
        return 2
    except KeyboardInterrupt:
        return _interrupted()
    except typer.Exit as exc:  # raised outside the command (typer returns the code otherwise)
        code = exc.exit_code
    except typer.Abort as exc:  # typer ≤ 0.1x turns Ctrl-C into Abort
        if isinstance(exc.__cause__ or exc.__context__, KeyboardInterrupt):
            return _interrupted()
        err_console.print("[bold red]aborted[/]")
        return 1
    except usage_error_type() as exc:
        if type(exc).__name__ == "NoArgsIsHelpError":  # click ≥ 8.2: `gaitsmith` alone
            exc.show()  # type: ignore[attr-defined]  # prints the help
        else:
            _print_error(usage_message(exc))
        return int(getattr(exc, "exit_code", 2))
    code = int(code) if isinstance(code, int) else 0
    if code == INTERRUPTED_EXIT_CODE:  # typer 0.2x turns Ctrl-C into Exit(130), returned here
        return _interrupted()
    return code


if __name__ == "__main__":
    sys.exit(main())

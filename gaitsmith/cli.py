"""`gaitsmith`: plan gaits, simulate them, inspect robots.

Each subcommand lives in its own module (`register(app)` adds it); `_COMMANDS` names them, and a
command's module is imported only when that command runs or `--help` lists it, so a command
does not pay for the others' imports (issue #16). `main` turns the packages' typed errors into
one clear line and exit code 2 — never a traceback.
"""

from __future__ import annotations

import gc
import importlib
import importlib.util
import os
import sys
from collections.abc import Iterator, Mapping
from typing import Any

import typer
import typer.main
from rich.markup import escape
from typer.core import TyperGroup

from gaitsmith.console import err_console
from gaitsmith.errors import CliError
from gaitsmith.option_coercion import install as _install_option_coercion
from robots.cli_usage import run_app
from robots.errors import RobotsError
from robots.mujoco_gl import defer_gl_backend

# the subcommands, in the order `gaitsmith --help` lists them, and the module that defines each
# (`register(app)` there adds it); a group of its own (`add_typer`) is listed after the commands,
# as typer orders them
_COMMANDS: tuple[tuple[str, str], ...] = (
    ("plan", "gaitsmith.plan_cmd"),
    ("simulate", "gaitsmith.simulate_cmd"),
    ("sweep", "gaitsmith.sweep_cmd"),
    ("retarget", "gaitsmith.retarget_cmd"),
    ("identify", "gaitsmith.identify_cmd"),
    ("library", "gaitsmith.library_cmd"),
    ("drive-sim", "gaitsmith.drive_sim_cmd"),
    ("design", "gaitsmith.design_cmd"),
    ("robots", "gaitsmith.robots_cmd"),
    ("cache", "gaitsmith.cache_cmd"),
)


class _LazyCommands(Mapping[str, Any]):
    """The subcommands by name; a subcommand's module is imported when the command is looked up.

    `gaitsmith plan …` imports `gaitsmith.plan_cmd` only (the other commands' modules cost
    ≈ 0.07 s of every command's start, issue #16); `--help` looks every command up, so it lists
    them as before. A command's module that is not installed is left out, as it always was."""

    def __init__(self, settings: typer.Typer) -> None:
        self._settings = settings
        self._modules = {
            name: module for name, module in _COMMANDS if importlib.util.find_spec(module)
        }
        self._built: dict[str, Any] = {}  # click builds each command once per process

    def __getitem__(self, name: str) -> Any:
        if name not in self._built:
            module = self._modules[name]  # KeyError: not a command
            self._built[name] = _click_command(module, name, self._settings)
        return self._built[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._modules)

    def __len__(self) -> int:
        return len(self._modules)


def _click_command(module_name: str, name: str, settings: typer.Typer) -> Any:
    """The click command `name` that `module_name`'s `register` defines, built as typer builds
    the commands of a group (`typer.main.get_group_from_info`) with the app's settings."""
    holder = typer.Typer()
    importlib.import_module(module_name).register(holder)
    for info in holder.registered_commands:
        command = typer.main.get_command_from_info(
            info,
            pretty_exceptions_short=settings.pretty_exceptions_short,
            rich_markup_mode=settings.rich_markup_mode,
        )
        if command.name == name:
            return command
    for group_info in holder.registered_groups:
        group = typer.main.get_group_from_info(
            group_info,
            pretty_exceptions_short=settings.pretty_exceptions_short,
            rich_markup_mode=settings.rich_markup_mode,
            suggest_commands=settings.suggest_commands,
        )
        if group.name == name:
            return group
    raise LookupError(f"{module_name}.register does not define the command {name!r}")


class _LazyGroup(TyperGroup):
    """`gaitsmith`'s command group: its commands are `_LazyCommands`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.commands = _LazyCommands(app)  # type: ignore[assignment]  # read-only mapping


def _no_group_options() -> None:
    """(typer makes a group of an app with a callback; `gaitsmith` itself has no options)"""


defer_gl_backend()  # mujoco's EGL/OpenGL import waits until something renders (≈ 0.05 s)
# headless rendering by default, for this process and its children, as when importing every
# subcommand's module set it (`gaitsmith.simulate_cmd`, `gaitsmith.drive_sim_cmd`)
os.environ.setdefault("MUJOCO_GL", "egl")
_install_option_coercion()  # plain option values without pydantic (≈ 0.1 s per command)

app = typer.Typer(
    name="gaitsmith",
    help="Plan efficient cyclic gaits for servo-legged robots and prove them in MuJoCo.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    # help texts are plain: units like [ms] or [m/s] are not rich markup tags to be eaten
    rich_markup_mode=None,
    cls=_LazyGroup,
    callback=_no_group_options,
)


#: `gc.set_threshold` while `main` runs a command (module comment in `main`)
COMMAND_GC_THRESHOLDS = (20000, 20, 20)


def user_error_types() -> tuple[type[BaseException], ...]:
    """The error base classes whose message is meant for the user (no traceback), of the
    modules imported so far: `main` asks when an exception reaches it, and a module the command
    never imported raised nothing. (Importing `sim.errors` up front imported the `sim` package
    with MuJoCo's validation, ≈ 45 ms of every `gaitsmith plan` without --simulate:
    docs/results/planner_speed_startup.md, session 44.)"""
    errors: list[type[BaseException]] = [CliError, RobotsError]
    for module, cls in (("planner.errors", "PlannerError"), ("sim.errors", "SimError")):
        found = getattr(sys.modules.get(module), cls, None)
        if isinstance(found, type) and issubclass(found, BaseException):
            errors.append(found)
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
    # Python's cyclic GC at its default thresholds (700, 10, 10) ran ≈ 50 young and one full
    # collection between the import and the planner's build, 25–40 ms of a `gaitsmith plan`
    # (docs/results/planner_speed_startup.md, session 44); CasADi's and typer's objects are
    # hardly ever cyclic garbage. Fewer collections while the command runs, then as it was.
    thresholds = gc.get_threshold()
    gc.set_threshold(*COMMAND_GC_THRESHOLDS)
    try:
        return run_app(app, argv, user_error_types, _print_error, _print_interrupted)
    finally:
        gc.set_threshold(*thresholds)


if __name__ == "__main__":
    sys.exit(main())

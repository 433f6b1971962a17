"""`gaitsmith.cli` imports a subcommand's module only when that command is looked up; `--help`
lists every command as the eager registration did."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import typer
import typer.main

from gaitsmith import cli


def test_the_command_table_is_what_the_modules_register() -> None:
    """`_COMMANDS` names each module's command in the order typer lists a group's commands
    (commands, then `add_typer` groups, each in registration order)."""
    eager = typer.Typer()
    for _, module in cli._COMMANDS:
        importlib.import_module(module).register(eager)
    names = [info.name for info in eager.registered_commands]
    names += [info.name for info in eager.registered_groups]
    assert names == [name for name, _ in cli._COMMANDS]


def test_every_command_is_found_and_help_lists_them() -> None:
    group = typer.main.get_command(cli.app)
    assert isinstance(group, typer.core.TyperGroup)
    assert list(group.commands) == [name for name, _ in cli._COMMANDS]
    for name, _ in cli._COMMANDS:
        command = group.get_command(None, name)  # type: ignore[arg-type]
        assert command is not None and command.name == name
    assert group.get_command(None, "plon") is None  # type: ignore[arg-type]


def test_importing_the_cli_imports_no_subcommand() -> None:
    code = ("import sys, gaitsmith.cli\n"
            "print(sorted(m for m in sys.modules if m.endswith('_cmd')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "[]"


def test_help_shows_units_and_toml_sections_in_brackets() -> None:
    """Help texts are plain text (`rich_markup_mode=None`): "[ms]", "[m/s]" and "[imu]" were
    eaten as rich style tags when help was rendered as markup."""
    from typer.testing import CliRunner

    runner = CliRunner()
    cases = ((["simulate", "--help"], ("[ms]", "[imu]")), (["plan", "--help"], ("[m/s]",)))
    for argv, shown in cases:
        res = runner.invoke(cli.app, argv, env={"COLUMNS": "200"})
        assert res.exit_code == 0, res.output
        assert all(s in res.output for s in shown), res.output


def test_a_plan_without_simulate_imports_no_sim_module(tmp_path: Path) -> None:
    """The user-error classes are looked up when an error reaches `main`
    (`gaitsmith.cli.user_error_types`): a `plan` that does not simulate never imports `sim`."""
    code = ("import sys\n"
            "from gaitsmith.cli import main\n"
            f"code = main(['plan', 'quad12', '--gait', 'nosuch', '-o', "
            f"{str(tmp_path / 'g.json')!r}])\n"
            "print(code, sorted(m for m in sys.modules if m == 'sim' or m.startswith('sim.')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip().splitlines()[-1] == "2 []"
    assert out.stderr.strip().startswith("error: --gait nosuch")


def test_a_sim_error_raised_in_a_command_is_one_line_and_exit_2() -> None:
    """An error class whose module the command imported is a user error, as before."""
    from robots.cli_usage import run_app
    from sim.errors import SimConfigError

    app = typer.Typer()

    @app.command()
    def fail() -> None:
        raise SimConfigError("bad servo model")

    @app.command()
    def other() -> None:
        """(two commands: typer runs a lone one without its name)"""

    assert any(issubclass(SimConfigError, c) for c in cli.user_error_types())
    errors: list[str] = []
    assert run_app(app, ["fail"], cli.user_error_types, errors.append, lambda: None) == 2
    assert errors == ["bad servo model"]


def test_main_runs_a_command_with_fewer_gc_collections_and_restores_them() -> None:
    import gc

    before = gc.get_threshold()
    seen: list[tuple[int, ...]] = []
    app = typer.Typer()

    @app.command()
    def probe() -> None:
        seen.append(gc.get_threshold())

    @app.command()
    def other() -> None:
        """(two commands: typer runs a lone one without its name)"""

    saved = cli.app
    cli.app = app
    try:
        assert cli.main(["probe"]) == 0
    finally:
        cli.app = saved
    assert seen == [cli.COMMAND_GC_THRESHOLDS]
    assert gc.get_threshold() == before

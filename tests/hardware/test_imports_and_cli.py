"""`hardware` stays light (no casadi / mujoco) and the gaitsmith-play commands behave."""

from __future__ import annotations

import pkgutil
import subprocess
import sys
import time

import pytest
from typer.testing import CliRunner

import hardware
from hardware.bus.virtual import PtyServer, VirtualServoBus
from hardware.cli import app, main

runner = CliRunner()


def test_hardware_imports_neither_casadi_nor_mujoco() -> None:
    modules = sorted(m.name for m in pkgutil.walk_packages(hardware.__path__, prefix="hardware."))
    assert "hardware.bus.virtual.pty" in modules and "hardware.cli" in modules
    code = (
        "import sys, importlib\n"
        f"for name in {['hardware', *modules]!r}:\n"
        "    importlib.import_module(name)\n"
        "heavy = sorted(m for m in sys.modules if m.split('.')[0] in ('casadi', 'mujoco'))\n"
        "assert not heavy, heavy\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_hardware_source_never_imports_sim_or_the_planner() -> None:
    """DESIGN: hardware never imports sim, not even lazily (the twin comes by entry point)."""
    import ast
    from pathlib import Path

    offenders = []
    for path in Path(hardware.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = (
                [a.name for a in node.names] if isinstance(node, ast.Import)
                else [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            )
            bad = [n for n in names if n.split(".")[0] in ("sim", "planner")]
            offenders += [f"{path.name}: {n}" for n in bad]
    assert not offenders, offenders


def test_the_mujoco_twin_is_found_by_entry_point() -> None:
    from hardware.play.commands import _virtual_plant
    from sim.twin import MujocoTwin

    assert _virtual_plant("sim") is MujocoTwin


def test_scan_unopenable_port_is_a_clear_error() -> None:
    result = runner.invoke(app, ["scan", "--port", "/dev/does-not-exist", "--protocol", "feetech"])
    assert result.exit_code == 1
    assert "cannot open" in result.output
    assert "Traceback" not in result.output


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["run", "--bogus"], "--bogus"),
        (["run", "gait.json"], "--robot"),
        (["scan", "--protocol", "nope"], "--protocol"),
        (["nosuchcommand"], "nosuchcommand"),
    ],
)
def test_usage_errors_are_one_line_and_exit_2(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`gaitsmith-play`'s usage mistakes: one line on stderr naming the option, exit code 2 (as
    `gaitsmith`), not click's boxed usage panel."""
    assert main(argv) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert expected in lines[0] and "--help" in lines[0]


def test_scan_lists_virtual_servos_on_a_pty(make_vbus: object) -> None:
    from robots.servo import servo_model

    vbus = VirtualServoBus({i: servo_model("XL430_W250") for i in (1, 2, 7)})
    with PtyServer(vbus) as server:
        result = runner.invoke(
            app,
            [
                "scan",
                "--port",
                server.path,
                "--protocol",
                "dynamixel",
                "--ids",
                "0-8",
                "--baud",
                "1000000",
            ],
        )
    assert result.exit_code == 0, result.output
    assert "XL430_W250" in result.output and "3 servo(s) found among 9 id(s)" in result.output


def test_virtual_bus_command_serves_quad12() -> None:
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from hardware.cli import main; main()",
            "virtual-bus",
            "--robot",
            "quad12",
            "--duration",
            "20",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        path = ""
        deadline = time.monotonic() + 20
        while not path.startswith("/dev/") and time.monotonic() < deadline:
            path = proc.stdout.readline().strip()
        assert path.startswith("/dev/"), proc.stderr.read() if proc.stderr else ""
        result = runner.invoke(
            # 100 ms per ping: the emulator shares 2 cores with the rest of the suite (10 ms
            # missed a reply once at load average 3.9)
            app, ["scan", "--port", path, "--protocol", "feetech", "--ids", "1-13",
                  "--timeout-ms", "100"]
        )
        assert result.exit_code == 0, result.output
        assert "12 servo(s) found among 13 id(s)" in result.output
        assert "STS3215_7V4" in result.output
    finally:
        proc.terminate()
        proc.wait(timeout=10)
    assert proc.returncode == 0

"""`gaitsmith-play run | calibrate | plot` end to end (in-process virtual bus, CliRunner)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import robots
from hardware.cli import app
from hardware.play.calibration import Calibration
from hardware.play.telemetry import read_telemetry
from hardware.play.virtual_rig import bringup_gait
from robots.gait import save

runner = CliRunner()


@pytest.fixture
def gait_file(tmp_path: Path) -> Path:
    path = tmp_path / "bringup.json"
    save(bringup_gait(robots.load("quad12")), path)
    return path


@pytest.fixture(autouse=True)
def _calibration_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))


def _run(*args: str) -> tuple[int, str]:
    res = runner.invoke(app, list(args))
    return res.exit_code, res.output


def test_run_virtual_with_telemetry_then_plot(gait_file: Path, tmp_path: Path) -> None:
    tel = tmp_path / "tel.csv"
    code, out = _run(
        "run", str(gait_file), "--robot", "quad12", "--virtual", "--force", "--no-realtime",
        "--ramp-s", "0.5", "--telemetry", str(tel),
    )  # fmt: skip
    assert code == 0, out
    assert "stopped: completed" in out and "WARNING" in out
    t = read_telemetry(tel)
    assert t.stop_reason == "completed" and len(t.tick) > 100
    png = tmp_path / "p.png"
    code, out = _run("plot", str(tel), "-o", str(png))
    assert code == 0, out
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_run_refuses_unvalidated_gait_in_one_line(gait_file: Path) -> None:
    code, out = _run("run", str(gait_file), "--robot", "quad12", "--virtual", "--no-realtime")
    assert code == 2
    assert "gait validation" in out and "--force" in out
    assert "Traceback" not in out


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("--robot", "hex18", "--virtual"), "robot_fingerprint"),
        (("--robot", "quad12", "--virtual", "--speed-scale", "9"), "--speed-scale 9"),
        (("--robot", "quad12", "--port", "/dev/nonexistent-gaitsmith"), "cannot open"),
        (("--robot", "quad12"), "give --port"),
        (("--robot", "quad12", "--virtual", "--rate", "0"), "--rate 0: must be a finite number"),
    ],
)
def test_run_failures_are_one_clear_line(
    gait_file: Path, args: tuple[str, ...], needle: str
) -> None:
    code, out = _run("run", str(gait_file), "--force", "--no-realtime", *args)
    assert code == 2, out
    assert needle in out and "Traceback" not in out


def test_dry_run_needs_no_bus(gait_file: Path) -> None:
    code, out = _run("run", str(gait_file), "--robot", "quad12", "--dry-run", "--force")
    assert code == 0, out
    assert "dry run" in out and "stopped: completed" in out


def test_run_virtual_sim_walks_the_twin(gait_file: Path) -> None:
    code, out = _run(
        "run", str(gait_file), "--robot", "quad12", "--virtual", "sim", "--force",
        "--no-realtime", "--ramp-s", "0.5",
    )  # fmt: skip
    assert code == 0, out
    assert "twin:" in out and "simulated" in out


def test_calibrate_records_offsets_from_stdin(tmp_path: Path) -> None:
    out_path = tmp_path / "cal.json"
    res = runner.invoke(
        app, ["calibrate", "--robot", "quad12", "--virtual", "-o", str(out_path)], input="\n"
    )
    assert res.exit_code == 0, res.output
    assert "Torque is OFF" in res.output and "fl_knee" in res.output
    robot = robots.load("quad12")
    cal = Calibration.load(out_path, robot)
    # the virtual robot sits slumped off its stance: the recorded zero absorbs that offset
    nominal = Calibration.from_robot(robot)
    assert cal.joint_names == robot.joint_names
    assert any(
        a.zero_offset_ticks != b.zero_offset_ticks
        for a, b in zip(cal.joints, nominal.joints, strict=True)
    )


def test_calibrate_abort_saves_nothing(tmp_path: Path) -> None:
    out_path = tmp_path / "cal.json"
    res = runner.invoke(
        app, ["calibrate", "--robot", "quad12", "--virtual", "-o", str(out_path)], input="q\n"
    )
    assert res.exit_code == 2 and "aborted" in res.output
    assert not out_path.exists()


VIRTUAL = ("--robot", "quad12", "--virtual", "--force", "--no-realtime", "--ramp-s", "0.5")


@pytest.mark.parametrize(
    ("faults", "reason", "code"),
    [
        (("status-lost@0.8",), "status_lost", 8),
        (("overheat=5@0.8",), "over_temperature", 5),
        (("drop=0.01", "vanish=3@0.8"), "no_response", 3),
        (("sag=1.6@0.8",), "low_voltage", 6),
        (("drop=0.01", "status-lost@0.8", "overload=2@0.79"), "servo_fault", 4),
    ],
)
def test_run_virtual_with_injected_faults_stops_safely(
    gait_file: Path, tmp_path: Path, faults: tuple[str, ...], reason: str, code: int
) -> None:
    tel = tmp_path / "tel.csv"
    fault_args = [a for f in faults for a in ("--fault", f)]
    exit_code, out = _run("run", str(gait_file), *VIRTUAL, "--telemetry", str(tel), *fault_args)
    assert exit_code == code, out
    assert f"stopped: {reason}" in out and "virtual bus faults:" in out
    t = read_telemetry(tel)
    assert t.stop_reason == reason
    assert t.phase[-1] == "ramp_out"  # the rest ramp ran to its end
    stop_rows = [i for i, p in enumerate(t.phase) if p == "ramp_out"]
    assert t.t_actual_s[stop_rows[0]] >= 0.79  # nothing went wrong before the injection time


def test_run_virtual_with_a_fault_from_the_start_is_refused_by_preflight(gait_file: Path) -> None:
    code, out = _run("run", str(gait_file), *VIRTUAL, "--fault", "vanish=3")
    assert code == 2, out
    assert "pre-flight: servo 3" in out and "Traceback" not in out


def test_run_virtual_with_one_percent_drops_completes(gait_file: Path) -> None:
    code, out = _run("run", str(gait_file), *VIRTUAL, "--fault", "drop=0.01", "--fault", "delay=0")
    assert code == 0, out
    assert "stopped: completed" in out


@pytest.mark.parametrize(
    ("fault", "needle"),
    [
        ("drop=2", "drop is a probability in [0, 1], got 2"),
        ("corrupt=-0.1", "probability in [0, 1]"),
        ("nope=1", "unknown fault 'nope'"),
        ("vanish=99", "no servo 99 on this bus (ids 1-12)"),
        ("vanish=x", "servo id 'x' is not an integer"),
        ("overheat", "overheat needs a value"),
        ("drop=0.1@soon", "start time 'soon' is not a number"),
        ("drop=0.1@-1", "start time must lie in [0, 86400] s"),
        ("status-lost=3", "status-lost takes no value"),
        ("delay=inf", "delay must be finite"),
        ("", "no fault named"),
    ],
)
def test_bad_fault_values_are_one_clear_line(gait_file: Path, fault: str, needle: str) -> None:
    code, out = _run("run", str(gait_file), *VIRTUAL, "--fault", fault)
    assert code == 2, out
    assert f"--fault {fault!r}" in out and needle in out, out
    assert "accepted: drop=P" in out and "vanish=3@2.0" in out  # the accepted forms
    assert "Traceback" not in out


@pytest.mark.parametrize("where", [("--port", "/dev/nonexistent-gaitsmith"), ("--dry-run",), ()])
def test_fault_needs_the_virtual_bus(gait_file: Path, where: tuple[str, ...]) -> None:
    code, out = _run(
        "run", str(gait_file), "--robot", "quad12", "--force", *where, "--fault", "drop=0.1"
    )
    assert code == 2, out
    assert "--fault" in out and "--virtual" in out and "virtual bus only" in out
    assert "Traceback" not in out


@pytest.mark.parametrize(
    ("command", "unit"), [("run", "time [s]"), ("scan", "rate [bit/s]"), ("virtual-bus", "[s]")]
)
def test_help_shows_units_in_brackets(command: str, unit: str) -> None:
    """Help is plain text (`rich_markup_mode=None`): as rich markup "[s]" vanished (a style tag)."""
    res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0 and unit in res.output, res.output

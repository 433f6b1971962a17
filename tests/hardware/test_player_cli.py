"""`gaitsmith-play run | calibrate | plot` end to end (in-process virtual bus, CliRunner)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import robots
from hardware.calibration import Calibration
from hardware.cli import app
from hardware.telemetry import read_telemetry
from hardware.virtual_rig import bringup_gait
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
        (("--robot", "quad12", "--virtual", "--rate", "0"), "rate_hz"),
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

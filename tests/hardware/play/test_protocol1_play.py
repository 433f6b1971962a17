"""`gaitsmith-play run GAIT --robot AXROBOT --virtual` plays a gait on AX-12A servos (Protocol
1.0), and calibrate / scan / budget accept such a robot."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

import robots
from hardware.cli import app
from hardware.play.telemetry import read_telemetry
from hardware.play.virtual_rig import bringup_gait
from robots.gait import save

runner = CliRunner()
AX_REACH_DEG = 145.0  # the AX turns ±150° about its centre tick 512; 5° kept in reserve


def make_ax_robot(tmp_path: Path, servo: str = "AX_12A", source: str = "quad12") -> Path:
    """`source` copied with every joint on `servo`: zero at the AX's centre tick 512, joint
    limits narrowed to ±145° (the MJCF range may be wider than the AX's 300°)."""
    robot_dir = tmp_path / f"{source}_{servo.lower()}"
    shutil.copytree(robots.robot.BUILTIN_DIR / source, robot_dir)
    base = robots.load(source)
    text = (robot_dir / "robot.toml").read_text(encoding="utf-8")
    text = re.sub(r'servo = "[^"]+"', f'servo = "{servo}"', text)
    text = re.sub(r"zero_offset_ticks = \d+", "zero_offset_ticks = 512", text)
    text = re.sub(r"bus_baud = \d+", "bus_baud = 1000000", text)
    text = re.sub(r"(?m)^limits_deg = .*\n", "", text)
    for j in base.joints:
        lo = max(math.degrees(j.lower_rad), -AX_REACH_DEG)
        hi = min(math.degrees(j.upper_rad), AX_REACH_DEG)
        header = f"[joints.{j.name}]\n"
        limits = f"limits_deg = [{math.ceil(lo * 1e3) / 1e3}, {math.floor(hi * 1e3) / 1e3}]\n"
        text = text.replace(header, header + limits)
    (robot_dir / "robot.toml").write_text(text, encoding="utf-8")
    return robot_dir


@pytest.fixture(autouse=True)
def _calibration_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))


def test_the_ax_robot_loads_inside_the_ax_range(tmp_path: Path) -> None:
    rob = robots.load(str(make_ax_robot(tmp_path)))
    assert {j.servo.name for j in rob.joints} == {"AX_12A"} and rob.servo_protocol == "dynamixel1"
    for j in rob.joints:
        for q in (j.lower_rad, j.upper_rad, j.stance_rad):
            assert 0 <= j.angle_to_ticks(q) <= 1023, j.name


@pytest.mark.parametrize(("source", "servo"), [("quad12", "AX_12A"), ("hex18", "AX_18A")])
def test_run_virtual_plays_a_gait_on_ax_servos(tmp_path: Path, source: str, servo: str) -> None:
    robot_dir = make_ax_robot(tmp_path, servo, source)
    gait = tmp_path / "bringup.json"
    save(bringup_gait(robots.load(str(robot_dir))), gait)
    tel = tmp_path / "tel.csv"
    res = runner.invoke(
        app,
        ["run", str(gait), "--robot", str(robot_dir), "--virtual", "--force", "--no-realtime",
         "--ramp-s", "0.5", "--telemetry", str(tel)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "stopped: completed" in res.output and "missed reads 0" in res.output
    t = read_telemetry(tel)
    assert t.stop_reason == "completed" and len(t.tick) > 100
    # the servos followed: present positions track the targets within the AX's resolution
    gait_rows = [k for k, ph in enumerate(t.phase) if ph == "gait"]
    err = abs(t.present_rad[gait_rows] - t.target_rad[gait_rows])
    assert float(err.max()) < 0.15


def test_budget_of_the_ax_robot_reads_servo_by_servo(tmp_path: Path) -> None:
    robot_dir = make_ax_robot(tmp_path)
    res = runner.invoke(app, ["budget", "--robot", str(robot_dir), "--rate", "100"])
    assert res.exit_code == 0, res.output
    assert "READ × 12 (present positions)" in res.output
    assert "dominant: USB adapter latency" in res.output and "latency_timer" in res.output
    assert "beyond what this bus sustains" in res.output


def test_scan_and_virtual_bus_know_protocol_1() -> None:
    res = runner.invoke(app, ["virtual-bus", "--protocol", "dynamixel1", "--ids", "1-3",
                              "--duration", "0.2", "--wire-baud", "1000000"])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "virtual dynamixel1 bus (3 x AX_12A)" in res.output


@pytest.mark.parametrize(
    ("fault", "code", "reason"),
    [("overheat=3@1.0", 5, "over_temperature"), ("status-lost@1.0", 8, "status_lost")],
)
def test_protocol1_faults_stop_the_run_safely(
    tmp_path: Path, fault: str, code: int, reason: str
) -> None:
    robot_dir = make_ax_robot(tmp_path)
    gait = tmp_path / "bringup.json"
    save(bringup_gait(robots.load(str(robot_dir))), gait)
    res = runner.invoke(
        app,
        ["run", str(gait), "--robot", str(robot_dir), "--virtual", "--force", "--no-realtime",
         "--ramp-s", "0.5", "--cycles", "3", "--fault", fault],
    )  # fmt: skip
    assert res.exit_code == code, res.output
    assert f"stopped: {reason}" in res.output and "Traceback" not in res.output
    assert "NOT confirmed" not in res.output  # torque off confirmed by every servo

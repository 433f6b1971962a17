"""Pre-flight and enforcement agree on the speed limit at every rate; absurd options, huge gait
periods, a full telemetry disk and refused runs end in one line (or a normal stop), never in a
hang, a traceback or a stray file."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import robots
from hardware.cli import app
from hardware.play.calibration import Calibration
from hardware.play.commands import rate_warnings
from hardware.play.errors import PreflightError, SpeedScaleError
from hardware.play.player import Player, PlayerConfig
from hardware.play.preflight import gait_peak_speeds_rad_s
from hardware.play.safety_gate import SafetyGate
from hardware.play.telemetry import TelemetryWriter, read_telemetry
from hardware.play.virtual_rig import bringup_gait
from hardware.play.watchdog import StopReason
from robots.gait import save
from tests.hardware.play.player_rig import assert_wire_safe, make_rig, torque_all_off

runner = CliRunner()
RATES_HZ = (30.0, 100.0, 1000.0)
MARGIN = PlayerConfig().speed_margin


def _allowed_rad_s(robot: robots.Robot) -> np.ndarray:
    return np.array([MARGIN * j.servo.no_load_speed_rad_s for j in robot.joints])


# -- the step limit: enforced speed = allowed speed at every rate --------------------------------
@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_the_gate_enforces_the_allowed_speed_exactly_at_every_rate(rate_hz: float) -> None:
    """A target running away at 1.5 × the allowed speed: the goal follows at the allowed speed
    (to within one tick over the whole run), never faster in any window, at any rate. Flooring
    the per-tick step to whole ticks enforced only 0.72 of it at 1000 Hz (STS3215)."""
    robot = robots.load("quad12")
    cal = Calibration.from_robot(robot)
    allowed = _allowed_rad_s(robot)
    gate = SafetyGate(cal, allowed, rate_hz, None)
    start = np.asarray(robot.nominal_stance_rad, float)
    lo = np.array([j.lower_rad for j in robot.joints])
    span_s = 0.6 * float(np.min((start - lo) / allowed))  # stay inside the limits
    n = int(span_s * rate_hz)
    gate.seed(gate.rad_to_ticks_float(start).round())
    ticks = [gate.last_ticks.astype(float)]
    for k in range(1, n + 1):
        ticks.append(np.asarray(gate.command(start - 1.5 * allowed * k / rate_hz).target_ticks))
    moved = np.abs(np.array(ticks) - ticks[0])  # (n + 1, J) ticks moved since the start
    s = gate.step_ticks
    np.testing.assert_allclose(gate.enforced_speed_rad_s, allowed, rtol=1e-12)
    assert np.all(np.abs(moved[-1] - n * s) <= 1.0), (moved[-1], n * s)  # the allowed speed
    steps = np.abs(np.diff(np.array(ticks), axis=0))
    assert np.all(steps <= gate.max_step_ticks)
    csum = np.vstack([np.zeros(len(s)), np.cumsum(steps, axis=0)])
    for w in (1, 2, 3, 7, 50):  # any w consecutive steps: at most w·s + 1 ticks
        assert np.all(csum[w:] - csum[:-w] <= w * s + 1.0 + 1e-9)


@pytest.mark.parametrize("rate_hz", RATES_HZ)
@pytest.mark.parametrize("fraction", [0.98, 1.02])
def test_preflight_refuses_exactly_where_the_enforced_limit_is_below_the_gait_peak(
    tmp_path: Path, rate_hz: float, fraction: float
) -> None:
    """A gait whose peak joint speed is `fraction` of the allowed speed: accepted and played
    without drift below 1, refused (naming the joint, the scale and the rate) above it — the
    same verdict at 30, 100 and 1000 Hz, because pre-flight judges against the speed the gate
    enforces at that rate."""
    rig = make_rig(tmp_path)
    allowed = _allowed_rad_s(rig.robot)
    scale = fraction * float(np.min(allowed / gait_peak_speeds_rad_s(rig.gait)))
    cfg = PlayerConfig(rate_hz=rate_hz, cycles=2, speed_scale=scale, ramp_s=0.5, force=True)
    if fraction > 1:
        with pytest.raises(SpeedScaleError, match=f"enforced at --rate {rate_hz:g}"):
            rig.play(cfg)
        return
    result, player = rig.play(cfg)
    assert result.stop.reason is StopReason.COMPLETED
    assert_wire_safe(rig, player.gate.max_step_ticks)
    tel = rig.telemetry()
    gait_rows = np.array([p == "gait" for p in tel.phase])
    t_gait = np.arange(int(gait_rows.sum())) / rate_hz * scale
    wanted = player.gate.rad_to_ticks_float(rig.gait.joint_targets(t_gait)).round()
    drift_ticks = np.abs(tel.target_ticks[gait_rows] - wanted)
    assert drift_ticks.max() <= 2, (drift_ticks.max(), result.step_clips)  # no silent drift


# -- absurd options and gait periods --------------------------------------------------------
@pytest.fixture
def gait_file(tmp_path: Path) -> Path:
    path = tmp_path / "bringup.json"
    save(bringup_gait(robots.load("quad12")), path)
    return path


@pytest.fixture(autouse=True)
def _calibration_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))


VIRTUAL = ("--robot", "quad12", "--virtual", "--force", "--no-realtime", "--ramp-s", "0.5")


@pytest.mark.parametrize(
    ("option", "value", "needle"),
    [
        ("--timeout-ms", "inf", "--timeout-ms inf: must be a finite number in [0.1, 1000] ms"),
        ("--timeout-ms", "0", "--timeout-ms 0: must be a finite number"),
        ("--cycles", "inf", "--cycles inf: must be a finite number in [0, 1e+06]"),
        ("--cycles", "1e308", "--cycles 1e+308: must be a finite number"),
        ("--cycles", "nan", "--cycles nan: must be a finite number"),
        ("--cycles", "-1", "--cycles -1: must be a finite number"),
        ("--ramp-s", "inf", "--ramp-s inf: must be a finite number in [0.01, 60] s"),
        ("--ramp-s", "-2", "--ramp-s -2: must be a finite number"),
        ("--speed-scale", "1e-310", "--speed-scale 1e-310: must be a finite number in [0.01, 10]"),
        ("--speed-scale", "nan", "--speed-scale nan"),
        ("--rate", "nan", "--rate nan: must be a finite number in [1, 1000] Hz"),
        ("--rate", "-100", "--rate -100"),
        ("--fault", "sag=1e308", "sag must lie in [0, 50] V, got 1e+308"),
        ("--fault", "sag=nan", "sag must be finite"),
        ("--fault", "delay=1e9", "delay must lie in [0, 10] s"),
        ("--fault", "drop=0.1@1e308", "start time must lie in [0, 86400] s"),
    ],
)
def test_absurd_options_are_refused_up_front_in_one_line(
    gait_file: Path, option: str, value: str, needle: str
) -> None:
    res = runner.invoke(app, ["run", str(gait_file), *VIRTUAL, option, value])
    assert res.exit_code == 2, res.output
    assert needle in res.output, res.output
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1


@pytest.mark.parametrize("period_s", [1e3, 1e30, 1e300])
def test_a_huge_gait_period_is_refused_not_played_for_ever(tmp_path: Path, period_s: float) -> None:
    robot = robots.load("quad12")
    path = tmp_path / "slow.json"
    save(bringup_gait(robot, period_s=0.8), path)
    doc = json.loads(path.read_text())
    doc["period_s"] = period_s  # written by hand: the Gait itself refuses such a period
    path.write_text(json.dumps(doc))
    res = runner.invoke(app, ["run", str(path), *VIRTUAL])
    assert res.exit_code == 2, res.output
    out = " ".join(res.output.split())
    assert "period_s" in out and "at most 60" in out  # the gait-file loader's bound
    assert "Traceback" not in res.output


def test_a_run_longer_than_a_day_is_refused(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    with pytest.raises(PreflightError, match=r"--cycles: 200000 cycles of 0\.8 s"):
        rig.play(PlayerConfig(cycles=200_000, force=True))
    assert not rig.telemetry_path.exists()  # refused: no telemetry file


# -- telemetry: refused runs leave no file; a full disk cuts the log, not the stop ------------
def test_a_refused_run_leaves_no_telemetry_file(gait_file: Path, tmp_path: Path) -> None:
    tel = tmp_path / "tel.csv"
    res = runner.invoke(
        app, ["run", str(gait_file), "--robot", "quad12", "--virtual", "--telemetry", str(tel)]
    )  # no --force: refused by pre-flight (no sim validation)
    assert res.exit_code == 2 and "gait validation" in res.output
    assert not tel.exists()
    old = tmp_path / "old.csv"
    old.write_text("a previous run's log\n")
    res = runner.invoke(
        app, ["run", str(gait_file), "--robot", "quad12", "--virtual", "--telemetry", str(old)]
    )
    assert res.exit_code == 2 and old.read_text() == "a previous run's log\n"  # untouched


def test_disk_full_mid_run_cuts_the_log_but_not_the_stop(tmp_path: Path) -> None:
    """The telemetry file's disk fills (/dev/full: ENOSPC) after 150 rows: the run plays and
    stops exactly as without telemetry trouble (same ticks per phase, ramp to rest, torque
    off, exit code); the result says the log was cut and after how many rows."""
    reference, _ = make_rig(tmp_path / "ref").play(PlayerConfig(cycles=1, ramp_s=0.5, force=True))
    rig = make_rig(tmp_path)
    writer = TelemetryWriter(rig.telemetry_path, rig.robot.joint_names, rig.ids)

    def fill_disk(tick: int, t_s: float) -> None:
        if tick == 150:  # from now on every write of the telemetry file fails with ENOSPC
            assert writer._fh is not None
            writer._fh.close()
            writer._fh = open("/dev/full", "w", newline="", encoding="utf-8")
            writer._csv = csv.writer(writer._fh)

    player = Player(
        rig.robot, rig.gait, bus=rig.bus, clock=rig.clock, telemetry=writer, on_tick=fill_disk,
        config=PlayerConfig(cycles=1, ramp_s=0.5, force=True),
    )  # fmt: skip
    result = player.run()
    assert result.stop.reason is StopReason.COMPLETED and result.exit_code == 0
    assert dict(result.ticks_by_phase) == dict(reference.ticks_by_phase)
    assert torque_all_off(rig)
    assert result.telemetry_cut == "No space left on device after 150 row(s)"
    tel = read_telemetry(rig.telemetry_path)  # what reached the disk is a readable prefix
    assert len(tel.tick) == 150 and tel.stop_reason is None


def test_telemetry_on_a_full_disk_keeps_the_exit_code_and_says_so(gait_file: Path) -> None:
    res = runner.invoke(app, ["run", str(gait_file), *VIRTUAL, "--telemetry", "/dev/full"])
    assert res.exit_code == 0, res.output
    assert "stopped: completed" in res.output and "Traceback" not in res.output
    assert "telemetry CUT SHORT: /dev/full: No space left on device after 0 row(s)" in res.output


# -- adapter unplugged on the in-process virtual bus ------------------------------------------
def test_unplug_fault_mid_gait_stops_with_adapter_lost(gait_file: Path, tmp_path: Path) -> None:
    tel = tmp_path / "tel.csv"
    res = runner.invoke(
        app, ["run", str(gait_file), *VIRTUAL, "--telemetry", str(tel), "--fault", "unplug@0.8"]
    )
    assert res.exit_code == 9, res.output
    out = " ".join(res.output.split())  # the console wraps long lines
    assert "stopped: adapter_lost — serial adapter on 'virtual' lost" in out
    assert "[Errno 5] Input/output error" in out
    assert "torque-off NOT confirmed" in res.output and "Traceback" not in res.output
    t = read_telemetry(tel)
    assert t.stop_reason == "adapter_lost" and t.t_actual_s[-1] >= 0.79


def test_unplugged_from_the_start_is_refused_by_preflight(gait_file: Path) -> None:
    res = runner.invoke(app, ["run", str(gait_file), *VIRTUAL, "--fault", "unplug"])
    assert res.exit_code == 2, res.output
    assert "pre-flight" in res.output and "Traceback" not in res.output


# -- rates --------------------------------------------------------------------------------
def test_rate_warnings_name_the_rate_this_machine_sustains(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    result, _ = rig.play(PlayerConfig(cycles=1, ramp_s=0.5, force=True))
    assert rate_warnings(result, 100.0) == []  # virtual clock: on time
    slow = replace(result, achieved_rate_hz=811.0, overruns=7853, work_p99_s=0.0021)
    (w,) = rate_warnings(slow, 1000.0)
    assert "held 811.0 Hz of the 1000 Hz asked" in w and "7853 of" in w
    assert "sustains about --rate 330" in w
    assert math.isclose(0.7 / 0.0021, 333.3, rel_tol=1e-3)


def test_a_rate_above_the_sustained_one_is_warned_before_the_run(gait_file: Path) -> None:
    res = runner.invoke(app, ["run", str(gait_file), *VIRTUAL, "--rate", "1000"])
    assert res.exit_code == 0, res.output
    assert "WARNING: --rate 1000 is above the" in res.output

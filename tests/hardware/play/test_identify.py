"""`gaitsmith-play identify`: the excitation stays inside the limits, is recorded, stops safely."""

from __future__ import annotations

import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import robots
from hardware.bus.servo_bus import BusConfig
from hardware.bus.virtual.bus import VirtualServoBus
from hardware.cli import app
from hardware.play.clock import VirtualClock
from hardware.play.errors import PlayerError
from hardware.play.identify import (
    CHECK_PHASE,
    LIMIT_MARGIN_RAD,
    TRAIN_PHASE,
    IdentifyPlayer,
    excitation_for,
    joint_groups,
)
from hardware.play.player import PlayerConfig
from hardware.play.telemetry import TelemetryWriter, read_telemetry
from hardware.play.virtual_rig import virtual_robot_bus
from hardware.play.watchdog import StopReason
from robots.robot import Robot
from tests.hardware.player_process import EXIT_FOR_SIGNAL, REASON_FOR_SIGNAL, PlayerProcess, env
from tests.zoo.fixtures import ZOO

runner = CliRunner()


@pytest.fixture(scope="module")
def spot() -> Robot:
    return robots.load(str(ZOO / "spotmicro"))


@pytest.fixture(autouse=True)
def _calibration_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))


def test_groups_take_the_kth_joint_of_every_leg(spot: Robot) -> None:
    groups = joint_groups(spot)
    names = [[spot.joint_names[j] for j in g] for g in groups]
    assert len(groups) == 3 and all(len(g) == 4 for g in groups)
    assert all(n.endswith("hip_roll") for n in names[0])
    assert all(n.endswith("knee") for n in names[2])
    assert [spot.joint_names[j] for g in joint_groups(spot, ("fl_knee",)) for j in g] == ["fl_knee"]
    with pytest.raises(PlayerError, match="no joint 'elbow'"):
        joint_groups(spot, ("elbow",))


def test_excitation_stays_inside_limits_and_under_the_speed_cap(spot: Robot) -> None:
    cap = np.array([0.9 * j.servo.no_load_speed_rad_s for j in spot.joints])
    ex = excitation_for(spot, cap, amplitude_rad=math.radians(40.0), segment_s=4.0)
    t = np.arange(0.0, ex.duration_s, 0.01)
    q = np.array([ex.targets(x) for x in t])
    lo = np.array([j.lower_rad for j in spot.joints]) + LIMIT_MARGIN_RAD
    hi = np.array([j.upper_rad for j in spot.joints]) - LIMIT_MARGIN_RAD
    assert np.all(q >= lo - 1e-9) and np.all(q <= hi + 1e-9)
    # every joint moved, in its own group's window only
    moved = np.ptp(q, axis=0)
    assert np.all(moved > math.radians(5.0))
    # the smooth parts (chirp, multisine) respect half the cap; the steps are the gate's job
    smooth = np.array([ex.phase(x).startswith(TRAIN_PHASE) for x in t])
    speed = np.abs(np.diff(q, axis=0)) / 0.01
    jumps = speed > 2 * cap  # step edges
    assert np.all((speed <= 0.5 * cap * 1.05) | jumps | ~smooth[1:, None])
    phases = {ex.phase(x) for x in t}
    assert {f"{TRAIN_PHASE}0", f"{CHECK_PHASE}0", f"{TRAIN_PHASE}2", f"{CHECK_PHASE}2"} <= phases


def test_bad_options_are_one_line_refusals(spot: Robot) -> None:
    cap = np.ones(spot.dof)
    with pytest.raises(PlayerError, match=r"--amplitude-deg 0\.1"):
        excitation_for(spot, cap, amplitude_rad=math.radians(0.1))
    with pytest.raises(PlayerError, match="--duration-s 1"):
        excitation_for(spot, cap, segment_s=1.0)


def _player(
    robot: Robot, tel: Path, **kwargs: object
) -> tuple[IdentifyPlayer, TelemetryWriter, VirtualServoBus]:
    clock = VirtualClock()
    vbus = virtual_robot_bus(robot, clock=clock.now_s)
    bus = vbus.connect(BusConfig(timeout_s=0.002))
    writer = TelemetryWriter(tel, robot.joint_names, [j.bus_id for j in robot.joints])
    player = IdentifyPlayer(
        robot, bus=bus, config=PlayerConfig(ramp_s=0.5), clock=clock, telemetry=writer,
        **kwargs,  # type: ignore[arg-type]
    )  # fmt: skip
    return player, writer, vbus


def test_run_records_goal_present_and_phases_then_torque_off(spot: Robot, tmp_path: Path) -> None:
    player, writer, vbus = _player(spot, tmp_path / "ident.csv", segment_s=2.0)
    result = player.run()
    writer.close()
    assert result.stop.reason is StopReason.COMPLETED
    assert result.limit_clips == 0
    tel = read_telemetry(tmp_path / "ident.csv")
    assert tel.stop_reason == "completed"
    for g in range(3):
        assert f"{TRAIN_PHASE}{g}" in tel.phase and f"{CHECK_PHASE}{g}" in tel.phase
    assert tel.phase[-1] == "ramp_out"
    assert np.all(np.isfinite(tel.present_rad[10:]))
    assert np.any(np.isfinite(tel.load_pct))  # status ticks carry the load
    assert not any(s.torque_enabled for s in vbus.servos)


def test_a_stop_mid_excitation_ramps_to_stance_and_turns_torque_off(
    spot: Robot, tmp_path: Path
) -> None:
    player, writer, _ = _player(spot, tmp_path / "ident.csv", segment_s=2.0)

    def stop_at(tick: int, t_s: float) -> None:
        if tick == 150:
            player.request_stop(StopReason.SIGINT, "test: Ctrl-C")

    player.on_tick = stop_at
    result = player.run()
    writer.close()
    assert result.stop.reason is StopReason.SIGINT
    tel = read_telemetry(tmp_path / "ident.csv")
    assert tel.phase[-1] == "ramp_out"
    stance = np.asarray(spot.nominal_stance_rad)
    assert np.max(np.abs(tel.target_rad[-1] - stance)) < 2e-3  # one tick
    assert result.exit_code == StopReason.SIGINT.exit_code


def test_cli_asks_unless_yes_and_records_on_the_virtual_bus(tmp_path: Path) -> None:
    out = tmp_path / "ident.csv"
    args = ["identify", "--robot", str(ZOO / "spotmicro"), "--virtual", "--no-realtime",
            "-o", str(out), "--duration-s", "2", "--joints", "fl_knee,fr_knee"]  # fmt: skip
    res = runner.invoke(app, args, input="n\n")
    assert res.exit_code == 2 and "LIFTED" in res.output and "not confirmed" in res.output
    assert not out.exists()
    res = runner.invoke(app, [*args, "--yes"])
    assert res.exit_code == 0, res.output
    tel = read_telemetry(out)
    assert {p for p in tel.phase if p.startswith(TRAIN_PHASE)} == {f"{TRAIN_PHASE}0"}
    knees = [tel.joint_names.index(n) for n in ("fl_knee", "fr_knee")]
    others = [j for j in range(len(tel.joint_names)) if j not in knees]
    excited = np.array([p.startswith((TRAIN_PHASE, CHECK_PHASE)) for p in tel.phase])
    assert np.all(np.ptp(tel.target_rad[excited][:, knees], axis=0) > 0.1)
    assert np.all(np.ptp(tel.target_rad[excited][:, others], axis=0) < 1e-9)
    assert "gaitsmith identify" in res.output


def test_cli_refuses_twin_settings_without_the_twin(tmp_path: Path) -> None:
    res = runner.invoke(
        app,
        ["identify", "--robot", "quad12", "--virtual", "-o", str(tmp_path / "x.csv"), "--yes",
         "--twin-servo-params", str(tmp_path / "p.toml")],
    )  # fmt: skip
    assert res.exit_code == 2 and "--virtual sim" in res.output
    res = runner.invoke(
        app, ["identify", "--robot", "quad12", "--virtual", "-o", str(tmp_path / "x.csv"),
              "--yes", "--joints", "fl_elbow"],
    )  # fmt: skip
    assert res.exit_code == 2 and "no joint 'fl_elbow'" in res.output
    res = runner.invoke(app, ["identify", "--robot", "quad12", "-o", str(tmp_path / "x.csv")])
    assert res.exit_code == 2 and "give --port DEVICE" in res.output
    assert not (tmp_path / "x.csv").exists()


class _IdentifyProcess(PlayerProcess):
    """`gaitsmith-play identify --port <pty>` in a subprocess against a virtual quad12."""

    def start(self) -> _IdentifyProcess:
        path = self.server.start()
        cmd = [
            sys.executable, "-m", "hardware.cli", "identify", "--robot", "quad12", "--yes",
            "--port", path, "-o", str(self.tel_path), "--ramp-s", "0.5", "--timeout-ms", "50",
            *self.args,
        ]  # fmt: skip
        self.proc = subprocess.Popen(
            cmd,
            env={**env(), "GAITSMITH_CALIBRATION_DIR": str(self.tmp_path / "cal")},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        return self


@pytest.mark.parametrize("signum", (signal.SIGINT, signal.SIGTERM), ids=("SIGINT", "SIGTERM"))
def test_a_signal_mid_excitation_stops_safely_on_a_real_port(tmp_path: Path, signum: int) -> None:
    p = _IdentifyProcess(tmp_path).start()
    assert p.wait_phase(f"{TRAIN_PHASE}0"), p.finish().stderr
    time.sleep(0.3)
    assert p.signal(signum)
    o = p.finish()
    assert "Traceback" not in o.stderr, o.stderr[-2000:]
    assert o.torqued == [], o.stderr[-2000:]
    assert o.code == EXIT_FOR_SIGNAL[signum], (o.code, o.stderr[-2000:])
    assert o.telemetry is not None and o.telemetry.stop_reason == REASON_FOR_SIGNAL[signum]
    assert o.telemetry.phase[-1] == "ramp_out"

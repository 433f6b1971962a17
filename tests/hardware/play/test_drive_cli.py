"""`gaitsmith-play drive` on the command line: option checks (one line, exit 2, nothing moved),
a scripted drive on the in-process virtual bus, and signals mid-drive in a subprocess on a
virtual bus served on a pseudo-terminal (the servos outlive the player: "no servo left torqued"
is read from their registers after the process ended)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

import robots
from hardware.bus.virtual import PtyServer
from hardware.cli import app
from hardware.play.telemetry import read_telemetry
from hardware.play.virtual_rig import virtual_robot_bus
from robots.library import save
from tests.hardware.play.drive_rig import repeated, script_lines
from tests.hardware.player_process import env, last_phase
from tests.robots.library_fixture import make_library

runner = CliRunner()
VIRTUAL = ("--robot", "quad12", "--virtual", "--no-realtime", "--ramp-s", "0.5")


@pytest.fixture(scope="module")
def library_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("lib") / "quad12_lib.json"
    save(make_library(robots.load("quad12")), path)
    return path


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--deadman-s", "0"], "--deadman-s 0: must be a finite number in [0.02, 60] s"),
        (["--deadman-s", "nan"], "--deadman-s nan: must be a finite number"),
        (["--accel", "-1"], "--accel -1: must be a finite number in [0.01, 20]"),
        (["--yaw-accel", "inf"], "--yaw-accel inf: must be"),
        (["--max-drive-s", "-3"], "--max-drive-s -3: must be"),
        (["--rate", "5000"], "--rate 5000: must be a finite number in [1, 1000] Hz"),
        (["--input", "joystick"], "--input 'joystick': accepted: keyboard, gamepad"),
        (["--input", "socket:"], "--input 'socket:': accepted:"),
    ],
)
def test_bad_options_are_one_line_refusals(
    library_file: Path, extra: list[str], message: str
) -> None:
    res = runner.invoke(app, ["drive", str(library_file), *VIRTUAL, "--input", "stdin", *extra])
    assert res.exit_code == 2, res.output
    assert message in " ".join(res.output.split()), res.output
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) <= 3


def test_no_port_no_virtual_and_faults_on_real_ports_are_refused(library_file: Path) -> None:
    res = runner.invoke(app, ["drive", str(library_file), "--robot", "quad12", "--input", "stdin"])
    assert res.exit_code == 2 and "give --port DEVICE or --virtual" in res.output
    res = runner.invoke(app, ["drive", str(library_file), "--robot", "quad12", "--input",
                              "stdin", "--port", "/dev/null", "--fault", "drop=0.1"])  # fmt: skip
    assert res.exit_code == 2 and "virtual bus only" in res.output


def test_a_library_of_another_robot_or_a_bad_file_is_refused(
    library_file: Path, tmp_path: Path
) -> None:
    other = tmp_path / "hex18_lib.json"
    save(make_library(robots.load("hex18")), other)
    res = runner.invoke(app, ["drive", str(other), *VIRTUAL, "--input", "stdin"])
    assert res.exit_code == 2 and str(other) in " ".join(res.output.split()), res.output
    assert "Traceback" not in res.output
    bad = tmp_path / "bad.json"
    bad.write_text('{"schema": "gaitsmith.library/1"')
    res = runner.invoke(app, ["drive", str(bad), *VIRTUAL, "--input", "stdin"])
    assert res.exit_code == 2 and "bad.json" in res.output and "Traceback" not in res.output
    res = runner.invoke(app, ["drive", str(tmp_path / "none.json"), *VIRTUAL, "--input", "stdin"])
    assert res.exit_code == 2 and "none.json" in res.output


def _cli(*args: str, stdin: bytes) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hardware.cli", "drive", *args],
        input=stdin.decode(), capture_output=True, text=True, env=env(), timeout=120,
    )  # fmt: skip


def test_a_scripted_drive_on_stdin_completes_and_logs_the_commands(
    library_file: Path, tmp_path: Path
) -> None:
    tel = tmp_path / "tel.csv"
    cmds = [*repeated(0.0, 1.5, 0.2, vx=0.1, yaw_rate=0.5), {"t": 1.5, "end": True}]
    out = _cli(str(library_file), *VIRTUAL, "--telemetry", str(tel),
               stdin=script_lines(cmds) + b"garbage\n")  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "stopped: completed — stdin ended; standing" in out.stdout
    assert "from stdin: 9 command(s), 1 malformed" in " ".join(out.stdout.split())
    t = read_telemetry(tel)
    assert t.stop_reason == "completed"
    assert max(t.extra["applied_yaw_rate_rad_s"]) == pytest.approx(0.5)
    assert {"ramp_in", "drive", "ramp_out"} <= set(t.phase)


class DriveProcess:
    """`gaitsmith-play drive --port <pty> --input stdin` against a virtual quad12 served here;
    the test writes commands to its stdin like a companion program."""

    def __init__(self, tmp_path: Path, library: Path) -> None:
        robot = robots.load("quad12")
        self.vbus = virtual_robot_bus(robot)
        self.server = PtyServer(self.vbus)
        self.tel = tmp_path / "tel.csv"
        self.library = library
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self) -> DriveProcess:
        port = self.server.start()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "hardware.cli", "drive", str(self.library), "--robot",
             "quad12", "--port", port, "--input", "stdin", "--ramp-s", "0.5", "--timeout-ms",
             "50", "--deadman-s", "2", "--telemetry", str(self.tel)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            env={**env(), "GAITSMITH_CALIBRATION_DIR": str(self.tel.parent / "cal")},
            start_new_session=True,
        )  # fmt: skip
        return self

    def send(self, line: bytes) -> None:
        assert self.proc is not None and self.proc.stdin is not None
        self.proc.stdin.write(line)
        self.proc.stdin.flush()

    def wait_phase(self, phase: str, timeout_s: float = 30.0) -> bool:
        end = time.monotonic() + timeout_s
        assert self.proc is not None
        while time.monotonic() < end and self.proc.poll() is None:
            if last_phase(self.tel) == phase:
                return True
            self.send(b'{"vx": 0.15, "yaw_rate": 0.3}\n')
            time.sleep(0.05)
        return False

    def finish(self) -> tuple[int, str, list[int]]:
        assert self.proc is not None
        try:
            out, err = self.proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, err = self.proc.communicate()
        time.sleep(0.05)
        self.server.stop()
        torqued = [s.servo_id for s in self.vbus.servos if s.torque_enabled]
        return self.proc.returncode, (out + err).decode(errors="replace"), torqued


@pytest.mark.slow
@pytest.mark.parametrize(
    "signum, code, reason, storm",
    [
        (signal.SIGINT, 130, "sigint", 1),
        (signal.SIGTERM, 143, "sigterm", 1),
        (signal.SIGINT, 130, "sigint", 200),
    ],
    ids=["sigint", "sigterm", "sigint-storm"],
)
def test_signals_mid_drive_end_in_the_run_safe_stop(
    library_file: Path, tmp_path: Path, signum: int, code: int, reason: str, storm: int
) -> None:
    p = DriveProcess(tmp_path, library_file).start()
    assert p.wait_phase("drive"), p.finish()[1][-2000:]
    time.sleep(0.3)
    assert p.proc is not None
    for _ in range(storm):
        if p.proc.poll() is not None:
            break
        p.proc.send_signal(signum)
        time.sleep(0.002)
    rc, text, torqued = p.finish()
    assert "Traceback" not in text, text[-2000:]
    assert rc == code, (rc, text[-2000:])
    assert torqued == []
    t = read_telemetry(p.tel)
    assert t.stop_reason == reason
    assert "drive" in t.phase
    if storm == 1:  # the ramp to rest ran; in a storm the second signal cuts it short
        assert t.phase[-1] == "ramp_out"
    assert f"stopped: {reason}" in text


def _keyboard_drive(library: Path, tmp_path: Path) -> tuple[subprocess.Popen[bytes], int, int]:
    """`drive` with a pseudo-terminal as stdin (so --input defaults to the keyboard)."""
    import os

    master, slave = os.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "hardware.cli", "drive", str(library), "--robot", "quad12",
         "--virtual", "--ramp-s", "0.5", "--deadman-s", "2", "--telemetry",
         str(tmp_path / "tel.csv")],
        stdin=slave, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env(),
        start_new_session=True,
    )  # fmt: skip
    return proc, master, slave


@pytest.mark.slow
@pytest.mark.parametrize("how", ["x-key", "sigint"])
def test_keyboard_drive_restores_the_terminal_on_every_exit(
    library_file: Path, tmp_path: Path, how: str
) -> None:
    import os
    import termios

    proc, master, slave = _keyboard_drive(library_file, tmp_path)
    before = termios.tcgetattr(slave)
    tel = tmp_path / "tel.csv"
    end = time.monotonic() + 30
    while time.monotonic() < end and last_phase(tel) not in ("drive", "stand"):
        time.sleep(0.05)
    assert termios.tcgetattr(slave) != before  # cbreak while driving
    for _ in range(10):  # hold "w": walk
        os.write(master, b"w")
        time.sleep(0.1)
    if how == "x-key":
        os.write(master, b"x")
    else:
        proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    text = (out + err).decode(errors="replace")
    after = termios.tcgetattr(slave)
    os.close(master)
    os.close(slave)
    assert "Traceback" not in text, text[-2000:]
    assert after == before, "terminal left in cbreak mode"
    assert proc.returncode == (0 if how == "x-key" else 130), text[-2000:]
    t = read_telemetry(tel)
    assert max(t.extra["requested_vx_m_s"]) > 0 and "drive" in t.phase
    assert "keys: arrows or W/S" in text and "command vx" in text


@pytest.mark.slow
def test_a_companion_program_drives_through_a_unix_socket(
    library_file: Path, tmp_path: Path
) -> None:
    import socket as socketlib

    sock_path = tmp_path / "drive.sock"
    tel = tmp_path / "tel.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "hardware.cli", "drive", str(library_file), "--robot", "quad12",
         "--virtual", "--ramp-s", "0.5", "--input", f"socket:{sock_path}", "--telemetry",
         str(tel)],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env(),
    )  # fmt: skip
    end = time.monotonic() + 30
    while time.monotonic() < end and not sock_path.exists() and proc.poll() is None:
        time.sleep(0.05)
    client = socketlib.socket(socketlib.AF_UNIX, socketlib.SOCK_STREAM)
    client.connect(str(sock_path))
    while time.monotonic() < end and last_phase(tel) not in ("drive", "stand"):
        time.sleep(0.05)
    for _ in range(15):
        client.sendall(b'{"vx": 0.1, "yaw_rate": -0.3}\n')
        time.sleep(0.1)
    client.sendall(b'{"vx": oops}\n{"end": true}\n')
    out, err = proc.communicate(timeout=60)
    client.close()
    text = " ".join((out + err).decode(errors="replace").split())
    assert proc.returncode == 0, text[-2000:]
    assert f"socket:{sock_path} ended; standing" in text
    assert "16 command(s), 1 malformed" in text
    assert not sock_path.exists()  # removed on exit
    t = read_telemetry(tel)
    assert min(t.extra["applied_yaw_rate_rad_s"]) == pytest.approx(-0.3)

"""Helpers (no tests here): the real `gaitsmith-play run` CLI in a subprocess, playing on a
virtual bus served on a pseudo-terminal by *this* process.

The servos outlive the player: if the player dies with torque on, the virtual servos' Torque
Enable registers still say 1 afterwards, exactly as real servos would. The player sees a serial
device (`--port /dev/pts/N`); closing the pty's master makes its reads and writes fail with
EIO, like a USB adapter pulled out.
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import robots
from hardware.telemetry import Telemetry, read_telemetry
from hardware.virtual import PtyServer, VirtualServoBus
from hardware.virtual_rig import bringup_gait, virtual_robot_bus
from robots.gait import save

ROOT = Path(__file__).resolve().parents[2]
BASE_ARGS = ("--robot", "quad12", "--force", "--ramp-s", "0.5", "--timeout-ms", "50")
STORM_N = 300
STORM_GAP_S = 0.002


def env() -> dict[str, str]:
    e = dict(os.environ)
    e["PYTHONPATH"] = os.pathsep.join([str(ROOT), e.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    e.setdefault("COLUMNS", "200")
    return e


def gait_file(tmp_path: Path) -> Path:
    path = tmp_path / "bringup.json"
    if not path.exists():
        save(bringup_gait(robots.load("quad12")), path)
    return path


def last_phase(path: Path) -> str | None:
    """The phase of the last complete telemetry row written so far (None: no row yet)."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    lines = text.splitlines(keepends=True)
    complete = [ln for ln in lines if ln.endswith("\n")][1:]
    if not complete:
        return None
    row = next(csv.reader([complete[-1]]))
    return row[1] if len(row) > 1 else None


@dataclass
class Outcome:
    """How a subprocess run ended, judged from outside."""

    code: int
    stdout: str
    stderr: str
    torqued: list[int]  # virtual servos with Torque Enable still 1
    telemetry: Telemetry | None
    signals_sent: int = 0
    first_signal_s: float = float("nan")  # monotonic time of the first signal sent
    exited_s: float = float("nan")  # monotonic time the process was seen gone
    extra: dict[str, float] = field(default_factory=dict)


class PlayerProcess:
    """`gaitsmith-play run --port <pty>` against a virtual quad12 served here."""

    def __init__(self, tmp_path: Path, *args: str) -> None:
        self.tmp_path = tmp_path
        self.robot = robots.load("quad12")
        self.vbus: VirtualServoBus = virtual_robot_bus(self.robot)
        self.server = PtyServer(self.vbus)
        self.tel_path = tmp_path / "tel.csv"
        self.args = args
        self.proc: subprocess.Popen[str] | None = None
        self.signals_sent = 0
        self.first_signal_s = float("nan")

    def start(self) -> PlayerProcess:
        path = self.server.start()
        cmd = [
            sys.executable, "-m", "hardware.cli", "run", str(gait_file(self.tmp_path)),
            *BASE_ARGS, "--port", path, "--telemetry", str(self.tel_path), *self.args,
        ]  # fmt: skip
        cal = self.tmp_path / "cal"
        self.proc = subprocess.Popen(
            cmd,
            env={**env(), "GAITSMITH_CALIBRATION_DIR": str(cal)},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,  # signals from the test reach the player only
        )
        return self

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def wait_for(self, test: Callable[[], bool], timeout_s: float = 15.0) -> bool:
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and self.alive():
            if test():
                return True
            time.sleep(0.005)
        return False

    def catches(self, signum: int) -> bool:
        """Whether the process has a handler for `signum` (Linux: /proc/PID/status SigCgt)."""
        assert self.proc is not None
        try:
            status = Path(f"/proc/{self.proc.pid}/status").read_text()
        except OSError:
            return False
        for line in status.splitlines():
            if line.startswith("SigCgt:"):
                return bool(int(line.split()[1], 16) >> (signum - 1) & 1)
        return False

    def wait_phase(self, phase: str, timeout_s: float = 15.0) -> bool:
        return self.wait_for(lambda: last_phase(self.tel_path) == phase, timeout_s)

    def signal(self, signum: int) -> bool:
        assert self.proc is not None
        if self.proc.poll() is not None:
            return False
        try:
            os.kill(self.proc.pid, signum)
        except ProcessLookupError:
            return False
        if not self.signals_sent:
            self.first_signal_s = time.monotonic()
        self.signals_sent += 1
        return True

    def storm(self, signum: int, n: int = STORM_N, gap_s: float = STORM_GAP_S) -> int:
        """Up to `n` signals `gap_s` apart (stops when the process is gone); returns how many."""
        sent = 0
        for _ in range(n):
            if not self.signal(signum):
                break
            sent += 1
            time.sleep(gap_s)
        return sent

    def finish(self, timeout_s: float = 30.0) -> Outcome:
        assert self.proc is not None
        try:
            out, err = self.proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, err = self.proc.communicate()
            err += "\n[test] player did not exit in time: killed"
        exited = time.monotonic()
        time.sleep(0.05)  # let the pty thread hand the last bytes to the servos
        self.server.stop()
        torqued = [s.servo_id for s in self.vbus.servos if s.torque_enabled]
        tel = read_telemetry(self.tel_path) if self.tel_path.exists() else None
        return Outcome(
            self.proc.returncode, out, err, torqued, tel, self.signals_sent,
            self.first_signal_s, exited,
        )  # fmt: skip


EXIT_FOR_SIGNAL: dict[int, int] = {
    signal.SIGINT: 130,
    signal.SIGTERM: 143,
    signal.SIGHUP: 129,
    signal.SIGQUIT: 131,
}
REASON_FOR_SIGNAL: dict[int, str] = {
    signal.SIGINT: "sigint",
    signal.SIGTERM: "sigterm",
    signal.SIGHUP: "sighup",
    signal.SIGQUIT: "sigquit",
}

"""`gaitsmith-play run --imu PORT`: a WitMotion stream on a pseudo-terminal feeds the player on
the virtual bus (the closed-loop gait plays without --force); a bad, silent or slow port is
refused in one line naming --imu before any servo moves."""

from __future__ import annotations

import os
import threading
import time
import tty
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from hardware.cli import app as play_app
from hardware.imu.witmotion import angle_frame
from hardware.play.telemetry import read_telemetry
from robots.attitude import ATTITUDE_GAIN_KEY
from robots.gait import load as load_gait
from robots.gait import save as save_gait

FIXTURE = Path(__file__).parents[2] / "sim" / "fixtures" / "biped_walk_0222.json"


class PtyImu:
    """A WitMotion IMU on a pseudo-terminal: angle frames (body tilted 2 deg in roll, IMU X
    axis pointing right) plus an acceleration frame and a garbage byte, at `rate_hz`."""

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.sent = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        accel = bytes([0x55, 0x51, 0x10, 0x00, 0x20, 0x00, 0, 0, 0, 0, 0xD6])
        while not self._stop.is_set():
            if self.rate_hz:
                try:  # the body rolls 2 deg right-side down: on an X-right IMU that is pitch
                    os.write(self.master, b"\x00" + accel + angle_frame(0.0, 2.0, 30.0))
                    self.sent += 1
                except OSError:
                    return
            time.sleep(1.0 / self.rate_hz if self.rate_hz else 0.01)

    def __enter__(self) -> PtyImu:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        os.close(self.master)
        os.close(self.slave)


@pytest.fixture
def closed_loop_gait(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))
    path = tmp_path / "walk.json"
    save_gait(load_gait(FIXTURE).with_validation(
        {"passed": True, "conditions": {ATTITUDE_GAIN_KEY: 0.5}}), path)
    yield path


def _common(path: Path) -> list[str]:
    return ["run", str(path), "--robot", "biped", "--virtual", "--ramp-s", "0.3",
            "--cycles", "1"]


def test_imu_feeds_the_player_on_the_virtual_bus(closed_loop_gait: Path, tmp_path: Path
                                                 ) -> None:
    tel = tmp_path / "tel.csv"
    with PtyImu(100.0) as imu:
        res = CliRunner().invoke(play_app, [*_common(closed_loop_gait), "--imu", imu.path,
                                            "--imu-baud", "115200", "--imu-mount", "yaw=-90",
                                            "--telemetry", str(tel)])
    assert res.exit_code == 0, res.output
    assert f"attitude feedback: gain 0.5 from the IMU on {imu.path}" in res.output
    line = next(s for s in res.output.splitlines() if s.startswith("imu "))
    frames = int(line.split(":")[1].split()[0])
    assert frames > 100 and "port lost" not in line, line
    assert "1 bad checksums" not in line  # the stray 0x00 bytes are skipped, not frames
    # the same run open loop (--force): the IMU's tilt changed the streamed targets
    open_tel = tmp_path / "open.csv"
    res = CliRunner().invoke(play_app, [*_common(closed_loop_gait), "--force", "--no-realtime",
                                        "--telemetry", str(open_tel)])
    assert res.exit_code == 0, res.output
    # compare tick by scheduled time (a loaded real-time run skips late ticks): the body's 2 deg
    # roll moves the stance legs by ~0.02-0.03 rad at G 0.5 (robots.attitude's map)
    closed, open_loop = read_telemetry(tel), read_telemetry(open_tel)
    rows_o = {round(t * 100): k for k, (t, ph) in
              enumerate(zip(open_loop.t_sched_s, open_loop.phase, strict=True)) if ph == "gait"}
    pairs = [(k, rows_o[round(t * 100)]) for k, (t, ph) in
             enumerate(zip(closed.t_sched_s, closed.phase, strict=True))
             if ph == "gait" and round(t * 100) in rows_o]
    assert len(pairs) > 30
    diff = np.array([closed.target_rad[a] - open_loop.target_rad[b] for a, b in pairs])
    p75 = float(np.percentile(np.abs(diff).max(axis=1), 75))
    print(f"closed - open loop, per tick max |target diff| p75 {p75:.4f} rad")
    assert p75 > 0.02  # the stance legs move by 0.02-0.03 rad; a flickering IMU: ~0.013


@pytest.mark.parametrize(("rate_hz", "match"), [(0.0, "no WitMotion angle frames"),
                                                (10.0, "the player needs at least 40 Hz")])
def test_silent_or_slow_imu_is_refused_in_one_line(closed_loop_gait: Path, rate_hz: float,
                                                   match: str) -> None:
    with PtyImu(rate_hz) as imu:
        res = CliRunner().invoke(play_app, [*_common(closed_loop_gait), "--imu", imu.path])
    assert res.exit_code == 2, res.output
    err = [s for s in res.output.splitlines() if s.strip()]
    assert len(err) == 1 and err[0].startswith(f"error: --imu {imu.path}: ") and match in err[0]


def test_bad_port_and_options_are_refused_in_one_line(closed_loop_gait: Path) -> None:
    common = _common(closed_loop_gait)
    cases = [
        (["--imu", "/dev/nonexistent-imu"], "error: --imu /dev/nonexistent-imu: cannot open"),
        (["--imu", "/dev/null", "--imu-baud", "1234"], "not a WitMotion rate"),
        (["--imu", "/dev/null", "--imu-mount", "pitch=3"], "error: --imu-mount:"),
        (["--attitude-gain", "0.5"], "pass --imu PORT"),
    ]
    for extra, match in cases:
        res = CliRunner().invoke(play_app, [*common, *extra])
        lines = [s for s in res.output.splitlines() if s.strip()]
        assert res.exit_code == 2 and len(lines) == 1 and match in lines[0], res.output
    res = CliRunner().invoke(play_app, [*common[:-4], "--virtual", "sim", "--imu", "/dev/null"])
    assert res.exit_code == 2 and "--imu: --virtual sim" in res.output, res.output


def test_imu_with_an_open_loop_gait_says_feedback_is_off(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))
    path = tmp_path / "open.json"
    save_gait(load_gait(FIXTURE).with_validation({"passed": True, "conditions": {}}), path)
    with PtyImu(100.0) as imu:
        res = CliRunner().invoke(play_app, [*_common(path), "--dry-run", "--imu", imu.path])
    assert res.exit_code == 0, res.output
    assert "attitude feedback: off (gain 0" in res.output, res.output

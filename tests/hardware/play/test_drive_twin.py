"""A scripted command stream drives hex18 along a square through the MuJoCo twin.

`fixtures/square.jsonl`: 4 × (straight at vx 0.1 m/s for 4 s, turn in place at 0.5 rad/s for
3.2 s), each line repeated every 0.2 s (a companion feeding a 0.5 s deadman), then the end.
`fixtures/hex18_square_lib.json`: a small library built with
`gaitsmith library hex18 --vx 0,0.1 --yaw-rate 0,0.5 --knots 20 --cycles 8 --workers 1`
(4 tripod entries, each validated in MuJoCo, and the stand; 229 s). The player streams to the
twin through the byte-level virtual bus (`--virtual sim`'s path, in-process, on a virtual
clock); the corners are measured from the twin's base track: the base position over each turn
in place.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import robots
from hardware.bus.servo_bus import BusConfig
from hardware.play.clock import VirtualClock
from hardware.play.command_sources import StreamSource
from hardware.play.drive import DriveConfig, Driver, drive_from_library
from hardware.play.player import PlayerConfig
from hardware.play.watchdog import StopReason
from robots.library import load

FIXTURES = Path(__file__).parent / "fixtures"
SQUARE = FIXTURES / "square.jsonl"
LIBRARY = FIXTURES / "hex18_square_lib.json"
SIDE_M = 0.4  # 4 s at 0.1 m/s


@dataclass(frozen=True)
class Track:
    """Per drive tick: base position (x, y, z) [m], heading [rad, unwrapped], applied command."""

    xyz: np.ndarray  # (K, 3)
    yaw: np.ndarray  # (K,)
    vx: np.ndarray  # (K,)
    yaw_rate: np.ndarray  # (K,)


@dataclass(frozen=True)
class Square:
    start: np.ndarray  # (2,) base position when the drive began [m]
    corners: np.ndarray  # (4, 2) base position over each turn in place [m]
    turns_deg: np.ndarray  # (4,) heading change over each turn
    sides_m: np.ndarray  # (4,) start→c1, c1→c2, c2→c3, c3→c4
    min_height_m: float

    def describe(self) -> str:
        pts = ", ".join(f"({x:+.3f}, {y:+.3f})" for x, y in self.corners)
        return (
            f"start ({self.start[0]:+.3f}, {self.start[1]:+.3f}) m; corners {pts} m; sides "
            f"{', '.join(f'{s:.3f}' for s in self.sides_m)} m; turns "
            f"{', '.join(f'{a:.1f}' for a in self.turns_deg)}°; last corner "
            f"{np.linalg.norm(self.corners[-1] - self.start):.3f} m from the start; lowest "
            f"base {self.min_height_m:.3f} m"
        )


def _segments(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index runs where `mask` holds."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def measure_square(track: Track) -> Square:
    turning = (np.abs(track.yaw_rate) > 0.25) & (np.abs(track.vx) < 0.02)
    turns = [s for s in _segments(turning) if s[1] - s[0] > 50]
    assert len(turns) == 4, turns
    corners = np.array([track.xyz[a:b, :2].mean(axis=0) for a, b in turns])
    turned = np.degrees([track.yaw[b - 1] - track.yaw[a] for a, b in turns])
    start = track.xyz[0, :2]
    pts = np.vstack([start, corners])
    sides = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    return Square(start, corners, turned, sides, float(track.xyz[:, 2].min()))


def drive_square(telemetry: Path | None = None) -> tuple[Square, Driver, float]:
    from sim.twin import MujocoTwin  # the test wires the twin, as the entry point does

    robot = robots.load("hex18")
    library = load(LIBRARY, robot)
    clock = VirtualClock()
    twin = MujocoTwin(robot, clock=clock.now_s)
    bus = twin.vbus.connect(BusConfig(timeout_s=0.001, retries=1))
    rows: list[tuple[float, ...]] = []
    fd = os.open(SQUARE, os.O_RDONLY)
    driver: Driver | None = None

    def on_tick(tick: int, t_s: float) -> None:
        b = driver.blender if driver is not None else None
        if b is None:
            return
        c = b.command
        rows.append((*twin.base_position_m, twin.history[-1].yaw_rad, c.vx_m_s, c.yaw_rate_rad_s))

    driver = drive_from_library(
        robot, library, StreamSource(fd, "square.jsonl"), bus=bus,
        config=PlayerConfig(cycles=None, ramp_s=1.0), drive=DriveConfig(deadman_s=0.5),
        clock=clock, on_tick=on_tick,
    )  # fmt: skip
    result = driver.drive_run()
    assert result.play.stop.reason is StopReason.COMPLETED, result.play.stop
    assert result.malformed == 0 and result.deadman_trips == 0
    a = np.array(rows)
    track = Track(a[:, :3], np.unwrap(a[:, 3]), a[:, 4], a[:, 5])
    return measure_square(track), driver, result.walking_s


@pytest.mark.slow
def test_a_scripted_square_on_the_twin() -> None:
    square, driver, walking_s = drive_square()
    print(f"[square] {square.describe()}; walking {walking_s:.1f} s")
    height0 = robots.load("hex18").stance_base_height_m
    assert square.min_height_m > 0.6 * height0  # no fall
    assert np.all((square.turns_deg > 60) & (square.turns_deg < 120)), square.describe()
    assert np.all(np.abs(square.sides_m - SIDE_M) < 0.5 * SIDE_M), square.describe()
    # four left turns of about 90°: the corners go round, and the last is back near the start
    assert abs(np.sum(square.turns_deg) - 360.0) < 90.0
    assert np.linalg.norm(square.corners[-1] - square.start) < 0.5 * SIDE_M
    assert driver.gate.commands > 0 and not math.isnan(square.sides_m.sum())


@pytest.mark.slow
def test_drive_virtual_sim_on_the_command_line_turns_the_twin(tmp_path: Path) -> None:
    """`gaitsmith-play drive --virtual sim`: the twin comes by entry point, not by import."""
    import re
    import subprocess
    import sys

    from tests.hardware.play.drive_rig import repeated, script_lines
    from tests.hardware.player_process import env

    cmds = [*repeated(0.0, 3.0, 0.2, yaw_rate=0.5), {"t": 3.0, "end": True}]
    out = subprocess.run(
        [sys.executable, "-m", "hardware.cli", "drive", str(LIBRARY), "--robot", "hex18",
         "--virtual", "sim", "--no-realtime", "--input", "stdin", "--ramp-s", "0.5"],
        input=script_lines(cmds).decode(), capture_output=True, text=True, env=env(),
        timeout=300,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr[-2000:]
    text = " ".join(out.stdout.split())
    turned = re.search(r"turned ([+-][0-9.]+)°", text)
    assert turned is not None, text
    assert 45.0 < float(turned.group(1)) < 120.0, text  # 0.5 rad/s for 3 s = 86° (+ ramps)

"""Shared helpers of the drive tests (no tests here): a scripted command source, the synthetic
gait library on a virtual rig, and running a `Driver` on it."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from hardware.play.command_sources import StreamSource
from hardware.play.drive import DriveConfig, Driver, DriveResult, drive_from_library
from hardware.play.player import PlayerConfig
from hardware.play.telemetry import TelemetryWriter
from robots.library import GaitLibrary
from tests.hardware.play.player_rig import Rig, make_rig
from tests.robots.library_fixture import make_library

DRIVE_CONFIG = PlayerConfig(cycles=None, ramp_s=0.5)
TELEMETRY_EXTRA = (
    "requested_vx_m_s", "requested_vy_m_s", "requested_yaw_rate_rad_s",
    "applied_vx_m_s", "applied_vy_m_s", "applied_yaw_rate_rad_s",
    "gait_phase", "malformed_lines",
)  # fmt: skip


def script_lines(commands: Sequence[dict[str, Any]]) -> bytes:
    return b"".join(json.dumps(c).encode() + b"\n" for c in commands)


def script_source(data: bytes, keep_open: bool = False) -> tuple[StreamSource, int | None]:
    """JSON lines on a pipe, as if on stdin: closed after writing (EOF ends the input), or
    `keep_open` (a companion that goes quiet; returns the writer's fd to close afterwards)."""
    r, w = os.pipe()
    os.set_blocking(w, True)
    os.write(w, data)
    if keep_open:
        return StreamSource(r, "script"), w
    os.close(w)
    return StreamSource(r, "script"), None


def repeated(
    t0_s: float, t1_s: float, every_s: float, **command: float
) -> list[dict[str, Any]]:
    """The same command every `every_s` from t0 to t1 (a companion keeping the deadman fed)."""
    n = max(1, round((t1_s - t0_s) / every_s))
    return [{"t": round(t0_s + i * every_s, 6), **command} for i in range(n)]


def drive_rig(tmp_path: Path, robot_name: str = "quad12") -> tuple[Rig, GaitLibrary]:
    rig = make_rig(tmp_path, robot_name)
    return rig, make_library(rig.robot)


def run_drive(
    rig: Rig,
    library: GaitLibrary,
    data: bytes,
    *,
    config: PlayerConfig = DRIVE_CONFIG,
    drive: DriveConfig | None = None,
    on_tick: Callable[[int, float], None] | None = None,
    keep_open: bool = False,
) -> tuple[DriveResult, Driver]:
    writer = TelemetryWriter(rig.telemetry_path, rig.robot.joint_names, rig.ids, TELEMETRY_EXTRA)
    source, still_open = script_source(data, keep_open)
    driver = drive_from_library(
        rig.robot, library, source, bus=rig.bus, config=config,
        drive=drive or DriveConfig(), clock=rig.clock, telemetry=writer, on_tick=on_tick,
    )  # fmt: skip
    try:
        return driver.drive_run(), driver
    finally:
        writer.close()
        if still_open is not None:
            os.close(still_open)

"""Telemetry CSV: streamed rows, stop row, read back, plot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hardware.bus.servo_bus import ServoStatus
from hardware.play.telemetry import (
    TelemetryWriter,
    TickRecord,
    columns,
    plot_telemetry,
    read_telemetry,
)

NAMES = ("a_hip", "a_knee")
IDS = (1, 2)


def _record(k: int, present: bool = True, status: bool = False) -> TickRecord:
    st = {i: ServoStatus(i, 12.5, 7.4, 31.0, (), 0) for i in IDS} if status else None
    return TickRecord(
        tick=k, phase="gait", t_sched_s=k * 0.01, t_actual_s=k * 0.01 + 1e-4, loop_s=5e-4,
        overrun=k == 3, target_rad=np.array([0.1 * k, -1.0]), target_ticks=(2048 + k, 1396),
        present_rad=np.array([0.1 * k - 0.01, -0.99]) if present else None, status=st,
    )  # fmt: skip


def test_rows_are_flushed_as_they_are_written(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    w = TelemetryWriter(path, NAMES, IDS)
    w.write(_record(0))
    w.write(_record(1))
    # readable mid-run (a crash keeps everything up to the last tick)
    lines = path.read_text().splitlines()
    assert len(lines) == 3 and lines[0].split(",") == columns(NAMES)
    w.finish("sigint", "Ctrl-C (SIGINT) received: stopping safely", 2, 0.02)
    assert w.finished


def test_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    w = TelemetryWriter(path, NAMES, IDS)
    for k in range(5):
        w.write(_record(k, present=k != 2, status=k % 2 == 0))
    w.finish("no_response", "servo 2 (a_knee): 4 consecutive missed reads", 5, 0.05)
    tel = read_telemetry(path)
    assert tel.joint_names == NAMES
    assert list(tel.tick) == [0, 1, 2, 3, 4]
    np.testing.assert_allclose(tel.target_rad[:, 0], 0.1 * np.arange(5))
    assert np.isnan(tel.present_rad[2]).all() and not np.isnan(tel.present_rad[3]).any()
    np.testing.assert_allclose(tel.jitter_s, 1e-4)
    assert list(tel.overrun) == [False, False, False, True, False]
    assert tel.stop_reason == "no_response" and "a_knee" in (tel.stop_message or "")


def test_not_a_telemetry_file(tmp_path: Path) -> None:
    bad = tmp_path / "x.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a gaitsmith telemetry file"):
        read_telemetry(bad)


def test_plot_writes_a_png(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    w = TelemetryWriter(path, NAMES, IDS)
    for k in range(20):
        w.write(_record(k))
    w.finish("completed", "played 1 cycle(s)", 20, 0.2)
    out = plot_telemetry(read_telemetry(path), tmp_path / "p.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_no_file_until_the_first_row_and_none_for_a_run_that_never_wrote(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    w = TelemetryWriter(path, NAMES, IDS)
    assert not path.exists()  # a run refused by pre-flight leaves nothing behind
    w.close()
    assert not path.exists()
    w = TelemetryWriter(path, NAMES, IDS)
    w.finish("sigterm", "SIGTERM received: stopping safely", 0, 0.0, -0.3)
    tel = read_telemetry(path)  # stopped before the first tick: header + stop row
    assert len(tel.tick) == 0 and tel.stop_reason == "sigterm" and tel.stop_requested_s == -0.3


def test_stop_row_holds_request_and_done_times(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    w = TelemetryWriter(path, NAMES, IDS)
    w.write(_record(0))
    w.finish("sigint", "Ctrl-C (SIGINT) received: stopping safely", 1, 0.75, 0.25)
    tel = read_telemetry(path)
    assert tel.stop_requested_s == 0.25 and tel.stop_done_s == 0.75


def test_a_full_disk_cuts_the_log_without_raising(tmp_path: Path) -> None:
    w = TelemetryWriter("/dev/full", NAMES, IDS)
    for k in range(3):
        w.write(_record(k))  # ENOSPC at the first flush: recorded, not raised
    w.finish("completed", "played 1 cycle(s)", 3, 0.03, 0.02)
    assert w.cut == "No space left on device after 0 row(s)" and not w.finished


def test_an_unwritable_place_fails_up_front(tmp_path: Path) -> None:
    with pytest.raises(IsADirectoryError):
        TelemetryWriter(tmp_path, NAMES, IDS)

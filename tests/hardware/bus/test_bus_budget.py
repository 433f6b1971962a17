"""`hardware.bus.budget` and `gaitsmith-play budget`: the packet model against what the drivers
really send, the virtual bus's wire-time emulation, and the budget against a player run on it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from typer.testing import CliRunner

import robots
from hardware.bus import budget as bus_budget
from hardware.bus.protocol import dynamixel2 as dxl
from hardware.bus.protocol import feetech as ft
from hardware.bus.servo_bus import BusConfig
from hardware.bus.virtual import VirtualPort, VirtualServoBus, WireTiming
from hardware.cli import app
from hardware.play.clock import MonotonicClock
from hardware.play.player import Player, PlayerConfig
from hardware.play.virtual_rig import bringup_gait, virtual_robot_bus
from robots.gait import save
from robots.servo import servo_model
from tests.hardware.conftest import ManualClock

runner = CliRunner()
AX = servo_model("AX_12A")
MODELS = {
    "ax": AX,
    "mx": replace(AX, name="MX_28_P1", model_number=29),
    "dynamixel2": servo_model("XL430_W250"),
    "feetech_sts": servo_model("STS3215_7V4"),
}


def test_packet_sizes_by_hand() -> None:
    ids = list(range(1, 13))
    # Feetech: FF FF FE LEN 83 addr len (id + 2 bytes) × 12 CHK = 7 + 36 + 1; SYNC READ 8 + 12
    ex = bus_budget.exchanges_for("feetech_sts", ids, [777] * 12)
    assert (ex[0].request_bytes, ex[1].request_bytes, ex[1].reply_bytes) == (44, 20, (8,) * 12)
    # Protocol 2.0: header 4, id, len 2, inst, addr 2, len 2, (id + 4) × 12, CRC 2 = 74
    ex = bus_budget.exchanges_for("dynamixel2", ids, [1060] * 12)
    assert ex[0].request_bytes == 74 and ex[1].request_bytes == 14 + 12
    assert ex[1].reply_bytes == (11 + 4,) * 12
    # Protocol 1.0 AX: one 8-byte READ and one 8-byte status per servo
    ex = bus_budget.exchanges_for("dynamixel1", ids, [12] * 12)
    assert (ex[1].request_bytes, ex[1].reply_bytes, ex[1].per_tick) == (8, (8,), 12.0)
    # MX: one BULK READ, 7 + 3 per servo
    ex = bus_budget.exchanges_for("dynamixel1", ids, [29] * 12)
    assert (ex[1].request_bytes, ex[1].reply_bytes, ex[1].per_tick) == (43, (8,) * 12, 1.0)


@pytest.mark.parametrize("kind", sorted(MODELS))
def test_the_budget_counts_the_bytes_the_driver_sends(kind: str) -> None:
    """A status tick's traffic, as the budget models it, equals the bytes on the port."""
    model = MODELS[kind]
    ids = list(range(1, 9))
    vbus = VirtualServoBus({i: model for i in ids}, clock=ManualClock())
    port = VirtualPort(vbus)
    bus = type(vbus.connect())(port, BusConfig(timeout_s=0.02))
    bus.open()
    for i in ids:
        bus.ping(i)  # the Protocol 1.0 driver learns the models (bulk read or not)
    budget = bus_budget.compute(model.protocol, ids, [model.model_number] * 8, 1_000_000)
    out0, in0, n0 = port.bytes_written, port.bytes_read, vbus.instructions
    bus.sync_write_positions({i: vbus.servo(i).goal_tick for i in ids})
    bus.sync_read_positions(ids)
    bus.read_status(ids)
    every = budget.status_every_ticks
    weights = [e.per_tick * (every if e.on_status_ticks_only else 1) for e in budget.exchanges]
    out = sum(w * e.request_bytes for w, e in zip(weights, budget.exchanges, strict=True))
    back = sum(w * sum(e.reply_bytes) for w, e in zip(weights, budget.exchanges, strict=True))
    assert (port.bytes_written - out0, port.bytes_read - in0) == (out, back)
    assert vbus.instructions - n0 == round(sum(weights))


def test_wire_timing_releases_replies_when_a_real_line_would() -> None:
    vbus = VirtualServoBus({1: MODELS["dynamixel2"], 2: MODELS["dynamixel2"]}, clock=ManualClock())
    vbus.wire = WireTiming(57_600, adapter_latency_s=0.016)
    request = dxl.sync_read(132, 4, [1, 2])
    replies = vbus.process(request, 10.0)
    byte_s, delay_s = 10 / 57_600, 500e-6  # X-series factory Return Delay Time
    first = 10.0 + len(request) * byte_s + delay_s + 15 * byte_s
    second = first + delay_s + 15 * byte_s
    assert [round(t, 9) for t, _ in replies] == [round(first + 0.016, 9), round(second + 0.016, 9)]
    # the next request waits for the line: a sync write sent "at once" is on it after the replies
    later = vbus.process(dxl.ping(1), 10.0)
    assert later[0][0] > second + 0.016 - 1e-9
    # Feetech STS: return delay 0, no latency
    fvbus = VirtualServoBus({3: MODELS["feetech_sts"]}, clock=ManualClock())
    fvbus.wire = WireTiming(1_000_000)
    ((t, reply),) = fvbus.process(ft.ping(3), 0.0)
    assert t == pytest.approx((6 + len(reply)) * 10e-6)


def test_dominant_term_and_advice() -> None:
    hex18 = robots.load("hex18")
    b = bus_budget.for_robot(hex18)  # FTDI default latency 16 ms
    assert b.dominant == "USB adapter latency" and "latency_timer" in b.advice()
    ax12 = bus_budget.compute("dynamixel1", list(range(1, 13)), [12] * 12, 1_000_000,
                              latency_ms=1.0)  # fmt: skip
    assert ax12.dominant == "USB adapter latency" and "lower it" not in ax12.advice()
    assert "one READ each" in ax12.advice()
    b = bus_budget.for_robot(hex18, latency_ms=0)
    assert b.dominant == "return delay" and "Return Delay" in b.advice()
    b = bus_budget.for_robot(hex18, latency_ms=0, return_delay_us=0, baud=57_600)
    assert b.dominant == "wire time" and "baud" in b.advice()
    assert b.overrun_free_rate_hz < b.mean_rate_hz
    assert bus_budget.rate_check(b, 0.5 * b.overrun_free_rate_hz) is None
    assert "overrun" in (
        bus_budget.rate_check(b, 0.5 * (b.mean_rate_hz + b.overrun_free_rate_hz)) or ""
    )
    assert "beyond" in (bus_budget.rate_check(b, 2 * b.mean_rate_hz) or "")


def test_budget_cli_reports_terms_and_checks_a_rate() -> None:
    res = runner.invoke(app, ["budget", "--robot", "quad12", "--latency-ms", "1", "--rate", "100"])
    assert res.exit_code == 0, res.output
    assert "12 × feetech_sts servos at 1000000 bit/s" in res.output
    assert "SYNC READ present positions: 20 B out, 12 × 8 B back" in res.output
    assert "--rate 100: within the bus budget" in res.output
    assert "mean tick [ms]: wire time" in res.output  # not eaten as console markup
    res = runner.invoke(app, ["budget", "--robot", "quad12", "--return-delay-us", "900"])
    assert res.exit_code == 2 and "return delay" in res.output and "Traceback" not in res.output
    res = runner.invoke(app, ["budget", "--robot", "quad12", "--baud", "5"])
    assert res.exit_code == 2 and "--baud 5" in res.output


def test_player_on_the_wire_timed_virtual_bus_holds_the_budget_rate() -> None:
    """Real time: quad12 asked 100 Hz behind an emulated 16 ms FTDI adapter plays at the
    budget's rate (benchmarks/bus_budget_check.py measures quad12 and hex18 longer)."""
    robot = robots.load("quad12")
    budget = bus_budget.for_robot(robot, latency_ms=16.0)
    gait = bringup_gait(robot, period_s=0.8)
    clock = MonotonicClock()
    vbus = virtual_robot_bus(robot, clock=clock.now_s)
    vbus.wire = WireTiming(robot.bus_baud, 0.016)
    bus = vbus.connect(BusConfig(timeout_s=0.003))
    cfg = PlayerConfig(rate_hz=100.0, cycles=2, ramp_s=0.5, force=True)
    result = Player(robot, gait, bus=bus, config=cfg, clock=clock).run()
    assert result.stop.reason.value == "completed" and result.misses == 0
    ratio = result.achieved_rate_hz / budget.mean_rate_hz
    assert 0.85 <= ratio <= 1.03, (result.achieved_rate_hz, budget.mean_rate_hz)


def test_run_on_a_real_port_warns_before_anything_opens_when_the_rate_is_beyond_the_bus(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hardware.bus.sdk_bus

    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))
    monkeypatch.setattr(hardware.bus.sdk_bus, "usb_latency_timer_s", lambda device: 0.016)
    gait = tmp_path / "bringup.json"
    save(bringup_gait(robots.load("quad12")), gait)
    args = ["run", str(gait), "--robot", "quad12", "--port", str(tmp_path / "no-such-tty")]
    res = runner.invoke(app, [*args, "--force", "--rate", "100"])
    assert "beyond what this bus sustains: about 52 Hz" in res.output
    assert "USB adapter latency dominates" in res.output and "latency_timer" in res.output
    assert res.exit_code == 2 and "cannot open" in res.output  # a warning, not the refusal
    res = runner.invoke(app, [*args, "--force", "--rate", "20"])
    assert "beyond" not in res.output and "overrun" not in res.output


def test_the_pty_server_honours_wire_timing() -> None:
    """On the pty too, a sync read takes the wire time the budget gives it (57.6 kbit/s,
    X-series factory return delay)."""
    import time

    from hardware.bus.dynamixel import DynamixelBus
    from hardware.bus.virtual import PtyServer

    ids = list(range(1, 7))
    vbus = VirtualServoBus({i: MODELS["dynamixel2"] for i in ids})
    vbus.wire = WireTiming(57_600)
    budget = bus_budget.compute("dynamixel2", ids, [1060] * 6, 57_600, latency_ms=0.0)
    read = budget.exchanges[1]
    expected_s = (read.request_bytes + sum(read.reply_bytes)) * 10 / 57_600 + 6 * 500e-6
    with PtyServer(vbus) as server:
        with DynamixelBus(server.path, BusConfig(timeout_s=0.02, baudrate=57_600)) as bus:
            bus.sync_read_positions(ids)
            t0 = time.monotonic()
            for _ in range(5):
                bus.sync_read_positions(ids)
            took_s = (time.monotonic() - t0) / 5
    assert expected_s <= took_s < 1.3 * expected_s + 0.002, (took_s, expected_s)

"""The unmodified `dynamixel_sdk` Protocol 1.0 PacketHandler against the virtual bus: on a pty
(the SDK's own PortHandler on the device path) and in-process; and `Dynamixel1Bus` on the pty."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from typing import Any

import dynamixel_sdk as sdk
import pytest

from hardware.bus.dynamixel import Dynamixel1Bus
from hardware.bus.servo_bus import BusConfig
from hardware.bus.virtual import PtyServer, VirtualPort, VirtualServoBus
from robots.servo import servo_model
from tests.hardware.conftest import ManualClock

AX = servo_model("AX_12A")
MX28 = replace(AX, name="MX_28_P1", model_number=29)
IDS = list(range(1, 9))


def _wait_for(cond: Callable[[], bool], timeout_s: float = 2.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not cond():
        assert time.monotonic() < deadline, "condition not met in time"
        time.sleep(0.001)


def _pty_port(vbus: VirtualServoBus) -> Iterator[Any]:
    with PtyServer(vbus) as server:
        port = sdk.PortHandler(server.path)
        assert port.openPort() and port.setBaudRate(1_000_000)
        yield port
        port.closePort()


def _inproc_port(vbus: VirtualServoBus) -> Iterator[Any]:
    port = VirtualPort(vbus)
    assert port.openPort()
    yield port


@pytest.fixture(params=["pty", "in-process"])
def transport(request: pytest.FixtureRequest) -> Callable[..., Iterator[Any]]:
    if request.param == "pty":  # a thread-served pty: see tests.hardware.conftest
        request.getfixturevalue("patient_sdk_timeouts")
        return _pty_port
    return _inproc_port


def test_sdk_protocol1_ping_read_write_sync_write(transport: Any) -> None:
    clock = ManualClock()
    vbus = VirtualServoBus({i: AX for i in IDS}, clock=clock)
    for port in transport(vbus):
        ph = sdk.PacketHandler(1.0)
        assert ph.ping(port, 3) == (12, sdk.COMM_SUCCESS, 0)  # ping reads the model number
        assert ph.ping(port, 40)[1] == sdk.COMM_RX_TIMEOUT
        assert ph.read2ByteTxRx(port, 2, 0) == (12, sdk.COMM_SUCCESS, 0)
        assert ph.read1ByteTxRx(port, 2, 43) == (30, sdk.COMM_SUCCESS, 0)  # temperature
        for i in IDS:
            assert ph.write1ByteTxRx(port, i, 24, 1) == (sdk.COMM_SUCCESS, 0)  # torque on
        writer = sdk.GroupSyncWrite(port, ph, 30, 2)
        for i in IDS:
            assert writer.addParam(i, [(300 + 7 * i) & 0xFF, (300 + 7 * i) >> 8])
        assert writer.txPacket() == sdk.COMM_SUCCESS
        _wait_for(lambda: vbus.servo(8).goal_tick == 356)  # pty: served by a thread
        clock.advance(5.0)
        for i in IDS:
            assert ph.read2ByteTxRx(port, i, 36) == (300 + 7 * i, sdk.COMM_SUCCESS, 0)
        # a goal beyond the CCW angle limit: clamped, answered with the angle-limit bit
        assert ph.write2ByteTxRx(port, 1, 8, 600) == (sdk.COMM_SUCCESS, 0)
        assert ph.write2ByteTxRx(port, 1, 30, 900) == (sdk.COMM_SUCCESS, 0x02)
        assert "Angle" in ph.getRxPacketError(0x02)


def test_sdk_protocol1_bulk_read_on_mx(transport: Any) -> None:
    clock = ManualClock()
    vbus = VirtualServoBus({i: MX28 for i in IDS}, clock=clock)
    for port in transport(vbus):
        ph = sdk.PacketHandler(1.0)
        reader = sdk.GroupBulkRead(port, ph)
        for i in IDS:
            assert reader.addParam(i, 36, 2) if i % 2 else reader.addParam(i, 42, 2)
        # GroupBulkRead.txPacket passes Protocol 1.0's bulkReadTx one argument too many in
        # dynamixel-sdk 4.1.0 (TypeError); send its parameters through the packet handler directly
        reader.makeParam()
        assert ph.bulkReadTx(port, reader.param, 3 * len(IDS)) == sdk.COMM_SUCCESS
        assert reader.rxPacket() == sdk.COMM_SUCCESS
        mid = (AX.position_min_tick + AX.position_max_tick + 1) // 2
        for i in IDS:
            if i % 2:
                assert reader.getData(i, 36, 2) == mid
            else:
                assert reader.getData(i, 42, 1) == 120 and reader.getData(i, 43, 1) == 30


def test_dynamixel1_bus_on_the_pty() -> None:
    vbus = VirtualServoBus({i: AX for i in IDS})
    with PtyServer(vbus) as server:
        bus = Dynamixel1Bus(server.path, BusConfig(timeout_s=0.02, baudrate=1_000_000))
        with bus:
            assert [s.servo_id for s in bus.scan(range(1, 10))] == IDS
            bus.torque_on(IDS)
            bus.sync_write_positions({i: 400 + i for i in IDS})
            _wait_for(lambda: vbus.servo(8).goal_tick == 408)
            _wait_for(lambda: bus.sync_read_positions(IDS) == {i: 400 + i for i in IDS})
            assert bus.read_status(IDS)[5].voltage_v == 12.0

"""The unmodified vendor SDKs talk to the virtual bus: on a pty (their own PortHandler on the
device path) and in-process (VirtualPort)."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from typing import Any

import dynamixel_sdk as dxl_sdk
import pytest
import scservo_sdk as ft_sdk

from hardware.bus.virtual import PtyServer, VirtualPort, VirtualServoBus
from tests.hardware.conftest import IDS, ManualClock


def _wait_for(cond: Callable[[], bool], timeout_s: float = 2.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not cond():
        assert time.monotonic() < deadline, "condition not met in time"
        time.sleep(0.001)


def _pty_port(vbus: VirtualServoBus, sdk: Any) -> Iterator[Any]:
    with PtyServer(vbus) as server:
        port = sdk.PortHandler(server.path)  # the SDK's own serial PortHandler
        assert port.openPort()
        assert port.setBaudRate(1_000_000)
        yield port
        port.closePort()


def _inproc_port(vbus: VirtualServoBus, sdk: Any) -> Iterator[Any]:
    port = VirtualPort(vbus)
    assert port.openPort()
    yield port


@pytest.fixture(params=["pty", "in-process"])
def transport(request: pytest.FixtureRequest) -> Callable[..., Iterator[Any]]:
    if request.param == "pty":  # a thread-served pty: see tests.hardware.conftest
        request.getfixturevalue("patient_sdk_timeouts")
        return _pty_port
    return _inproc_port


def test_dynamixel_sdk(make_vbus: Any, clock: ManualClock, transport: Any) -> None:
    vbus = make_vbus("dynamixel2")
    for port in transport(vbus, dxl_sdk):
        ph = dxl_sdk.PacketHandler(2.0)
        model, result, error = ph.ping(port, 3)
        assert (model, result, error) == (1060, dxl_sdk.COMM_SUCCESS, 0)
        _, result, _ = ph.ping(port, 40)
        assert result == dxl_sdk.COMM_RX_TIMEOUT
        value, result, error = ph.read2ByteTxRx(port, 1, 0)
        assert (value, result, error) == (1060, dxl_sdk.COMM_SUCCESS, 0)
        for i in IDS:
            assert ph.write1ByteTxRx(port, i, 64, 1) == (dxl_sdk.COMM_SUCCESS, 0)
        writer = dxl_sdk.GroupSyncWrite(port, ph, 116, 4)
        for i in IDS:
            assert writer.addParam(i, list((1000 + 10 * i).to_bytes(4, "little")))
        assert writer.txPacket() == dxl_sdk.COMM_SUCCESS
        _wait_for(lambda: vbus.servo(5).get("goal_position") == 1050)  # pty: served by a thread
        clock.advance(5.0)  # long enough to arrive at the no-load speed
        reader = dxl_sdk.GroupSyncRead(port, ph, 132, 4)
        for i in IDS:
            assert reader.addParam(i)
        assert reader.txRxPacket() == dxl_sdk.COMM_SUCCESS
        assert {i: reader.getData(i, 132, 4) for i in IDS} == {i: 1000 + 10 * i for i in IDS}
        pos, result, _ = ph.read4ByteTxRx(port, 7, 132)
        assert (pos, result) == (1070, dxl_sdk.COMM_SUCCESS)
        found, result = ph.broadcastPing(port)
        assert result == dxl_sdk.COMM_SUCCESS and sorted(found) == IDS


def test_feetech_sdk(make_vbus: Any, clock: ManualClock, transport: Any) -> None:
    vbus = make_vbus("feetech_sts")
    for port in transport(vbus, ft_sdk):
        ph = ft_sdk.PacketHandler(0)
        model, result, error = ph.ping(port, 3)
        assert (model, result, error) == (777, ft_sdk.COMM_SUCCESS, 0)
        _, result, _ = ph.ping(port, 40)
        assert result == ft_sdk.COMM_RX_TIMEOUT
        for i in IDS:
            assert ph.write1ByteTxRx(port, i, 40, 1) == (ft_sdk.COMM_SUCCESS, 0)
        writer = ft_sdk.GroupSyncWrite(port, ph, 42, 2)
        for i in IDS:
            assert writer.addParam(i, [ft_sdk.SCS_LOBYTE(900 + i), ft_sdk.SCS_HIBYTE(900 + i)])
        assert writer.txPacket() == ft_sdk.COMM_SUCCESS
        _wait_for(lambda: vbus.servo(12).get("goal_position") == 912)
        clock.advance(5.0)
        reader = ft_sdk.GroupSyncRead(port, ph, 56, 2)
        for i in IDS:
            assert reader.addParam(i)
        assert reader.txRxPacket() == ft_sdk.COMM_SUCCESS
        assert {i: reader.getData(i, 56, 2) for i in IDS} == {i: 900 + i for i in IDS}
        pos, result, _ = ph.read2ByteTxRx(port, 12, 56)
        assert (pos, result) == (912, ft_sdk.COMM_SUCCESS)
        volts, result, _ = ph.read1ByteTxRx(port, 1, 62)
        assert (volts, result) == (74, ft_sdk.COMM_SUCCESS)  # 7.4 V in 0.1 V

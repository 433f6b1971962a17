"""DynamixelBus / FeetechBus over the in-process virtual bus: normal operation, every injected
fault raises its typed error, and no call blocks longer than its configured timeout budget."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest

from hardware.bus.dynamixel import DynamixelBus
from hardware.bus.feetech import FeetechBus
from hardware.bus.servo_bus import BusConfig, ServoBus
from hardware.bus.virtual import FaultPlan, VirtualServoBus
from hardware.errors import CorruptPacket, NoResponse, ServoFault
from tests.hardware.conftest import IDS, ManualClock

TIMEOUT_S = 0.010
SLACK_S = 0.050  # scheduler / Python overhead allowance on a loaded CI machine
FLAGS = {
    "dynamixel2": {"overload": "overload", "overheat": "overheating", "voltage": "input_voltage"},
    "feetech_sts": {"overload": "overload", "overheat": "overheat", "voltage": "voltage"},
}


@pytest.fixture(params=["dynamixel2", "feetech_sts"])
def protocol(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def _connect(vbus: VirtualServoBus, retries: int = 0) -> ServoBus:
    return vbus.connect(BusConfig(timeout_s=TIMEOUT_S, retries=retries))


def _timed(fn: Callable[[], Any]) -> tuple[BaseException | None, float]:
    t0 = time.perf_counter()
    try:
        fn()
    except BaseException as exc:
        return exc, time.perf_counter() - t0
    return None, time.perf_counter() - t0


def test_driver_round_trip(make_vbus: Any, clock: ManualClock, protocol: str) -> None:
    vbus = make_vbus(protocol)
    with _connect(vbus) as bus:
        assert isinstance(bus, DynamixelBus if protocol == "dynamixel2" else FeetechBus)
        found = bus.scan(range(0, 15))
        assert [f.servo_id for f in found] == IDS
        assert {f.model_number for f in found} == {1060 if protocol == "dynamixel2" else 777}
        assert bus.sync_read_positions(IDS) == {i: 2048 for i in IDS}
        bus.torque_on(IDS)
        bus.sync_write_positions({i: 2048 + 40 * i for i in IDS})
        clock.advance(0.01)  # part-way: the no-load speed limits the motion
        mid = bus.sync_read_positions(IDS)
        speed = vbus.servo(1).model.no_load_speed_rad_s * vbus.servo(1).model.ticks_per_rad
        assert mid[12] == pytest.approx(2048 + speed * 0.01, abs=1)
        clock.advance(1.0)
        assert bus.sync_read_positions(IDS) == {i: 2048 + 40 * i for i in IDS}
        status = bus.read_status(IDS)
        nominal = vbus.servo(1).model.nominal_voltage_v
        assert all(s.voltage_v == pytest.approx(nominal) for s in status.values())
        assert all(s.temperature_c == 30 and s.error_flags == () for s in status.values())
        bus.torque_off([1])
        assert bus.read(1, "torque_enable") == 0
        assert bus.stats.failures == 3  # the scan's empty ids 0, 13, 14 (one attempt each)


def test_feetech_negative_positions_are_sign_magnitude(make_vbus: Any, clock: ManualClock) -> None:
    vbus = make_vbus("feetech_sts")
    vbus.servo(1).write(9, (0).to_bytes(2, "little"))  # keep min limit 0: goal -5 is clamped
    with _connect(vbus) as bus:
        bus.torque_on([1])
        bus.sync_write_positions({1: -5})
        clock.advance(2.0)
        assert bus.sync_read_positions([1]) == {1: 0}


def test_drop_raises_no_response_within_timeout(make_vbus: Any, protocol: str) -> None:
    vbus = make_vbus(protocol)
    with _connect(vbus, retries=2) as bus:
        vbus.faults = FaultPlan(drop_probability=1.0)
        exc, dt = _timed(lambda: bus.sync_read_positions(IDS))
        assert isinstance(exc, NoResponse) and exc.attempts == 3
        assert dt < 3 * TIMEOUT_S + SLACK_S
        exc, dt = _timed(lambda: bus.read(4, "present_position"))
        assert isinstance(exc, NoResponse) and exc.servo_id == 4
        assert dt < 3 * TIMEOUT_S + SLACK_S
        assert bus.stats.retries == 4 and bus.stats.failures == 2


def test_corrupt_raises_corrupt_packet(make_vbus: Any, protocol: str) -> None:
    vbus = make_vbus(protocol)
    with _connect(vbus) as bus:
        vbus.faults = FaultPlan(corrupt_probability=1.0, seed=3)
        for _ in range(5):
            exc, dt = _timed(lambda: bus.read(2, "present_position"))
            assert isinstance(exc, CorruptPacket), exc
            assert dt < TIMEOUT_S + SLACK_S
        exc, _ = _timed(lambda: bus.sync_read_positions(IDS))
        assert isinstance(exc, CorruptPacket)


def test_delay_beyond_timeout_is_no_response_and_short_delay_is_fine(
    make_vbus: Any, protocol: str
) -> None:
    vbus = make_vbus(protocol)
    with _connect(vbus) as bus:
        vbus.faults = FaultPlan(delay_s=0.2)
        exc, dt = _timed(lambda: bus.ping(1))
        assert isinstance(exc, NoResponse)
        assert dt < TIMEOUT_S + SLACK_S  # did not wait for the late reply
        time.sleep(0.2)  # the stream is FIFO: replies after the late one would queue behind it
        vbus.faults = FaultPlan(delay_s=0.002)
        assert bus.sync_read_positions(IDS) == {i: 2048 for i in IDS}


def test_retries_recover_from_intermittent_drops(make_vbus: Any, protocol: str) -> None:
    vbus = make_vbus(protocol)
    with _connect(vbus, retries=6) as bus:
        vbus.faults = FaultPlan(drop_probability=0.3, seed=7)
        for _ in range(10):
            assert bus.read(1, "present_position") == 2048
        assert bus.stats.retries > 0 and bus.stats.failures == 0


def test_vanished_servo(make_vbus: Any, clock: ManualClock, protocol: str) -> None:
    vbus = make_vbus(protocol)
    with _connect(vbus) as bus:
        vbus.faults = FaultPlan(vanish_at_s={5: 1.0})
        assert len(bus.sync_read_positions(IDS)) == 12
        clock.advance(1.0)
        exc, dt = _timed(lambda: bus.sync_read_positions(IDS))
        assert isinstance(exc, NoResponse) and exc.servo_id == 5
        assert dt < TIMEOUT_S + SLACK_S
        vbus.faults = FaultPlan()
        vbus.vanish(9)  # on demand
        exc, _ = _timed(lambda: bus.ping(9))
        assert isinstance(exc, NoResponse) and exc.servo_id == 9
        assert [s.servo_id for s in bus.scan(IDS)] == [i for i in IDS if i != 9]


@pytest.mark.parametrize("fault", ["overload", "overheat", "voltage"])
def test_hardware_fault_flags(make_vbus: Any, protocol: str, fault: str) -> None:
    vbus = make_vbus(protocol)
    name = FLAGS[protocol][fault]
    plan = {
        "overload": FaultPlan(overload=frozenset({3})),
        "overheat": FaultPlan(overheat=frozenset({3})),
        "voltage": FaultPlan(voltage_sag_v=vbus.servo(3).model.nominal_voltage_v * 0.3),
    }[fault]
    with _connect(vbus) as bus:
        vbus.faults = plan
        exc, _ = _timed(lambda: bus.sync_read_positions([1, 2, 3]))
        assert isinstance(exc, ServoFault)
        assert exc.servo_id == (1 if fault == "voltage" else 3)  # a sag hits every servo
        assert name in exc.flags
        status = bus.read_status(IDS)  # the flags are data here, not an exception
        assert name in status[3].error_flags
        if fault == "overheat":
            assert status[3].temperature_c > vbus.servo(3).model.max_temperature_c
        if fault == "voltage":
            assert status[3].voltage_v < vbus.servo(3).model.voltage_min_v
        if fault == "overload":
            assert abs(status[3].load_pct) == 100.0
        assert bus.stats.faults >= 1


def test_dynamixel_latched_error_cleared_by_reboot(make_vbus: Any) -> None:
    vbus = make_vbus("dynamixel2")
    with _connect(vbus) as bus:
        assert isinstance(bus, DynamixelBus)
        bus.torque_on([3])
        vbus.faults = FaultPlan(overload=frozenset({3}))
        with pytest.raises(ServoFault):
            bus.read(3, "present_position")
        vbus.faults = FaultPlan()
        with pytest.raises(ServoFault, match="overload"):  # latched until reboot
            bus.read(3, "present_position")
        assert vbus.servo(3).torque_enabled is False  # Shutdown: torque off on overload
        bus.reboot(3)
        assert bus.read(3, "hardware_error") == 0


def test_dropped_register_reads_lose_status_but_not_positions(
    make_vbus: Any, protocol: str
) -> None:
    """`FaultPlan.drop_reads_of`: no reply to (sync-)reads touching those registers, on the wire;
    other reads and writes are answered."""
    vbus = make_vbus(protocol)
    vbus.faults = FaultPlan(drop_reads_of=frozenset({"present_temperature"}))
    with _connect(vbus, retries=1) as bus:
        assert bus.sync_read_positions(IDS) == {i: 2048 for i in IDS}
        bus.torque_on(IDS)
        with pytest.raises(NoResponse) as info:
            bus.read_status(IDS)
        assert info.value.attempts == 2
        with pytest.raises(NoResponse):
            bus.read(3, "present_temperature")
        assert bus.read(3, "present_position") == 2048
        vbus.faults = FaultPlan()
        assert bus.read_status(IDS)[3].temperature_c == 30.0
    with pytest.raises(ValueError, match="no register 'nope'"):
        vbus.faults = FaultPlan(drop_reads_of=frozenset({"nope"}))

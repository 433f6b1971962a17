"""Dynamixel Protocol 1.0: the codec byte for byte against ROBOTIS's worked examples, the AX/MX
control table, the virtual bus speaking it and the `Dynamixel1Bus` driver on it.

Worked examples (ROBOTIS, Protocol 1.0 "Instruction Details"; the same examples are printed in
the ROBOTIS RX-28 / RX-64 / DX-116 user's manuals §4-5, e.g.
http://www.manualsdir.com/manuals/195512/robotis-rx-28.html?page=23 and
http://auto.manualsonline.com/manuals/mfg/robotis_co_ltd/dynamixel_rx64.html?p=24):
* Example 1 WRITE ID 1 to every servo (broadcast): FF FF FE 04 03 03 01 F6
* Example 2 READ the temperature (address 0x2B, 1 byte) of ID 1: FF FF 01 04 02 2B 01 CC,
  status FF FF 01 03 00 20 DB (32 °C)
* Example 3 PING ID 1: FF FF 01 02 01 FB, status FF FF 01 02 00 FC
* Example 4 RESET ID 0: FF FF 00 02 06 F7, status FF FF 00 02 00 FD
* Example 5 SYNC WRITE goal position and moving speed (address 0x1E, 4 bytes) to IDs 0-3:
  FF FF FE 18 83 1E 04 00 10 00 50 01 01 20 02 60 03 02 30 00 70 01 03 20 02 80 03 12
* Example 6 READ model number and firmware (address 0, 3 bytes) of ID 1: FF FF 01 04 02 00 03 F5,
  status FF FF 01 05 00 1C 00 08 D5 (RX-28: model 28, firmware 8)
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from hardware.bus.control_table import DYNAMIXEL_AX, TABLES
from hardware.bus.dynamixel import Dynamixel1Bus
from hardware.bus.protocol import dynamixel1 as p1
from hardware.bus.protocol.common import FACTORY_RESET, READ
from hardware.bus.servo_bus import BusConfig
from hardware.bus.virtual import FaultPlan, VirtualServoBus
from hardware.errors import CorruptPacket, ServoFault
from robots.servo import servo_model
from tests.hardware.conftest import ManualClock

AX = servo_model("AX_12A")
MX28 = replace(AX, name="MX_28_P1", model_number=29)  # an MX-28 left on Protocol 1.0
IDS = list(range(1, 7))


def h(text: str) -> bytes:
    return bytes.fromhex(text)


# -- codec: the manual's examples -------------------------------------------------------------
def test_instruction_packets_match_the_manual_byte_for_byte() -> None:
    assert p1.write(0xFE, 0x03, b"\x01") == h("FF FF FE 04 03 03 01 F6")
    assert p1.read(1, 0x2B, 1) == h("FF FF 01 04 02 2B 01 CC")
    assert p1.ping(1) == h("FF FF 01 02 01 FB")
    assert p1.factory_reset(0) == h("FF FF 00 02 06 F7")
    assert p1.read(1, 0x00, 3) == h("FF FF 01 04 02 00 03 F5")
    items = {
        0: h("10 00 50 01"),  # position 0x010, speed 0x150
        1: h("20 02 60 03"),  # 0x220, 0x360
        2: h("30 00 70 01"),  # 0x030, 0x170
        3: h("20 02 80 03"),  # 0x220, 0x380
    }
    assert p1.sync_write(0x1E, 4, items) == h(
        "FF FF FE 18 83 1E 04 00 10 00 50 01 01 20 02 60 03 02 30 00 70 01 03 20 02 80 03 12"
    )


def test_status_packets_match_the_manual_and_parse_back() -> None:
    assert p1.build_status(1, 0, b"\x20") == h("FF FF 01 03 00 20 DB")
    assert p1.build_status(1, 0) == h("FF FF 01 02 00 FC")
    assert p1.build_status(0, 0) == h("FF FF 00 02 00 FD")
    st = p1.parse_packet(h("FF FF 01 05 00 1C 00 08 D5"), "status")
    assert (st.servo_id, st.error, st.params) == (1, 0, h("1C 00 08"))
    inst = p1.parse_packet(h("FF FF 01 04 02 2B 01 CC"), "instruction")
    assert (inst.servo_id, inst.instruction, inst.params) == (1, READ, h("2B 01"))
    with pytest.raises(ValueError, match="bit 7"):
        p1.build_status(1, 0x80)  # always 0 in Protocol 1.0


def test_checksum_is_the_complement_of_the_byte_sum() -> None:
    body = h("01 04 02 2B 01")  # ID LEN INST PARAMS of example 2
    assert p1.checksum(body) == (~sum(body)) & 0xFF == 0xCC
    with pytest.raises(CorruptPacket, match="checksum"):
        p1.parse_packet(h("FF FF 01 04 02 2B 01 CD"), "instruction")


def test_error_byte_bits_follow_the_manual() -> None:
    # bit 0 input voltage, 1 angle limit, 2 overheating, 3 range, 4 checksum, 5 overload,
    # 6 instruction (e-Manual Protocol 1.0, "Status Packet")
    assert [p1.ERROR_BITS[1 << b] for b in range(7)] == [
        "input_voltage", "angle_limit", "overheating", "range", "checksum", "overload",
        "instruction",
    ]  # fmt: skip
    assert DYNAMIXEL_AX.status_error_bits == p1.ERROR_BITS


def test_bulk_read_layout_is_the_sdks() -> None:
    # dynamixel_sdk GroupBulkRead (Protocol 1.0): 0x00, then (length, id, address) per servo
    pkt = p1.bulk_read([(1, 36, 2), (2, 30, 4)])
    assert pkt[:5] == h("FF FF FE 09 92") and pkt[5:-1] == h("00 02 01 24 04 02 1E")
    parsed = p1.parse_packet(pkt, "instruction")
    assert p1.bulk_read_items(parsed.params) == [(1, 36, 2), (2, 30, 4)]


def test_ax_control_table_addresses() -> None:
    t = TABLES["dynamixel1"]
    where = {n: (t[n].addr, t[n].size) for n in t.registers}
    assert where["goal_position"] == (30, 2) and where["present_position"] == (36, 2)
    assert where["present_load"] == (40, 2) and where["present_voltage"] == (42, 1)
    assert where["present_temperature"] == (43, 1) and where["torque_enable"] == (24, 1)
    assert where["moving_speed"] == (32, 2) and where["status_return_level"] == (16, 1)
    assert where["return_delay"] == (5, 1)
    assert t["present_load"].decode(h("F4 05")) == -500  # 1024 + 500: CW, bit 10
    assert AX.position_max_tick == 1023 and AX.ticks_per_rev == pytest.approx(1228.8)


# -- the virtual bus and the driver -----------------------------------------------------------
def _bus(model=AX, clock=None, **kw):  # type: ignore[no-untyped-def]
    vbus = VirtualServoBus({i: model for i in IDS}, clock=clock or ManualClock(), **kw)
    return vbus, vbus.connect(BusConfig(timeout_s=0.02))


def test_virtual_bus_answers_the_manuals_ping_and_read() -> None:
    vbus, _ = _bus()
    (_, reply), = vbus.process(p1.ping(1), 0.0)  # fmt: skip
    assert reply == h("FF FF 01 02 00 FC")
    (_, reply), = vbus.process(p1.read(1, 0x2B, 1), 0.0)  # fmt: skip
    assert reply == h("FF FF 01 03 00 1E") + bytes((p1.checksum(h("01 03 00 1E")),))  # 30 °C


def test_driver_plays_positions_through_sync_write_and_per_servo_reads() -> None:
    clock = ManualClock()
    vbus, bus = _bus(clock=clock)
    assert isinstance(bus, Dynamixel1Bus)
    assert [i.model_number for i in bus.scan(range(1, 8))] == [12] * 6
    assert not bus.bulk_read_ok(IDS)  # the AX has no BULK READ
    bus.torque_on(IDS)
    before = vbus.instructions
    bus.sync_write_positions({i: 500 + i for i in IDS})
    clock.advance(2.0)
    assert bus.sync_read_positions(IDS) == {i: 500 + i for i in IDS}
    assert vbus.instructions - before == 1 + len(IDS)  # one SYNC WRITE, one READ per servo
    status = bus.read_status(IDS)
    assert status[3].voltage_v == 12.0 and status[3].temperature_c == 30.0
    assert status[3].error_flags == ()


def test_mx_models_are_read_with_one_bulk_read() -> None:
    clock = ManualClock()
    vbus, bus = _bus(model=MX28, clock=clock)
    for i in IDS:
        bus.ping(i)
    assert bus.bulk_read_ok(IDS)
    bus.torque_on(IDS)
    bus.sync_write_positions({i: 600 - i for i in IDS})
    clock.advance(2.0)
    before = vbus.instructions
    assert bus.sync_read_positions(IDS) == {i: 600 - i for i in IDS}
    assert vbus.instructions - before == 1
    assert set(bus.read_status(IDS)) == set(IDS)


def test_a_mixed_bus_falls_back_to_reads_per_servo() -> None:
    vbus = VirtualServoBus({1: MX28, 2: AX}, clock=ManualClock())
    bus = vbus.connect(BusConfig(timeout_s=0.02))
    bus.ping(1)
    bus.ping(2)
    assert not bus.bulk_read_ok([1, 2])
    assert set(bus.sync_read_positions([1, 2])) == {1, 2}


def test_health_bits_of_the_error_byte_become_faults_and_status_flags() -> None:
    vbus, bus = _bus()
    vbus.faults = FaultPlan(overheat=frozenset({2}))
    flags = bus.read_status(IDS)[2].error_flags
    assert flags == ("overheating",)
    with pytest.raises(ServoFault, match="overheating"):
        bus.sync_read_positions(IDS)


def test_overheating_shuts_the_torque_off_as_the_ax_does() -> None:
    vbus, bus = _bus()
    bus.torque_on([4])
    vbus.faults = FaultPlan(overheat=frozenset({4}))
    with pytest.raises(ServoFault):
        bus.read(4, "present_position")
    assert not vbus.servo(4).torque_enabled  # Shutdown 36 includes overheating


def test_goal_outside_the_angle_limits_is_clamped_and_flagged() -> None:
    vbus, bus = _bus()
    bus.write(1, "max_position_limit", 700)
    with pytest.raises(ServoFault, match="angle_limit"):
        bus.write(1, "goal_position", 900)
    assert vbus.servo(1).goal_tick == 700


def test_unknown_instruction_and_out_of_table_reads_are_answered_with_error_bits() -> None:
    vbus, _ = _bus()
    (_, reply), = vbus.process(p1.build_instruction(1, 0x7F), 0.0)  # fmt: skip
    assert p1.parse_packet(reply, "status").error == p1.INSTRUCTION
    (_, reply), = vbus.process(p1.read(1, 45, 10), 0.0)  # fmt: skip
    st = p1.parse_packet(reply, "status")
    assert st.error == p1.RANGE and st.params == b""


def test_status_return_level_below_2_is_refused_at_ping_with_the_fix() -> None:
    vbus, bus = _bus()
    vbus.servo(5).mem[16] = 1  # answer PING and READ only
    with pytest.raises(ServoFault, match=r"status_return_level 1.*address 16 to 2"):
        bus.ping(5)
    # and the servo really does not acknowledge writes at that level
    assert vbus.process(p1.write(5, 25, b"\x01"), 0.0) == []
    assert vbus.process(p1.ping(5), 0.0) != []


def test_factory_reset_and_broadcast_write() -> None:
    vbus, _ = _bus()
    assert vbus.process(p1.write(0xFE, 25, b"\x01"), 0.0) == []  # broadcast: no status
    assert all(s.get("led") == 1 for s in vbus.servos)
    vbus.process(p1.build_instruction(3, FACTORY_RESET), 0.0)
    assert vbus.servo(1).get("led") == 1 and [s.servo_id for s in vbus.servos].count(1) == 2

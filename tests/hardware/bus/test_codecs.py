"""Packet codecs against the vendors' worked examples, plus property-based round trips."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hardware.bus.control_table import (
    DYNAMIXEL_X,
    FEETECH_STS,
    decode_sign_magnitude,
    encode_sign_magnitude,
)
from hardware.bus.protocol import dynamixel2 as dxl
from hardware.bus.protocol import feetech as ft
from hardware.bus.protocol.common import PING, READ, STATUS, Packet
from hardware.errors import CorruptPacket


def h(text: str) -> bytes:
    return bytes.fromhex(text)


# -- Dynamixel Protocol 2.0: ROBOTIS e-Manual "Protocol 2.0", Instruction Details examples ------
def test_crc_table_matches_emanual_head() -> None:
    assert dxl.CRC_TABLE[:8] == (0x0000, 0x8005, 0x800F, 0x000A, 0x801B, 0x001E, 0x0014, 0x8011)
    assert dxl.CRC_TABLE[-1] == 0x0202


@pytest.mark.parametrize(
    ("built", "expected"),
    [
        (dxl.ping(1), "FF FF FD 00 01 03 00 01 19 4E"),
        (dxl.ping(0xFE), "FF FF FD 00 FE 03 00 01 31 42"),
        (dxl.read(1, 132, 4), "FF FF FD 00 01 07 00 02 84 00 04 00 1D 15"),
        (
            dxl.write(1, 116, (512).to_bytes(4, "little")),
            "FF FF FD 00 01 09 00 03 74 00 00 02 00 00 CA 89",
        ),
        (dxl.sync_read(132, 4, [1, 2]), "FF FF FD 00 FE 09 00 82 84 00 04 00 01 02 CE FA"),
        (
            dxl.sync_write(
                116, 4, {1: (150).to_bytes(4, "little"), 2: (170).to_bytes(4, "little")}
            ),
            "FF FF FD 00 FE 11 00 83 74 00 04 00 01 96 00 00 00 02 AA 00 00 00 82 87",
        ),
        (dxl.reboot(1), "FF FF FD 00 01 03 00 08 2F 4E"),
        (dxl.factory_reset(1, 0x01), "FF FF FD 00 01 04 00 06 01 A1 E6"),
        (
            dxl.build_packet(1, 0x04, bytes((0x68, 0x00, 0xC8, 0, 0, 0))),  # Reg Write example
            "FF FF FD 00 01 09 00 04 68 00 C8 00 00 00 AE 8E",
        ),
        (dxl.build_packet(1, 0x05), "FF FF FD 00 01 03 00 05 02 CE"),  # Action example
    ],
)
def test_dynamixel_instruction_examples(built: bytes, expected: str) -> None:
    assert built == h(expected)


@pytest.mark.parametrize(
    ("status", "servo_id", "params"),
    [
        ("FF FF FD 00 01 07 00 55 00 06 04 26 65 5D", 1, "06 04 26"),  # ping: model 1030, fw 38
        ("FF FF FD 00 02 07 00 55 00 06 04 26 6F 6D", 2, "06 04 26"),
        ("FF FF FD 00 01 08 00 55 00 A6 00 00 00 8C C0", 1, "A6 00 00 00"),  # position 166
        ("FF FF FD 00 02 08 00 55 00 1F 08 00 00 BA BE", 2, "1F 08 00 00"),  # position 2079
        ("FF FF FD 00 01 04 00 55 00 A1 0C", 1, ""),  # write / reboot acknowledgement
        ("FF FF FD 00 01 06 00 55 00 77 00 C3 69", 1, "77 00"),  # voltage 11.9 V
        ("FF FF FD 00 02 05 00 55 00 24 8B A9", 2, "24"),  # temperature 36 °C
    ],
)
def test_dynamixel_status_examples(status: str, servo_id: int, params: str) -> None:
    raw = h(status)
    assert dxl.parse_packet(raw) == Packet(servo_id, STATUS, h(params), error=0)
    assert dxl.build_status(servo_id, 0, h(params)) == raw


def test_dynamixel_status_decodes_with_control_table() -> None:
    p = dxl.parse_packet(h("FF FF FD 00 02 08 00 55 00 1F 08 00 00 BA BE"))
    assert DYNAMIXEL_X["present_position"].decode(p.params) == 2079


def test_dynamixel_stuffing_example() -> None:
    assert dxl.stuff(h("FF FF FD")) == h("FF FF FD FD")
    assert dxl.unstuff(h("FF FF FD FD")) == h("FF FF FD")
    frame = dxl.write(1, 0x100, h("FF FF FD 01"))
    assert h("FF FF FD FD 01") in frame
    # LEN = INST + 2 address + 4 data + 1 stuffed 0xFD + 2 CRC
    assert frame[5] | (frame[6] << 8) == 1 + 2 + 4 + 1 + 2
    assert dxl.parse_packet(frame).params == h("00 01 FF FF FD 01")


# -- Feetech SCS/STS: protocol manual §4 examples ------------------------------------------------
@pytest.mark.parametrize(
    ("built", "expected"),
    [
        (ft.ping(1), "FF FF 01 02 01 FB"),
        (ft.read(1, 0x38, 2), "FF FF 01 04 02 38 02 BE"),
        (ft.write(0xFE, 5, bytes((1,))), "FF FF FE 04 03 05 01 F4"),
        (ft.write(1, 0x2A, h("00 08 00 00 E8 03")), "FF FF 01 09 03 2A 00 08 00 00 E8 03 D5"),
        (ft.reg_write(1, 0x2A, h("00 08 00 00 E8 03")), "FF FF 01 09 04 2A 00 08 00 00 E8 03 D4"),
        (ft.reg_write(10, 0x2A, h("00 08 00 00 E8 03")), "FF FF 0A 09 04 2A 00 08 00 00 E8 03 CB"),
        (ft.action(), "FF FF FE 02 05 FA"),
        (
            ft.sync_write(0x2A, 6, {i: h("00 08 00 00 E8 03") for i in (1, 2, 3, 4)}),
            "FF FF FE 20 83 2A 06 01 00 08 00 00 E8 03 02 00 08 00 00 E8 03 "
            "03 00 08 00 00 E8 03 04 00 08 00 00 E8 03 58",
        ),
        (ft.sync_read(0x38, 8, [1, 2]), "FF FF FE 06 82 38 08 01 02 36"),
    ],
)
def test_feetech_instruction_examples(built: bytes, expected: str) -> None:
    assert built == h(expected)


@pytest.mark.parametrize(
    ("status", "servo_id", "params"),
    [
        ("FF FF 01 02 00 FC", 1, ""),
        ("FF FF 01 04 00 18 05 DD", 1, "18 05"),  # present position 1304
        ("FF FF 01 0A 00 00 08 00 00 00 00 79 1E 55", 1, "00 08 00 00 00 00 79 1E"),
        ("FF FF 02 0A 00 FF 07 00 00 00 00 77 23 53", 2, "FF 07 00 00 00 00 77 23"),
    ],
)
def test_feetech_status_examples(status: str, servo_id: int, params: str) -> None:
    raw = h(status)
    assert ft.parse_packet(raw, "status") == Packet(servo_id, None, h(params), error=0)
    assert ft.build_status(servo_id, 0, h(params)) == raw


def test_feetech_sync_read_reply_decodes() -> None:
    p = ft.parse_packet(h("FF FF 01 0A 00 00 08 00 00 00 00 79 1E 55"), "status")
    block = p.params  # starts at Present Position (0x38)
    assert FEETECH_STS["present_position"].decode(block[0:2]) == 2048
    assert FEETECH_STS["present_voltage"].to_physical(block[62 - 56]) == pytest.approx(12.1)
    assert FEETECH_STS["present_temperature"].decode(block[63 - 56 : 64 - 56]) == 30
    assert ft.parse_packet(h("FF FF 01 04 00 18 05 DD"), "status").params == (1304).to_bytes(
        2, "little"
    )


def test_feetech_sign_magnitude() -> None:
    reg = FEETECH_STS["present_position"]
    assert reg.encode(-100) == (100 | 0x8000).to_bytes(2, "little")
    assert reg.decode((100 | 0x8000).to_bytes(2, "little")) == -100
    load = FEETECH_STS["present_load"]
    assert load.decode((250 | 1 << 10).to_bytes(2, "little")) == -250
    with pytest.raises(ValueError):
        encode_sign_magnitude(1 << 15, 15)


# -- property-based round trips --------------------------------------------------------------
ids = st.integers(0, 0xFC)
payloads = st.binary(max_size=60) | st.lists(
    st.sampled_from([b"\xff", b"\xfd", b"\x00", b"\xff\xff\xfd"]), max_size=20
).map(b"".join)


@given(ids, st.integers(0, 0xFF).filter(lambda i: i != STATUS), payloads)
def test_dynamixel_instruction_round_trip(servo_id: int, inst: int, params: bytes) -> None:
    frame = dxl.build_packet(servo_id, inst, params)
    assert dxl.parse_packet(frame) == Packet(servo_id, inst, params)
    body = frame[7:-2]  # every "FF FF FD" on the wire is followed by a stuffed "FD"
    for i in range(len(body) - 2):
        if body[i : i + 3] == b"\xff\xff\xfd":
            assert body[i + 3 : i + 4] == b"\xfd"


@given(ids, st.integers(0, 0xFF), payloads)
def test_dynamixel_status_round_trip(servo_id: int, error: int, params: bytes) -> None:
    assert dxl.parse_packet(dxl.build_status(servo_id, error, params)) == Packet(
        servo_id, STATUS, params, error
    )


@given(payloads)
def test_stuffing_round_trip(body: bytes) -> None:
    assert dxl.unstuff(dxl.stuff(body)) == body


@given(ids, payloads, st.data())
def test_dynamixel_corruption_raises(servo_id: int, params: bytes, data: st.DataObject) -> None:
    frame = bytearray(dxl.build_packet(servo_id, READ, params))
    i = data.draw(st.integers(4, len(frame) - 1))
    frame[i] ^= data.draw(st.integers(1, 255))
    with pytest.raises(CorruptPacket):
        dxl.parse_packet(bytes(frame))


@given(ids, st.integers(0, 0xFF), st.binary(max_size=60))
def test_feetech_round_trip(servo_id: int, code: int, params: bytes) -> None:
    assert ft.parse_packet(ft.build_instruction(servo_id, code, params), "instruction") == Packet(
        servo_id, code, params
    )
    assert ft.parse_packet(ft.build_status(servo_id, code, params), "status") == Packet(
        servo_id, None, params, code
    )


@given(ids, st.binary(max_size=60), st.data())
def test_feetech_corruption_raises(servo_id: int, params: bytes, data: st.DataObject) -> None:
    frame = bytearray(ft.build_instruction(servo_id, PING, params))
    i = data.draw(st.integers(2, len(frame) - 1))
    frame[i] ^= data.draw(st.integers(1, 255))
    with pytest.raises(CorruptPacket):
        ft.parse_packet(bytes(frame), "instruction")


@settings(max_examples=50)
@given(st.lists(st.tuples(ids, st.binary(max_size=20)), min_size=1, max_size=5), st.data())
def test_stream_parsers_resync_over_garbage_and_chunking(
    packets: list[tuple[int, bytes]], data: st.DataObject
) -> None:
    for proto in ("dxl", "ft"):
        if proto == "dxl":
            frames = [dxl.build_packet(i, READ, p) for i, p in packets]
            parser: dxl.StreamParser | ft.StreamParser = dxl.StreamParser()
        else:
            frames = [ft.build_instruction(i, READ, p) for i, p in packets]
            parser = ft.StreamParser("instruction")
        garbage = data.draw(st.binary(max_size=8).filter(lambda g: b"\xff" not in g))
        stream = garbage + b"".join(frames)
        cut = data.draw(st.integers(0, len(stream)))
        got = parser.feed(stream[:cut]) + parser.feed(stream[cut:])
        assert [(p.servo_id, p.params) for p in got] == packets


@given(st.integers(-(2**15) + 1, 2**15 - 1))
def test_sign_magnitude_round_trip(value: int) -> None:
    assert decode_sign_magnitude(encode_sign_magnitude(value, 15), 15) == value

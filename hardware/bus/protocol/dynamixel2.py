"""DYNAMIXEL Protocol 2.0 packet codec (ROBOTIS e-Manual, "Protocol 2.0").

Frame: FF FF FD 00 | ID | LEN_L LEN_H | INST | PARAMS... | CRC_L CRC_H, where LEN counts the
instruction, the (stuffed) parameters and the two CRC bytes. Status packets use INST 0x55 followed
by an ERROR byte. Byte stuffing: inside INST..PARAMS every "FF FF FD" gets an extra "FD"; LEN and
the CRC are computed over the stuffed packet. CRC-16: polynomial 0x8005, initial value 0, not
reflected (the e-Manual's "CRC Calculation" table).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from hardware.bus.protocol.common import (
    BROADCAST_ID,
    FACTORY_RESET,
    PING,
    READ,
    REBOOT,
    STATUS,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
    FrameStream,
    Packet,
)
from hardware.errors import CorruptPacket

HEADER = b"\xff\xff\xfd\x00"
MAX_LENGTH = 1024  # the SDK's RXPACKET_MAX_LEN


def _crc_table() -> tuple[int, ...]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray, crc: int = 0) -> int:
    """CRC-16 (poly 0x8005, init 0) as in the e-Manual's update_crc()."""
    for b in data:
        crc = ((crc << 8) ^ CRC_TABLE[((crc >> 8) ^ b) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Insert 0xFD after every "FF FF FD" in `body` (instruction + parameters)."""
    out = bytearray()
    for b in body:
        out.append(b)
        if b == 0xFD and len(out) >= 3 and out[-3] == 0xFF and out[-2] == 0xFF:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """Inverse of `stuff`: "FF FF FD FD" → "FF FF FD"."""
    out = bytearray()
    i = 0
    n = len(body)
    while i < n:
        b = body[i]
        out.append(b)
        i += 1
        if (
            b == 0xFD
            and i < n
            and body[i] == 0xFD
            and len(out) >= 3
            and out[-3] == 0xFF
            and out[-2] == 0xFF
        ):
            i += 1  # drop the stuffed 0xFD
    return bytes(out)


def build_packet(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A complete, stuffed, CRC'd frame."""
    if not 0 <= servo_id <= 0xFE or servo_id == 0xFD:
        raise ValueError(f"invalid packet id {servo_id}")
    body = stuff(bytes((instruction,)) + bytes(params))
    length = len(body) + 2
    if length > MAX_LENGTH:
        raise ValueError(f"packet too long ({length} > {MAX_LENGTH})")
    frame = HEADER + bytes((servo_id, length & 0xFF, length >> 8)) + body
    crc = crc16(frame)
    return frame + bytes((crc & 0xFF, crc >> 8))


def build_status(servo_id: int, error: int, params: bytes = b"") -> bytes:
    """A status packet (INST 0x55) with error byte `error`."""
    return build_packet(servo_id, STATUS, bytes((error,)) + bytes(params))


def parse_packet(raw: bytes) -> Packet:
    """Decode one complete frame; raises CorruptPacket on any framing or CRC error."""
    raw = bytes(raw)
    if len(raw) < 10:
        raise CorruptPacket(f"frame of {len(raw)} bytes is shorter than 10")
    if raw[:4] != HEADER:
        raise CorruptPacket(f"bad header {raw[:4].hex(' ')}")
    servo_id = raw[4]
    length = raw[5] | (raw[6] << 8)
    if length != len(raw) - 7:
        raise CorruptPacket(f"length field {length} but {len(raw) - 7} bytes follow", servo_id)
    crc = raw[-2] | (raw[-1] << 8)
    if crc16(raw[:-2]) != crc:
        raise CorruptPacket(f"CRC 0x{crc:04X} != 0x{crc16(raw[:-2]):04X}", servo_id)
    body = unstuff(raw[7:-2])
    instruction = body[0]
    if instruction == STATUS:
        if len(body) < 2:
            raise CorruptPacket("status packet without error byte", servo_id)
        return Packet(servo_id, STATUS, body[2:], error=body[1])
    return Packet(servo_id, instruction, body[1:])


class StreamParser(FrameStream):
    """Incremental Protocol 2.0 frame extractor (see `FrameStream`)."""

    header = HEADER
    prefix_len = 7  # header, id, length (2 bytes)

    def _frame_length(self, buf: bytearray) -> int | None:
        length = buf[5] | (buf[6] << 8)
        return 7 + length if 3 <= length <= MAX_LENGTH else None

    def _parse(self, frame: bytes) -> Packet:
        return parse_packet(frame)


# -- instruction builders (e-Manual "Instruction Details") ------------------------------------
def ping(servo_id: int) -> bytes:
    return build_packet(servo_id, PING)


def read(servo_id: int, addr: int, length: int) -> bytes:
    return build_packet(servo_id, READ, _u16(addr) + _u16(length))


def write(servo_id: int, addr: int, data: bytes) -> bytes:
    return build_packet(servo_id, WRITE, _u16(addr) + bytes(data))


def sync_read(addr: int, length: int, ids: Iterable[int]) -> bytes:
    return build_packet(BROADCAST_ID, SYNC_READ, _u16(addr) + _u16(length) + bytes(ids))


def sync_write(addr: int, length: int, items: Mapping[int, bytes]) -> bytes:
    params = bytearray(_u16(addr) + _u16(length))
    for servo_id, data in items.items():
        if len(data) != length:
            raise ValueError(f"servo {servo_id}: {len(data)} data bytes, expected {length}")
        params.append(servo_id)
        params.extend(data)
    return build_packet(BROADCAST_ID, SYNC_WRITE, bytes(params))


def reboot(servo_id: int) -> bytes:
    return build_packet(servo_id, REBOOT)


def factory_reset(servo_id: int, option: int = 0x01) -> bytes:
    return build_packet(servo_id, FACTORY_RESET, bytes((option,)))


def _u16(v: int) -> bytes:
    return bytes((v & 0xFF, (v >> 8) & 0xFF))

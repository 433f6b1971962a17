"""Feetech SCS/STS ("FT-SCS") packet codec (Feetech communication protocol manual).

Instruction frame: FF FF | ID | LEN | INST | PARAMS... | CHK
Status frame:      FF FF | ID | LEN | STATUS | PARAMS... | CHK
LEN = number of parameters + 2; CHK = ~(ID + LEN + INST/STATUS + PARAMS) & 0xFF.
Multi-byte values are little-endian on STS/SMS servos (the SDK's protocol_end 0).
The frame does not say whether it is an instruction or a status: the reader knows the direction.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Literal

from hardware.errors import CorruptPacket
from hardware.protocol.common import (
    ACTION,
    BROADCAST_ID,
    PING,
    READ,
    REG_WRITE,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
    FrameStream,
    Packet,
)

HEADER = b"\xff\xff"
MAX_LENGTH = 250  # the SDK's RXPACKET_MAX_LEN
Direction = Literal["instruction", "status"]


def checksum(body: bytes | bytearray) -> int:
    """~(sum of ID, LEN, INST/STATUS and parameters) & 0xFF."""
    return ~sum(body) & 0xFF


def _frame(servo_id: int, code: int, params: bytes) -> bytes:
    if not 0 <= servo_id <= 0xFE:
        raise ValueError(f"invalid packet id {servo_id}")
    length = len(params) + 2
    if length + 4 > MAX_LENGTH:
        raise ValueError(f"packet too long ({length + 4} > {MAX_LENGTH})")
    body = bytes((servo_id, length, code)) + bytes(params)
    return HEADER + body + bytes((checksum(body),))


def build_instruction(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    return _frame(servo_id, instruction, params)


def build_status(servo_id: int, error: int, params: bytes = b"") -> bytes:
    return _frame(servo_id, error, params)


def parse_packet(raw: bytes, direction: Direction) -> Packet:
    """Decode one complete frame; raises CorruptPacket on framing or checksum errors."""
    raw = bytes(raw)
    if len(raw) < 6:
        raise CorruptPacket(f"frame of {len(raw)} bytes is shorter than 6")
    if raw[:2] != HEADER:
        raise CorruptPacket(f"bad header {raw[:2].hex(' ')}")
    servo_id, length = raw[2], raw[3]
    if length != len(raw) - 4:
        raise CorruptPacket(f"length field {length} but {len(raw) - 4} bytes follow", servo_id)
    if checksum(raw[2:-1]) != raw[-1]:
        raise CorruptPacket(f"checksum 0x{raw[-1]:02X} != 0x{checksum(raw[2:-1]):02X}", servo_id)
    code, params = raw[4], raw[5:-1]
    if direction == "status":
        return Packet(servo_id, None, params, error=code)
    return Packet(servo_id, code, params)


class StreamParser(FrameStream):
    """Incremental frame extractor for one direction (see `FrameStream`)."""

    header = HEADER
    prefix_len = 4  # header, id, length

    def __init__(self, direction: Direction, max_frame: int | None = None) -> None:
        super().__init__(max_frame)
        self.direction: Direction = direction

    def _resync(self, buf: bytearray) -> bool:
        if buf[2] == 0xFF:  # FF FF FF ...: the header starts one byte later
            del buf[:1]
            return True
        return False

    def _frame_length(self, buf: bytearray) -> int | None:
        length = buf[3]
        return 4 + length if 2 <= length and length + 4 <= MAX_LENGTH else None

    def _parse(self, frame: bytes) -> Packet:
        return parse_packet(frame, self.direction)


# -- instruction builders (protocol manual §4) -------------------------------------------------
def ping(servo_id: int) -> bytes:
    return build_instruction(servo_id, PING)


def read(servo_id: int, addr: int, length: int) -> bytes:
    return build_instruction(servo_id, READ, bytes((addr, length)))


def write(servo_id: int, addr: int, data: bytes) -> bytes:
    return build_instruction(servo_id, WRITE, bytes((addr,)) + bytes(data))


def reg_write(servo_id: int, addr: int, data: bytes) -> bytes:
    return build_instruction(servo_id, REG_WRITE, bytes((addr,)) + bytes(data))


def action(servo_id: int = BROADCAST_ID) -> bytes:
    return build_instruction(servo_id, ACTION)


def sync_read(addr: int, length: int, ids: Iterable[int]) -> bytes:
    return build_instruction(BROADCAST_ID, SYNC_READ, bytes((addr, length)) + bytes(ids))


def sync_write(addr: int, length: int, items: Mapping[int, bytes]) -> bytes:
    params = bytearray((addr, length))
    for servo_id, data in items.items():
        if len(data) != length:
            raise ValueError(f"servo {servo_id}: {len(data)} data bytes, expected {length}")
        params.append(servo_id)
        params.extend(data)
    return build_instruction(BROADCAST_ID, SYNC_WRITE, bytes(params))

"""DYNAMIXEL Protocol 1.0 packet codec (ROBOTIS e-Manual, "Protocol 1.0"; the same packets and
worked examples are in the ROBOTIS AX-12 / RX-28 / RX-64 / DX-116 user's manuals, §4).

Instruction packet: FF FF | ID | LEN | INST | PARAMS... | CHECKSUM
Status packet:      FF FF | ID | LEN | ERROR | PARAMS... | CHECKSUM
LEN = number of parameters + 2; CHECKSUM = ~(ID + LEN + INST/ERROR + ΣPARAMS) & 0xFF.
Addresses and lengths are one byte; multi-byte values are little-endian. This is the frame the
Feetech SCS protocol copied, so the framing (checksum, stream resynchronisation) is
`hardware.bus.protocol.feetech`'s; what differs is the instruction set (no SYNC READ; BULK READ
0x92 on MX / EX servos only, not AX) and the meaning of the status error byte (`ERROR_BITS`).

A frame does not say whether it is an instruction or a status: the reader knows the direction.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from hardware.bus.protocol import feetech as _frame
from hardware.bus.protocol.common import (
    ACTION,
    BROADCAST_ID,
    FACTORY_RESET,
    PING,
    READ,
    REG_WRITE,
    WRITE,
)

HEADER = _frame.HEADER
MAX_LENGTH = 250  # dynamixel_sdk protocol1_packet_handler TXPACKET_MAX_LEN / RXPACKET_MAX_LEN
BULK_READ = 0x92
STATUS_OVERHEAD = 6  # bytes of a status frame without parameters: FF FF ID LEN ERR CHK
INSTRUCTION_OVERHEAD = 6  # FF FF ID LEN INST CHK

# Status packet error byte (e-Manual Protocol 1.0, "Status Packet": bit 7 is always 0).
INPUT_VOLTAGE = 0x01
ANGLE_LIMIT = 0x02
OVERHEATING = 0x04
RANGE = 0x08
CHECKSUM = 0x10
OVERLOAD = 0x20
INSTRUCTION = 0x40
ERROR_BITS: Mapping[int, str] = {
    INPUT_VOLTAGE: "input_voltage",
    ANGLE_LIMIT: "angle_limit",
    OVERHEATING: "overheating",
    RANGE: "range",
    CHECKSUM: "checksum",
    OVERLOAD: "overload",
    INSTRUCTION: "instruction",
}
# bits that answer the instruction rather than report the servo's health
COMMAND_ERRORS = ANGLE_LIMIT | RANGE | CHECKSUM | INSTRUCTION

checksum = _frame.checksum
parse_packet = _frame.parse_packet
StreamParser = _frame.StreamParser


def build_instruction(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    return _frame.build_instruction(servo_id, instruction, params)


def build_status(servo_id: int, error: int, params: bytes = b"") -> bytes:
    if not 0 <= error <= 0x7F:
        raise ValueError(f"status error byte 0x{error:02X} has bit 7 set (always 0 in 1.0)")
    return _frame.build_status(servo_id, error, params)


# -- instruction builders (e-Manual "Instruction Details") ------------------------------------
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


def factory_reset(servo_id: int) -> bytes:
    """RESET (0x06): the whole control table back to factory values (ID becomes 1)."""
    return build_instruction(servo_id, FACTORY_RESET)


def sync_write(addr: int, length: int, items: Mapping[int, bytes]) -> bytes:
    """SYNC WRITE (0x83), broadcast: LEN = (L + 1)·N + 4; no status packets come back."""
    return _frame.sync_write(addr, length, items)


def bulk_read(items: Iterable[tuple[int, int, int]]) -> bytes:
    """BULK READ (0x92), broadcast, MX / EX series only: parameters 0x00, then (length, id,
    address) per servo; each servo answers with its own status packet, in the listed order
    (a servo waits for the one listed before it)."""
    params = bytearray((0x00,))
    for servo_id, addr, length in items:
        params.extend((length, servo_id, addr))
    return build_instruction(BROADCAST_ID, BULK_READ, bytes(params))


def bulk_read_items(params: bytes) -> list[tuple[int, int, int]]:
    """(id, address, length) per servo of a BULK READ's parameters (inverse of `bulk_read`)."""
    body = params[1:]
    return [(body[i + 1], body[i + 2], body[i]) for i in range(0, len(body) - 2, 3)]


def status_length(n_params: int) -> int:
    """Bytes on the wire of a status packet with `n_params` parameters."""
    return STATUS_OVERHEAD + n_params

"""Values shared by the packet codecs."""

from __future__ import annotations

from dataclasses import dataclass

BROADCAST_ID = 0xFE

# Instruction codes common to Dynamixel Protocol 2.0 and Feetech STS/SCS.
PING = 0x01
READ = 0x02
WRITE = 0x03
REG_WRITE = 0x04
ACTION = 0x05
FACTORY_RESET = 0x06
REBOOT = 0x08
SYNC_READ = 0x82
SYNC_WRITE = 0x83
STATUS = 0x55  # Dynamixel 2.0 only: the instruction byte of a status packet


@dataclass(frozen=True)
class Packet:
    """One decoded packet.

    Instruction packets have `error` None; status packets carry the error/status byte.
    For Dynamixel status packets `instruction` is 0x55; for Feetech it is None (the byte
    in that position is the status byte).
    """

    servo_id: int
    instruction: int | None
    params: bytes
    error: int | None = None

    @property
    def is_status(self) -> bool:
        return self.error is not None

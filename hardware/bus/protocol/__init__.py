"""Wire-protocol codecs (pure functions on bytes): Dynamixel Protocol 2.0 and Feetech STS/SCS."""

from hardware.bus.protocol.common import Packet

__all__ = ["Packet"]

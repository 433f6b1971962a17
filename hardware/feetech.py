"""`FeetechBus`: Feetech STS/SMS servos (SCS protocol, little-endian); the port is the SDK's
`scservo_sdk.PortHandler`, the packets are `hardware.protocol.feetech`'s."""

from __future__ import annotations

from typing import Any

import scservo_sdk as sdk

from hardware.bus import BusConfig, ServoInfo
from hardware.control_table import FEETECH_STS, decode_flags
from hardware.protocol import feetech as codec
from hardware.protocol.common import FrameStream
from hardware.sdk_bus import LatencyMixin, SdkServoBus

STS_ENDIANNESS = 0  # scservo_sdk "protocol_end": 0 = little-endian (STS/SMS), 1 = SCS


class FeetechPortHandler(LatencyMixin, sdk.PortHandler):  # type: ignore[misc]
    """The SDK's PortHandler with a configurable reply allowance."""


class FeetechBus(SdkServoBus):
    """Feetech STS-series servos on one bus.

    `port` is a device path (e.g. "/dev/ttyACM0") or a PortHandler-like object.
    Note: scservo_sdk's clearPort() only flushes output; the engine (`hardware.sdk_bus`) drains
    stale input itself before every request (a late reply must not be taken for the next one).
    """

    protocol = "feetech_sts"
    default_baudrate = 1_000_000  # STS factory setting
    default_reply_gap_s = 0.0  # STS factory Return Delay Time 0
    status_overhead = 6  # header 2, id, length, status, checksum
    ping_params = 0
    identity_span = (0, 5)  # firmware major 0, minor 1, model number 3 (2 B)
    codec = codec
    sdk = sdk

    def __init__(self, port: Any, config: BusConfig | None = None) -> None:
        super().__init__(port, FEETECH_STS, config)

    def _make_port_handler(self, path: str) -> Any:
        return FeetechPortHandler(path)

    def _status_parser(self, max_frame: int | None) -> FrameStream:
        return codec.StreamParser("status", max_frame)

    def _identity(self, servo_id: int, data: bytes) -> ServoInfo:
        return ServoInfo(servo_id, data[3] | (data[4] << 8), f"{data[0]}.{data[1]}")

    def _fault_flags(self, servo_id: int, error: int) -> tuple[str, ...]:
        return decode_flags(error, self.table.status_error_bits)

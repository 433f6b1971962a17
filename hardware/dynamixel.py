"""`DynamixelBus`: DYNAMIXEL Protocol 2.0 (X-series control table); the port is the SDK's
`dynamixel_sdk.PortHandler`, the packets are `hardware.protocol.dynamixel2`'s."""

from __future__ import annotations

from typing import Any

import dynamixel_sdk as sdk

from hardware.bus import BusConfig, ServoInfo
from hardware.control_table import (
    DYNAMIXEL_ALERT_BIT,
    DYNAMIXEL_ERROR_NUMBERS,
    DYNAMIXEL_X,
    decode_flags,
)
from hardware.errors import AdapterLost, BusError
from hardware.protocol import dynamixel2 as codec
from hardware.protocol.common import STATUS, FrameStream, Packet
from hardware.sdk_bus import LatencyMixin, SdkServoBus


class DynamixelPortHandler(LatencyMixin, sdk.PortHandler):  # type: ignore[misc]
    """The SDK's PortHandler with a configurable reply allowance."""


class DynamixelBus(SdkServoBus):
    """Dynamixel X-series servos on one Protocol 2.0 bus.

    `port` is a device path (e.g. "/dev/ttyUSB0") or a PortHandler-like object.
    """

    protocol = "dynamixel2"
    default_baudrate = 57_600  # X-series factory setting
    default_reply_gap_s = 0.0005  # X-series factory Return Delay Time: 250 × 2 µs
    status_overhead = 11  # header 4, id, length 2, 0x55, error, CRC 2
    ping_params = 3  # model number (2), firmware version (1)
    identity_span = (0, 7)  # model number at 0 (2 B) ... firmware version at 6
    codec = codec
    sdk = sdk

    def __init__(self, port: Any, config: BusConfig | None = None) -> None:
        super().__init__(port, DYNAMIXEL_X, config)

    def _make_port_handler(self, path: str) -> Any:
        return DynamixelPortHandler(path)

    def _status_parser(self, max_frame: int | None) -> FrameStream:
        return codec.StreamParser(max_frame)

    def _frame_bytes(self, n_params: int) -> int:
        return self.status_overhead + n_params + (n_params + 1) // 3  # worst-case byte stuffing

    def _matches(self, packet: Packet, n_params: int) -> bool:
        if packet.instruction != STATUS:
            return False  # an instruction packet (e.g. our own echo on a loopback): not a reply
        if len(packet.params) == n_params:
            return True
        # an error status (instruction / access / data-length error) carries no data
        return not packet.params and bool((packet.error or 0) & ~DYNAMIXEL_ALERT_BIT)

    def _identity(self, servo_id: int, data: bytes) -> ServoInfo:
        return ServoInfo(servo_id, data[0] | (data[1] << 8), str(data[6]))

    def _fault_flags(self, servo_id: int, error: int) -> tuple[str, ...]:
        flags: list[str] = []
        number = error & ~DYNAMIXEL_ALERT_BIT
        if number:
            flags.append(DYNAMIXEL_ERROR_NUMBERS.get(number, f"error_{number}"))
        if error & DYNAMIXEL_ALERT_BIT:
            reg = self.table["hardware_error"]
            try:
                data, _ = self._read_once(servo_id, reg.addr, reg.size)
                hw = data[0]
            except AdapterLost:
                raise
            except BusError:
                hw = 0
            if hw:
                flags.extend(decode_flags(hw, self.table.hardware_error_bits))
            else:
                flags.append("alert")
        return tuple(flags)

    def reboot(self, servo_id: int) -> None:
        """Reboot one servo (clears latched hardware errors; torque comes back off)."""

        def attempt() -> None:
            self._exchange(codec.reboot(servo_id), {servo_id: 0}, "reboot")

        self._transact(attempt)

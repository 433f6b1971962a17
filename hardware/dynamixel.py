"""`DynamixelBus`: DYNAMIXEL Protocol 2.0 (X-series control table) over `dynamixel_sdk`."""

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
from hardware.sdk_bus import LatencyMixin, SdkServoBus

_PKT_ID = 4
_PKT_INSTRUCTION = 7
_PKT_PARAMETER0 = 8


class DynamixelPortHandler(LatencyMixin, sdk.PortHandler):  # type: ignore[misc]
    """The SDK's PortHandler with a configurable reply allowance."""


class DynamixelBus(SdkServoBus):
    """Dynamixel X-series servos on one Protocol 2.0 bus.

    `port` is a device path (e.g. "/dev/ttyUSB0") or a PortHandler-like object.
    """

    protocol = "dynamixel2"
    default_baudrate = 57_600  # X-series factory setting
    sdk = sdk

    def __init__(self, port: Any, config: BusConfig | None = None) -> None:
        super().__init__(port, DYNAMIXEL_X, config)

    def _make_packet_handler(self) -> Any:
        return sdk.PacketHandler(2.0)

    def _make_port_handler(self, path: str) -> Any:
        return DynamixelPortHandler(path)

    def _ping_once(self, servo_id: int) -> ServoInfo:
        port = self._require_open()
        tx = [0] * 10
        tx[_PKT_ID] = servo_id
        tx[5], tx[6] = 3, 0
        tx[_PKT_INSTRUCTION] = sdk.INST_PING
        rx, result, _ = self.ph.txRxPacket(port, tx)
        self._raise_for(result, servo_id, "ping")
        p = _PKT_PARAMETER0
        model = rx[p + 1] | (rx[p + 2] << 8)
        return ServoInfo(servo_id, model, str(rx[p + 3]))

    def _sync_read_tx(self, port: Any, addr: int, length: int, ids: list[int]) -> int:
        return int(self.ph.syncReadTx(port, addr, length, ids, len(ids), False))

    def _fault_flags(self, servo_id: int, error: int) -> tuple[str, ...]:
        flags: list[str] = []
        number = error & ~DYNAMIXEL_ALERT_BIT
        if number:
            flags.append(DYNAMIXEL_ERROR_NUMBERS.get(number, f"error_{number}"))
        if error & DYNAMIXEL_ALERT_BIT:
            reg = self.table["hardware_error"]
            hw, result, _ = self.ph.read1ByteTxRx(self.port, servo_id, reg.addr)
            if result == sdk.COMM_SUCCESS and hw:
                flags.extend(decode_flags(hw, self.table.hardware_error_bits))
            else:
                flags.append("alert")
        return tuple(flags)

    def reboot(self, servo_id: int) -> None:
        """Reboot one servo (clears latched hardware errors; torque comes back off)."""
        port = self._require_open()

        def attempt() -> None:
            result, _error = self.ph.reboot(port, servo_id)
            self._raise_for(result, servo_id, "reboot")

        self._transact(attempt)

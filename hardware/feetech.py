"""`FeetechBus`: Feetech STS/SMS servos (SCS protocol, little-endian) over `scservo_sdk`."""

from __future__ import annotations

from typing import Any

import scservo_sdk as sdk

from hardware.bus import BusConfig, ServoInfo
from hardware.control_table import FEETECH_STS, decode_flags
from hardware.sdk_bus import LatencyMixin, SdkServoBus

STS_ENDIANNESS = 0  # scservo_sdk "protocol_end": 0 = little-endian (STS/SMS), 1 = SCS


class FeetechPortHandler(LatencyMixin, sdk.PortHandler):  # type: ignore[misc]
    """The SDK's PortHandler with a configurable reply allowance."""


class FeetechBus(SdkServoBus):
    """Feetech STS-series servos on one bus.

    `port` is a device path (e.g. "/dev/ttyACM0") or a PortHandler-like object.
    Note: scservo_sdk's clearPort() only flushes output, so this driver discards stale input
    itself before every transaction (a late reply must not be taken for the next one).
    """

    protocol = "feetech_sts"
    default_baudrate = 1_000_000  # STS factory setting
    sdk = sdk

    def __init__(self, port: Any, config: BusConfig | None = None) -> None:
        super().__init__(port, FEETECH_STS, config)

    def _make_packet_handler(self) -> Any:
        return sdk.PacketHandler(STS_ENDIANNESS)

    def _make_port_handler(self, path: str) -> Any:
        return FeetechPortHandler(path)

    def _transaction_port(self) -> Any:
        port = self._require_open()
        ser = getattr(port, "ser", None)
        if ser is not None:
            ser.reset_input_buffer()
        else:
            port.clearPort()
        return port

    def _ping_once(self, servo_id: int) -> ServoInfo:
        port = self._transaction_port()
        model, result, _ = self.ph.ping(port, servo_id)  # ping + read of Model Number (addr 3)
        self._raise_for(result, servo_id, "ping")
        major = self.table["firmware_major"]
        fw, result, _ = self.ph.readTxRx(port, servo_id, major.addr, 2)
        self._raise_for(result, servo_id, "read firmware")
        return ServoInfo(servo_id, int(model), f"{fw[0]}.{fw[1]}")

    def _sync_read_tx(self, port: Any, addr: int, length: int, ids: list[int]) -> int:
        return int(self.ph.syncReadTx(port, addr, length, ids, len(ids)))

    def _fault_flags(self, servo_id: int, error: int) -> tuple[str, ...]:
        return decode_flags(error, self.table.status_error_bits)

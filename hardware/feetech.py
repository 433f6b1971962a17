"""`FeetechBus`: Feetech STS/SMS servos (SCS protocol, little-endian) over `scservo_sdk`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
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

    def __init__(self, port: Any, config: BusConfig | None = None) -> None:
        super().__init__(port, FEETECH_STS, config)

    def _make_packet_handler(self) -> Any:
        return sdk.PacketHandler(STS_ENDIANNESS)

    def _make_port_handler(self, path: str) -> Any:
        return FeetechPortHandler(path)

    def _result_codes(self) -> dict[str, int]:
        return {
            "success": sdk.COMM_SUCCESS,
            "timeout": sdk.COMM_RX_TIMEOUT,
            "corrupt": sdk.COMM_RX_CORRUPT,
        }

    def _fresh_port(self) -> Any:
        port = self._require_open()
        ser = getattr(port, "ser", None)
        if ser is not None:
            ser.reset_input_buffer()
        else:
            port.clearPort()
        return port

    def _ping_once(self, servo_id: int) -> ServoInfo:
        port = self._fresh_port()
        model, result, _ = self.ph.ping(port, servo_id)  # ping + read of Model Number (addr 3)
        self._raise_for(result, servo_id, "ping")
        major = self.table["firmware_major"]
        fw, result, _ = self.ph.readTxRx(port, servo_id, major.addr, 2)
        self._raise_for(result, servo_id, "read firmware")
        return ServoInfo(servo_id, int(model), f"{fw[0]}.{fw[1]}")

    def _read_once(self, servo_id: int, addr: int, length: int) -> tuple[bytes, int]:
        port = self._fresh_port()
        data, result, error = self.ph.readTxRx(port, servo_id, addr, length)
        self._raise_for(result, servo_id, f"read {addr}+{length}")
        return bytes(data), int(error)

    def _write_once(self, servo_id: int, addr: int, data: bytes) -> int:
        port = self._fresh_port()
        result, error = self.ph.writeTxRx(port, servo_id, addr, len(data), list(data))
        self._raise_for(result, servo_id, f"write {addr}+{len(data)}")
        return int(error)

    def _sync_write_once(self, addr: int, length: int, data: Mapping[int, bytes]) -> None:
        port = self._fresh_port()
        group = sdk.GroupSyncWrite(port, self.ph, addr, length)
        for servo_id, raw in data.items():
            group.addParam(servo_id, list(raw))
        self._raise_for(group.txPacket(), None, f"sync write {addr}+{length}")

    def _sync_read_once(
        self, addr: int, length: int, ids: Sequence[int]
    ) -> dict[int, tuple[bytes, int]]:
        # GroupSyncRead drops each reply's status byte; the packet handler keeps it.
        port = self._fresh_port()
        ids = list(ids)
        result = self.ph.syncReadTx(port, addr, length, ids, len(ids))
        self._raise_for(result, None, f"sync read {addr}+{length}")
        out: dict[int, tuple[bytes, int]] = {}
        for servo_id in ids:
            data, result, error = self.ph.readRx(port, servo_id, length)
            self._raise_for(result, servo_id, f"sync read {addr}+{length}")
            out[servo_id] = (bytes(data), int(error))
        return out

    def _fault_flags(self, servo_id: int, error: int) -> tuple[str, ...]:
        return decode_flags(error, self.table.status_error_bits)

"""Shared plumbing of the vendor-SDK drivers: port ownership, timeouts, result-code mapping.

A driver accepts either a device path (it then creates the SDK's `PortHandler`, subclassed only
to make the reply allowance configurable) or an already-built port object with the
`PortHandler` interface (e.g. `hardware.virtual.VirtualPort`), which it uses as is.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import serial

from hardware.bus import BusConfig, ServoBus
from hardware.control_table import ControlTable
from hardware.errors import BusError, CorruptPacket, NoResponse, PortError


class LatencyMixin:
    """Replaces the SDK's fixed 34 ms USB-latency allowance by `latency_ms` (configurable)."""

    latency_ms: float = 34.0
    packet_start_time: float
    packet_timeout: float
    tx_time_per_byte: float
    getCurrentTime: Callable[[], float]  # provided by the SDK's PortHandler

    def set_latency_ms(self, ms: float) -> None:
        self.latency_ms = ms

    def setPacketTimeout(self, packet_length: int) -> None:
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + self.latency_ms


class SdkServoBus(ServoBus):
    """Port lifecycle and error mapping common to DynamixelBus and FeetechBus."""

    default_baudrate = 1_000_000
    sdk: Any  # the vendor SDK module (dynamixel_sdk or scservo_sdk): same group/result API

    def __init__(self, port: Any, table: ControlTable, config: BusConfig | None) -> None:
        super().__init__(table, config)
        self._port_arg = port
        self.port: Any = None
        self._open = False
        self.ph: Any = self._make_packet_handler()
        self._codes = {
            "success": self.sdk.COMM_SUCCESS,
            "timeout": self.sdk.COMM_RX_TIMEOUT,
            "corrupt": self.sdk.COMM_RX_CORRUPT,
        }
        self._sync_writers: dict[tuple[int, int], Any] = {}

    # -- to provide ------------------------------------------------------------------------------
    def _make_packet_handler(self) -> Any:
        raise NotImplementedError

    def _make_port_handler(self, path: str) -> Any:
        raise NotImplementedError

    def _sync_read_tx(self, port: Any, addr: int, length: int, ids: list[int]) -> int:
        """Send the SDK's sync-read instruction (signatures differ per vendor)."""
        raise NotImplementedError

    def _transaction_port(self) -> Any:
        """The open port, ready for a request/reply transaction."""
        return self._require_open()

    # -- primitives shared by both SDKs ------------------------------------------------------------
    def _read_once(self, servo_id: int, addr: int, length: int) -> tuple[bytes, int]:
        port = self._transaction_port()
        data, result, error = self.ph.readTxRx(port, servo_id, addr, length)
        self._raise_for(result, servo_id, f"read {addr}+{length}")
        return bytes(data), int(error)

    def _write_once(self, servo_id: int, addr: int, data: bytes) -> int:
        port = self._transaction_port()
        result, error = self.ph.writeTxRx(port, servo_id, addr, len(data), list(data))
        self._raise_for(result, servo_id, f"write {addr}+{len(data)}")
        return int(error)

    def _sync_write_once(self, addr: int, length: int, data: Mapping[int, bytes]) -> None:
        port = self._transaction_port()
        group = self._sync_writers.get((addr, length))
        if group is None or group.port is not port:
            group = self.sdk.GroupSyncWrite(port, self.ph, addr, length)
            self._sync_writers[(addr, length)] = group
        group.clearParam()
        for servo_id, raw in data.items():
            group.addParam(servo_id, list(raw))
        self._raise_for(group.txPacket(), None, f"sync write {addr}+{length}")

    def _sync_read_once(
        self, addr: int, length: int, ids: Sequence[int]
    ) -> dict[int, tuple[bytes, int]]:
        # The SDKs' GroupSyncRead drops each reply's error/status byte; the packet handler
        # keeps it, so the drivers send the instruction and receive each reply themselves.
        port = self._transaction_port()
        ids = list(ids)
        self._raise_for(self._sync_read_tx(port, addr, length, ids), None,
                        f"sync read {addr}+{length}")
        out: dict[int, tuple[bytes, int]] = {}
        for servo_id in ids:
            data, result, error = self.ph.readRx(port, servo_id, length)
            self._raise_for(result, servo_id, f"sync read {addr}+{length}")
            out[servo_id] = (bytes(data), int(error))
        return out

    # -- lifecycle -------------------------------------------------------------------------------
    @property
    def port_name(self) -> str:
        if isinstance(self._port_arg, str):
            return self._port_arg
        return str(getattr(self._port_arg, "port_name", type(self._port_arg).__name__))

    @property
    def is_open(self) -> bool:
        return self._open

    def open(self) -> None:
        if self._open:
            return
        port = self._port_arg
        if isinstance(port, str):
            port = self._make_port_handler(port)
            port.baudrate = self.config.baudrate or self.default_baudrate
            try:
                ok = port.openPort()
            except (serial.SerialException, OSError, ValueError) as exc:
                raise PortError(self.port_name, f"cannot open: {exc}") from None
            if not ok:
                raise PortError(self.port_name, f"unsupported baud rate {port.baudrate}")
        else:
            if not getattr(port, "is_open", False) and not port.openPort():
                raise PortError(self.port_name, "cannot open")
            if self.config.baudrate is not None and not port.setBaudRate(self.config.baudrate):
                raise PortError(self.port_name, f"unsupported baud rate {self.config.baudrate}")
        if hasattr(port, "set_latency_ms"):
            port.set_latency_ms(self.config.timeout_s * 1000.0)
        self.port = port
        self._open = True

    def close(self) -> None:
        if self._open and self.port is not None:
            try:
                self.port.closePort()
            finally:
                self._open = False

    # -- helpers for the primitives ---------------------------------------------------------------
    def _require_open(self) -> Any:
        if not self._open:
            raise PortError(self.port_name, "bus is not open")
        self.port.is_using = False  # a previous exception must not leave the port "busy"
        return self.port

    def _raise_for(self, result: int, servo_id: int | None, what: str) -> None:
        codes = self._codes
        if result == codes["success"]:
            return
        text = self.ph.getTxRxResult(result)
        if result == codes["timeout"]:
            raise NoResponse(-1 if servo_id is None else servo_id, 1, f"{what}: {text}")
        if result == codes["corrupt"]:
            raise CorruptPacket(f"{what}: {text}", servo_id)
        raise BusError(f"{what} (servo {servo_id}): SDK result {result} {text}")

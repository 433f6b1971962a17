"""`DynamixelBus`: DYNAMIXEL Protocol 2.0 (X-series control table) and `Dynamixel1Bus`:
Protocol 1.0 (AX / MX control table); the port is the SDK's `dynamixel_sdk.PortHandler`, the
packets are `hardware.bus.protocol.dynamixel2`'s / `.dynamixel1`'s."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import dynamixel_sdk as sdk

from hardware.bus.control_table import (
    DYNAMIXEL1_BULK_READ_MODELS,
    DYNAMIXEL_ALERT_BIT,
    DYNAMIXEL_AX,
    DYNAMIXEL_ERROR_NUMBERS,
    DYNAMIXEL_X,
    Register,
    decode_flags,
)
from hardware.bus.protocol import dynamixel1 as p1
from hardware.bus.protocol import dynamixel2 as codec
from hardware.bus.protocol.common import STATUS, FrameStream, Packet
from hardware.bus.sdk_bus import LatencyMixin, SdkServoBus
from hardware.bus.servo_bus import BusConfig, ServoInfo, ServoStatus
from hardware.errors import AdapterLost, BusError, ServoFault


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


class Dynamixel1Bus(SdkServoBus):
    """Dynamixel AX / MX servos on one Protocol 1.0 bus (AX-12A, AX-18A, MX-28 in 1.0...).

    The port is the SDK's `PortHandler` (or a PortHandler-like object); packets are
    `hardware.bus.protocol.dynamixel1`'s, transactions the shared engine's (`hardware.bus.sdk_bus`).
    Protocol 1.0 has no SYNC READ: several servos are read with one BULK READ when every one of
    them answers it (MX / EX models, learnt from their model number at ping), else with one
    READ per servo. There is no hardware-error register either: the status packet's error byte
    carries the health bits (input voltage, overheating, overload) while the condition lasts.
    The servos must answer every instruction (Status Return Level 2, the factory setting): ping
    checks it, since at 0 or 1 every acknowledged write would look like a lost reply.
    """

    protocol = "dynamixel1"
    default_baudrate = 1_000_000  # AX / MX factory setting (Baud Rate 1)
    default_reply_gap_s = 0.0005  # factory Return Delay Time: 250 × 2 µs
    status_overhead = p1.STATUS_OVERHEAD
    ping_params = 0
    identity_span = (0, 17)  # model number 0 (2 B), firmware 2, ..., Status Return Level 16
    codec = p1
    sdk = sdk

    def __init__(self, port: Any, config: BusConfig | None = None) -> None:
        super().__init__(port, DYNAMIXEL_AX, config)
        self.models: dict[int, int] = {}  # model number per servo id, learnt at ping

    def _make_port_handler(self, path: str) -> Any:
        return DynamixelPortHandler(path)

    def _status_parser(self, max_frame: int | None) -> FrameStream:
        return p1.StreamParser("status", max_frame)

    def _matches(self, packet: Packet, n_params: int) -> bool:
        if len(packet.params) == n_params:
            return True
        # a refused instruction (range / instruction error) is answered without data
        return not packet.params and bool((packet.error or 0) & p1.COMMAND_ERRORS)

    def _identity(self, servo_id: int, data: bytes) -> ServoInfo:
        level = data[16]
        if level != 2:
            raise ServoFault(
                servo_id,
                (
                    f"status_return_level {level} (needs 2, the factory setting: at {level} "
                    "writes are not acknowledged; set address 16 to 2)",
                ),
                0,
            )
        model = data[0] | (data[1] << 8)
        self.models[servo_id] = model
        return ServoInfo(servo_id, model, str(data[2]))

    def _fault_flags(self, servo_id: int, error: int) -> tuple[str, ...]:
        return decode_flags(error, self.table.status_error_bits)

    def bulk_read_ok(self, ids: Iterable[int]) -> bool:
        """Whether one BULK READ can serve `ids`: every one pinged and of a model that has it."""
        return all(self.models.get(i) in DYNAMIXEL1_BULK_READ_MODELS for i in ids)

    def _read_request(self, ids: list[int], start: int, n: int) -> bytes:
        if len(ids) == 1:
            return p1.read(ids[0], start, n)
        return p1.bulk_read((i, start, n) for i in ids)

    def _sync_read_once(
        self, addr: int, length: int, ids: Sequence[int]
    ) -> dict[int, tuple[bytes, int]]:
        ids = list(ids)
        if len(ids) > 1 and self.bulk_read_ok(ids):
            return super()._sync_read_once(addr, length, ids)
        return {i: self._read_once(i, addr, length) for i in ids}

    def read_status(self, ids: Sequence[int]) -> dict[int, ServoStatus]:
        """Load, voltage, temperature (one read of addresses 40-43 per servo, or one bulk read)
        and the health bits of the status packets' error byte (never raises ServoFault)."""
        load, volt, temp = (
            self.table[n] for n in ("present_load", "present_voltage", "present_temperature")
        )
        lo, hi = load.addr, temp.addr + temp.size
        ids = list(ids)
        if not ids:
            return {}
        got = self._transact(lambda: self._sync_read_once(lo, hi - lo, ids))
        out = {}
        for i in ids:
            data, error = got[i]

            def value(reg: Register, data: bytes = data) -> int:
                return reg.decode(data[reg.addr - lo : reg.addr - lo + reg.size])

            out[i] = ServoStatus(
                servo_id=i,
                load_pct=load.to_physical(value(load)),
                voltage_v=volt.to_physical(value(volt)),
                temperature_c=temp.to_physical(value(temp)),
                error_flags=decode_flags(error, self.table.status_error_bits),
                error_raw=error,
            )
        return out

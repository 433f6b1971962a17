"""The transaction engine of the vendor-SDK drivers: port ownership, request/reply matching,
deadlines, late-reply bookkeeping and error mapping.

A driver accepts either a device path (it then creates the SDK's `PortHandler`, which owns the
serial device and its baud-rate setup) or an already-built port object with the `PortHandler`
interface (e.g. `hardware.virtual.VirtualPort`), which it uses as is. Packets are built and
parsed by `hardware.protocol` (checked against the vendors' manuals); the SDKs' packet
handlers are not used for transactions, because they match a reply by servo id only, take a
late reply for the current one, and index short replies (`IndexError` in scservo_sdk's ping).

One attempt (`_exchange`):

1. drain: whatever arrived since the last attempt (late replies) is read and discarded — the
   SDKs' `clearPort` does not do this for Feetech (it flushes output only); at most
   `timeout_s` of time, so a babbling line cannot stall it;
2. send the request; its deadline is the wire time of the request and of every expected reply
   at the port's baud rate, plus `BusConfig.timeout_s`, plus the USB adapter's latency timer
   when the kernel exposes one (`usb_latency_timer_s`), plus `reply_gap_s` per reply;
3. read until every expected reply is in or the deadline passes. A reply is taken only if its
   servo id, packet type (Protocol 2.0 status instruction 0x55) and parameter count match the
   request; anything else is a stray (late, or for someone else) and is discarded.

Late replies: a status packet carries no register address, so a reply that missed its
deadline could later pass for the answer to another request to the same servo with the same
reply length. The engine remembers every reply it gave up on as (servo id, parameter count);
a stray that matches one cancels it, and so does a later reply of the same servo taken as an
answer (a servo answers its requests in order and the serial stream is FIFO, so once it has
answered a later request an earlier reply can no longer come: it was lost). While one is
outstanding, a read that would expect that same signature reads one more byte (or more; the
span moves down at the end of the control table) and keeps only the bytes asked for, so the
two cannot be confused. A write whose acknowledgement could be a late one is confirmed by
reading the register back. A reply later than `BusConfig.late_reply_horizon_s`, or more than
`MAX_LATE_PER_SERVO` attempts late, is assumed not to exist.

Port failures (OSError / serial.SerialException from read, write or wait, or the port closed
under us) raise `AdapterLost`; after one, every call raises it again until `close()` + `open()`.
"""

from __future__ import annotations

import os
import select
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import serial

from hardware.bus import MAX_BAUD, MIN_BAUD, BusConfig, ServoBus, ServoInfo
from hardware.control_table import ControlTable
from hardware.errors import AdapterLost, CorruptPacket, NoResponse, PortError, ServoFault
from hardware.protocol.common import FrameStream, Packet

T = TypeVar("T")
MAX_EXTRA_BYTES = 32  # how far a read may be lengthened to dodge outstanding late replies
# Outstanding replies remembered per servo, oldest forgotten first. One fewer than the read
# lengths on offer, so a servo that has stopped answering (each failed attempt leaves one) can
# always be asked again and is not locked out when it comes back. The price: a reply more than
# that many attempts late (≥ 0.1 s at a 100 Hz tick) could pass for a later answer of the same
# length — a real adapter is late by milliseconds; the virtual bus's delay fault can be more.
MAX_LATE_PER_SERVO = MAX_EXTRA_BYTES
DRAIN_PARSE_BYTES = 1024  # stale input parsed before a request (late replies cancel debts)
DRAIN_LIMIT_BYTES = 1 << 16  # at most this much more is read and dropped unparsed
READ_CHUNK = 512  # bytes per read: bounds the parsing work between two deadline checks
PORT_ERRORS = (OSError, serial.SerialException)
USB_SERIAL_SYSFS = Path("/sys/bus/usb-serial/devices")
MAX_ADAPTER_LATENCY_S = 0.255  # the FTDI latency timer is one byte of milliseconds


def usb_latency_timer_s(device: str, sysfs: Path = USB_SERIAL_SYSFS) -> float:
    """The USB-serial adapter's latency timer [s] for `device` (e.g. /dev/ttyUSB0, or a
    /dev/serial/by-id link to it), 0 when the kernel exposes none (pty, CDC-ACM, in-process).

    An FTDI adapter (ROBOTIS U2D2, most Feetech boards' FT232) holds received bytes up to this
    long (default 16 ms) before handing them to the host, so a reply allowance that ignores it
    makes every read time out. The drivers add it to `BusConfig.timeout_s`.
    """
    name = os.path.basename(os.path.realpath(device))
    try:
        ms = float((sysfs / name / "latency_timer").read_text().strip())
    except (OSError, ValueError):
        return 0.0
    return min(max(ms, 0.0), MAX_ADAPTER_LATENCY_S * 1000.0) / 1000.0


class LatencyMixin:
    """Replaces the SDK's fixed 34 ms USB-latency allowance by `latency_ms` (configurable), for
    code that still drives the SDK's packet handler on our port handlers."""

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


@dataclass(frozen=True)
class _Late:
    """A reply given up on that may still arrive: (servo id, parameter count) until `until_s`;
    `exchange` numbers the attempt that gave up on it."""

    servo_id: int
    n_params: int
    until_s: float
    exchange: int


class SdkServoBus(ServoBus):
    """Port lifecycle, transactions and error mapping common to DynamixelBus and FeetechBus."""

    default_baudrate = 1_000_000
    default_reply_gap_s = 0.0
    status_overhead = 6  # bytes of a status frame without parameters
    ping_params = 0  # parameters of a ping's status packet
    identity_span = (0, 1)  # (addr, length) read to learn model number and firmware
    codec: Any  # hardware.protocol.dynamixel2 or .feetech: ping/read/write/sync_* builders
    sdk: Any  # the vendor SDK module (its PortHandler opens device paths)

    def __init__(self, port: Any, table: ControlTable, config: BusConfig | None) -> None:
        super().__init__(table, config)
        self._port_arg = port
        self.port: Any = None
        self._open = False
        self._lost: AdapterLost | None = None
        self._late: list[_Late] = []
        self._exchanges = 0
        self.adapter_latency_s = 0.0  # USB latency timer of a device path (see open)
        gap = self.config.reply_gap_s
        self.reply_gap_s = self.default_reply_gap_s if gap is None else gap

    # -- to provide ------------------------------------------------------------------------------
    def _make_port_handler(self, path: str) -> Any:
        raise NotImplementedError

    def _status_parser(self, max_frame: int | None) -> FrameStream:
        raise NotImplementedError

    def _matches(self, packet: Packet, n_params: int) -> bool:
        """Whether `packet` has the shape of the status expected (parameter count `n_params`)."""
        return len(packet.params) == n_params

    def _identity(self, servo_id: int, data: bytes) -> ServoInfo:
        raise NotImplementedError

    def _frame_bytes(self, n_params: int) -> int:
        """Longest status frame with `n_params` parameters (byte stuffing included)."""
        return self.status_overhead + n_params

    # -- primitives --------------------------------------------------------------------------------
    def _ping_once(self, servo_id: int) -> ServoInfo:
        self._exchange(self.codec.ping(servo_id), {servo_id: self.ping_params}, "ping")
        addr, length = self.identity_span  # the ping's status proves presence; the identity
        data, _ = self._read_once(servo_id, addr, length)  # comes from a guarded read
        return self._identity(servo_id, data)

    def _read_once(self, servo_id: int, addr: int, length: int) -> tuple[bytes, int]:
        return self._guarded_read([servo_id], addr, length, f"read {addr}+{length}")[servo_id]

    def _write_once(self, servo_id: int, addr: int, data: bytes) -> int:
        what = f"write {addr}+{len(data)}"
        ambiguous = self._outstanding(servo_id, 0)
        got = self._exchange(self.codec.write(servo_id, addr, data), {servo_id: 0}, what)
        if not ambiguous:
            return int(got[servo_id].error or 0)
        back, error = self._read_once(servo_id, addr, len(data))
        if back != bytes(data):
            raise CorruptPacket(
                f"{what}: the acknowledgement may be a late reply and the register reads back "
                f"{back.hex(' ')} instead of {bytes(data).hex(' ')}",
                servo_id,
            )
        return error

    def _sync_write_once(self, addr: int, length: int, data: Mapping[int, bytes]) -> None:
        self._exchange(self.codec.sync_write(addr, length, data), {}, f"sync write {addr}+{length}")

    def _sync_read_once(
        self, addr: int, length: int, ids: Sequence[int]
    ) -> dict[int, tuple[bytes, int]]:
        return self._guarded_read(list(ids), addr, length, f"sync read {addr}+{length}")

    def _guarded_read(
        self, ids: list[int], addr: int, length: int, what: str
    ) -> dict[int, tuple[bytes, int]]:
        """Read [addr, addr+length) from `ids` (one READ, or one SYNC_READ for several), with a
        reply length no outstanding late reply of these servos has."""
        self._expire()
        start, n, offset = self._read_plan(ids, addr, length, what)
        request = (  # one servo: a READ; several: one SYNC_READ
            self.codec.read(ids[0], start, n)
            if len(ids) == 1
            else self.codec.sync_read(start, n, ids)
        )
        got = self._exchange(request, {i: n for i in ids}, what)
        out: dict[int, tuple[bytes, int]] = {}
        for i in ids:
            p = got[i]
            error = int(p.error or 0)
            if len(p.params) != n:  # an error status without data (Dynamixel access error...)
                raise ServoFault(i, self._fault_flags(i, error), error)
            out[i] = (bytes(p.params[offset : offset + length]), error)
        return out

    def _read_plan(
        self, ids: Iterable[int], addr: int, length: int, what: str
    ) -> tuple[int, int, int]:
        """(start, n, offset): read n bytes at start, the wanted ones begin at offset."""
        ids = set(ids)
        taken = {e.n_params for e in self._late if e.servo_id in ids}
        for n in range(length, length + MAX_EXTRA_BYTES + 1):
            if n in taken:
                continue
            start = min(addr, self.table.size - n)
            if start < 0:
                break
            return start, n, addr - start
        # every length is taken by replies still owed: by a servo that has stopped answering
        # (each failed attempt leaves one) or by a line so late nothing can be told apart
        owed = {i: sum(e.servo_id == i for e in self._late) for i in ids}
        worst = max(sorted(owed), key=lambda i: owed[i])
        raise NoResponse(
            worst,
            1,
            f"{what}: {owed[worst]} earlier replies still owed (it has not answered since); "
            "a late one could not be told from this one, so nothing was sent",
        )

    # -- the engine -----------------------------------------------------------------------------
    def _exchange(self, request: bytes, expects: Mapping[int, int], what: str) -> dict[int, Packet]:
        """One attempt: drain, send `request`, collect one matching status per servo in
        `expects` ({servo id: parameter count}) before the deadline; raises NoResponse /
        CorruptPacket (and remembers the missing replies as possibly late) or AdapterLost."""
        port = self._io_port(what)
        self._expire()
        self._drain(port)
        self._exchanges += 1
        number = self._exchanges
        # a reply taken where a late one of the same shape was outstanding may be that late one:
        # then its own is still to come, so the count of outstanding replies stays as it is
        ambiguous = {i for i, n in expects.items() if self._outstanding(i, n)}
        budget = self._budget_s(len(request), expects.values())
        self._counts["budget_s"] += self.config.timeout_s  # what the drain may take
        t0 = time.monotonic()
        self._send(port, request, what)
        if not expects:
            return {}
        self._counts["budget_s"] += budget
        deadline = t0 + budget
        # frames much longer than any expected one are impossible (false headers in noise);
        # strays of other lengths (e.g. late replies to a longer read) still parse
        parser = self._status_parser(max(self._frame_bytes(n) for n in expects.values()) + 64)
        got: dict[int, Packet] = {}
        strays: list[str] = []
        last_look = False
        while True:
            data = self._read_port(port, what)
            for p in parser.feed(data) if data else ():
                n = expects.get(p.servo_id)
                if n is not None and p.servo_id not in got and self._matches(p, n):
                    got[p.servo_id] = p
                    if p.servo_id not in ambiguous:
                        self._answered(p.servo_id, number)
                else:
                    strays.append(f"servo {p.servo_id} with {len(p.params)} byte(s)")
                    self._stray(p)
            if len(got) == len(expects):
                return got
            if last_look:
                break
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                last_look = True  # one more read: a reply may have come in while we slept
            elif not data:
                self._wait(port, remaining, what)
        missing = [i for i in expects if i not in got]
        until = time.monotonic() + self.config.late_reply_horizon_s
        self._late.extend(_Late(i, expects[i], until, number) for i in missing)
        self._cap_late(missing)
        ignored = (
            f"; ignored {len(strays)} stray repl(ies): {', '.join(strays[:3])}" if strays else ""
        )
        if parser.corrupt or parser.buffered:
            raise CorruptPacket(
                f"{what}: {parser.corrupt} bad frame(s), {parser.buffered} byte(s) of an "
                f"incomplete one by the {budget * 1e3:.1f} ms deadline{ignored}",
                missing[0],
            )
        raise NoResponse(missing[0], 1, f"{what}: no reply within {budget * 1e3:.1f} ms{ignored}")

    def _budget_s(self, request_bytes: int, reply_params: Iterable[int]) -> float:
        per_byte = 10.0 / self._baud()  # 8N1: 10 bits per byte
        replies = list(reply_params)
        wire = request_bytes + sum(self._frame_bytes(n) for n in replies)
        allowance = self.config.timeout_s + self.adapter_latency_s
        return wire * per_byte + allowance + self.reply_gap_s * len(replies)

    def _baud(self) -> float:
        try:
            baud = float(self.port.getBaudRate())
        except Exception:  # a port object without the accessor: the configured one
            baud = float(self.config.baudrate or self.default_baudrate)
        return min(max(baud, MIN_BAUD), MAX_BAUD)

    def _outstanding(self, servo_id: int, n_params: int) -> bool:
        self._expire()
        return any(e.servo_id == servo_id and e.n_params == n_params for e in self._late)

    def _expire(self) -> None:
        if self._late:
            now = time.monotonic()
            self._late = [e for e in self._late if e.until_s > now]

    def _answered(self, servo_id: int, exchange: int) -> None:
        """Servo `servo_id` answered in `exchange`: its earlier outstanding replies are lost."""
        if self._late:
            self._late = [e for e in self._late if e.servo_id != servo_id or e.exchange >= exchange]

    def _cap_late(self, ids: Iterable[int]) -> None:
        for i in set(ids):
            mine = [k for k, e in enumerate(self._late) if e.servo_id == i]
            for k in reversed(mine[:-MAX_LATE_PER_SERVO] if len(mine) > MAX_LATE_PER_SERVO else []):
                del self._late[k]

    def _stray(self, p: Packet) -> None:
        """A well-formed reply nobody is waiting for: if it is one given up on, forget it."""
        self._counts["stray"] += 1
        for k, e in enumerate(self._late):
            if e.servo_id == p.servo_id and e.n_params == len(p.params):
                del self._late[k]
                return

    def _drain(self, port: Any) -> None:
        """Read what came in since the last attempt: late replies are parsed (and cancel what
        they were owed for); beyond `DRAIN_PARSE_BYTES` it is noise, dropped unparsed. Bounded
        by bytes and by `timeout_s` of time, so a babbling line cannot stall a call here."""
        parser = self._status_parser(None)
        total = 0
        stop_at = time.monotonic() + self.config.timeout_s
        while total < DRAIN_LIMIT_BYTES and time.monotonic() < stop_at:
            data = self._read_port(port, "drain")
            if not data:
                return
            if total < DRAIN_PARSE_BYTES:
                for p in parser.feed(data):
                    self._stray(p)
            total += len(data)

    # -- port I/O (every OS error becomes AdapterLost) ------------------------------------------
    def _io_port(self, what: str) -> Any:
        port = self._require_open()
        if self._lost is not None:
            raise AdapterLost(self.port_name, what, self._lost.os_error)
        if not getattr(port, "is_open", True):
            self._adapter_lost(what, "the port was closed while in use")
        return port

    def _adapter_lost(self, what: str, error: BaseException | str) -> None:
        self._lost = AdapterLost(self.port_name, what, error)
        raise AdapterLost(self.port_name, what, error)

    def _send(self, port: Any, request: bytes, what: str) -> None:
        try:
            written = port.writePort(bytes(request))
        except PORT_ERRORS as exc:
            self._adapter_lost(f"{what} (write)", exc)
        if written != len(request):
            self._adapter_lost(f"{what} (write)", f"wrote {written} of {len(request)} bytes")

    def _read_port(self, port: Any, what: str) -> bytes:
        try:
            return bytes(port.readPort(READ_CHUNK) or b"")
        except PORT_ERRORS as exc:
            self._adapter_lost(f"{what} (read)", exc)
        return b""  # pragma: no cover - _adapter_lost raises

    def _wait(self, port: Any, timeout_s: float, what: str) -> None:
        """Block until input may be there, at most `timeout_s` (and never long: re-check often)."""
        timeout_s = min(timeout_s, 0.005)
        try:
            waiter = getattr(port, "wait_for_input", None)
            if waiter is not None:
                waiter(timeout_s)
                return
            ser = getattr(port, "ser", None)
            fileno = getattr(ser, "fileno", None)
            if fileno is not None:
                select.select([fileno()], [], [], timeout_s)
                return
        except PORT_ERRORS as exc:
            self._adapter_lost(f"{what} (wait)", exc)
        except ValueError as exc:  # select on a closed file descriptor
            self._adapter_lost(f"{what} (wait)", exc)
        time.sleep(min(timeout_s, 0.0002))

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
            self.adapter_latency_s = usb_latency_timer_s(self._port_arg)
        else:
            try:
                if not getattr(port, "is_open", False) and not port.openPort():
                    raise PortError(self.port_name, "cannot open")
                if self.config.baudrate is not None and not port.setBaudRate(self.config.baudrate):
                    raise PortError(self.port_name, f"unsupported baud rate {self.config.baudrate}")
            except PORT_ERRORS as exc:
                raise PortError(self.port_name, f"cannot open: {exc}") from None
        self.port = port
        self._open = True
        self._lost = None
        self._late = []

    def close(self) -> None:
        """Close the port; idempotent, and quiet when the adapter is already gone."""
        if self._open and self.port is not None:
            try:
                self.port.closePort()
            except PORT_ERRORS:
                pass  # unplugged: nothing left to close
            finally:
                self._open = False

    def _require_open(self) -> Any:
        if not self._open:
            raise PortError(self.port_name, "bus is not open")
        return self.port

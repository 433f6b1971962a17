"""`ServoBus`: the abstract servo bus every driver (and the player) speaks.

A concrete driver implements five single-shot primitives on raw bytes (`_ping_once`,
`_read_once`, `_write_once`, `_sync_write_once`, `_sync_read_once`); this class adds register
encoding from the family's `ControlTable`, fault decoding, and retries with a counted budget.

Retries: every transaction is tried at most `1 + BusConfig.retries` times; only `NoResponse`
and `CorruptPacket` are retried (a `ServoFault` is an answer, not a transmission error; an
`AdapterLost` means the port itself is gone). Each attempt is bounded by its own deadline (the
wire time of the request and of the expected replies at the port's baud rate, plus
`BusConfig.timeout_s`, plus `reply_gap_s` per reply) and by `timeout_s` for draining stale
input before it; `BusStats.budget_s` sums those, so a caller knows the longest a call can
take: (1 + retries) · (per-attempt deadline + timeout_s).

Inputs are bounded: non-finite or absurd timeouts, baud rates, retries and servo ids raise
`InvalidSetting` (a `ValueError`) with one line naming the setting.
"""

from __future__ import annotations

import math
import operator
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import TypeVar

from hardware.control_table import ControlTable, Register, decode_flags
from hardware.errors import (
    AdapterLost,
    BusError,
    CorruptPacket,
    InvalidSetting,
    NoResponse,
    ServoFault,
)

T = TypeVar("T")

MAX_SERVO_ID = 252
MAX_TIMEOUT_S = 10.0  # a reply allowance above this is a typo (ms given as s), not a bus
MIN_BAUD, MAX_BAUD = 1_200, 12_000_000  # slowest UART to the fastest X-series / USB adapters
MAX_RETRIES = 100
MAX_REPLY_GAP_S = 0.01  # Dynamixel Return Delay Time tops out at 508 µs; 10 ms is generous


def bounded(what: str, value: float, lo: float, hi: float, unit: str = "") -> float:
    """`value` as a float if finite and in [lo, hi]; else InvalidSetting naming `what`."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InvalidSetting(what, f"{value!r} is not a number") from None
    if not math.isfinite(x) or not lo <= x <= hi:
        raise InvalidSetting(what, f"{value!r} is outside [{lo:g}, {hi:g}]{unit}")
    return x


def bounded_int(what: str, value: object, lo: int, hi: int) -> int:
    """`value` as an int if it is an integer in [lo, hi]; else InvalidSetting naming `what`."""
    try:
        n = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise InvalidSetting(what, f"{value!r} is not an integer") from None
    if not lo <= n <= hi:
        raise InvalidSetting(what, f"{n} is outside {lo}..{hi}")
    return int(n)


@dataclass(frozen=True)
class BusConfig:
    """Transport settings shared by every driver.

    timeout_s: reply allowance per attempt beyond the wire time of request and replies [s]
        (covers the servo's processing and OS scheduling; a USB adapter's latency timer is
        added by the drivers). Default 10 ms: a pty round trip to the virtual bus is 0.4 ms
        typical, 0.7 ms p99, but on a loaded 2-core machine a 1 ms sleep overshot by up to
        12 ms (measured); at 3 ms a quad12 gait over the pty lost 0-3 reads per run and one
        run in six stopped on an unconfirmed torque-on, at 10 ms none (6 runs each).
    retries: extra attempts after a NoResponse / CorruptPacket (0 = try once).
    baudrate: serial speed [bit/s]; None = the port's current / the driver's default.
    raise_on_fault: raise ServoFault when a reply carries hardware-error flags.
    reply_gap_s: extra allowance per expected reply [s] (the servos' Return Delay Time: in a
        sync read each servo waits for the one before it); None = the driver's default.
    late_reply_horizon_s: how long a reply that missed its deadline may still turn up [s]; for
        that long (or until the servo answers a later request) the driver keeps it from being
        taken for the answer to a later request (see `hardware.sdk_bus`). Real late replies
        come from USB latency and scheduling (milliseconds); the default 60 s covers the
        longest delay the virtual bus injects (`FaultPlan.delay_s` ≤ 60 s).
    """

    timeout_s: float = 0.010
    retries: int = 1
    baudrate: int | None = None
    raise_on_fault: bool = True
    reply_gap_s: float | None = None
    late_reply_horizon_s: float = 60.0

    def __post_init__(self) -> None:
        bounded("timeout_s", self.timeout_s, 1e-6, MAX_TIMEOUT_S, " s")
        if not self.timeout_s > 0:
            raise InvalidSetting("timeout_s", f"{self.timeout_s!r} must be positive")
        bounded_int("retries", self.retries, 0, MAX_RETRIES)
        if self.baudrate is not None:
            bounded_int("baudrate", self.baudrate, MIN_BAUD, MAX_BAUD)
        if self.reply_gap_s is not None:
            bounded("reply_gap_s", self.reply_gap_s, 0.0, MAX_REPLY_GAP_S, " s")
        bounded("late_reply_horizon_s", self.late_reply_horizon_s, 0.0, 3600.0, " s")


@dataclass(frozen=True)
class ServoInfo:
    """What a ping tells about one servo."""

    servo_id: int
    model_number: int
    firmware: str


@dataclass(frozen=True)
class ServoStatus:
    """Health of one servo: load [% of max, signed], voltage [V], temperature [°C], error flags."""

    servo_id: int
    load_pct: float
    voltage_v: float
    temperature_c: float
    error_flags: tuple[str, ...]
    error_raw: int


@dataclass(frozen=True)
class BusStats:
    """Counters since the bus was created (attempt-level: one retry = one more attempt)."""

    transactions: int = 0
    attempts: int = 0
    retries: int = 0
    no_response: int = 0
    corrupt: int = 0
    faults: int = 0
    failures: int = 0  # transactions that raised after exhausting their retries
    stray: int = 0  # well-formed replies that answered something else (late, other id/length)
    adapter_lost: int = 0
    budget_s: float = 0.0  # sum of the attempts' deadlines [s]: the longest the calls could take


class ServoBus(ABC):
    """A half-duplex servo bus: open/close, ping/scan, torque, sync write/read, status."""

    protocol: str = ""

    def __init__(self, table: ControlTable, config: BusConfig | None = None) -> None:
        self.table = table
        self.config = config or BusConfig()
        self._counts: dict[str, float] = {f: 0 for f in BusStats.__dataclass_fields__}

    # -- lifecycle ------------------------------------------------------------------------
    @abstractmethod
    def open(self) -> None:
        """Open the port (raises PortError)."""

    @abstractmethod
    def close(self) -> None:
        """Close the port; idempotent."""

    @property
    @abstractmethod
    def is_open(self) -> bool: ...

    def __enter__(self) -> ServoBus:
        if not self.is_open:
            self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- primitives (one attempt, raw bytes) -----------------------------------------------
    @abstractmethod
    def _ping_once(self, servo_id: int) -> ServoInfo: ...

    @abstractmethod
    def _read_once(self, servo_id: int, addr: int, length: int) -> tuple[bytes, int]:
        """Read `length` bytes at `addr`; returns (data, status error byte)."""

    @abstractmethod
    def _write_once(self, servo_id: int, addr: int, data: bytes) -> int:
        """Write `data` at `addr` and wait for the status; returns the status error byte."""

    @abstractmethod
    def _sync_write_once(self, addr: int, length: int, data: Mapping[int, bytes]) -> None:
        """Broadcast one sync-write (no replies)."""

    @abstractmethod
    def _sync_read_once(
        self, addr: int, length: int, ids: Sequence[int]
    ) -> dict[int, tuple[bytes, int]]:
        """Sync-read `length` bytes at `addr` from `ids`: {id: (data, status error byte)}."""

    @abstractmethod
    def _fault_flags(self, servo_id: int, error: int) -> tuple[str, ...]:
        """Decode a non-zero status error byte into flag names (may query the servo)."""

    # -- retry machinery --------------------------------------------------------------------
    @property
    def stats(self) -> BusStats:
        c = self._counts
        return BusStats(**{k: (v if k == "budget_s" else int(v)) for k, v in c.items()})  # type: ignore[arg-type]

    def _transact(self, attempt: Callable[[], T], retries: int | None = None) -> T:
        budget = self.config.retries if retries is None else retries
        self._counts["transactions"] += 1
        last: BusError | None = None
        for n in range(budget + 1):
            self._counts["attempts"] += 1
            if n:
                self._counts["retries"] += 1
            try:
                return attempt()
            except NoResponse as exc:
                self._counts["no_response"] += 1
                last = NoResponse(exc.servo_id, n + 1, exc.detail)
            except CorruptPacket as exc:
                self._counts["corrupt"] += 1
                last = CorruptPacket(exc.detail, exc.servo_id, n + 1)
            except ServoFault:
                self._counts["faults"] += 1
                self._counts["failures"] += 1
                raise
            except AdapterLost:
                self._counts["adapter_lost"] += 1
                self._counts["failures"] += 1
                raise
        self._counts["failures"] += 1
        assert last is not None
        raise last

    def _check(self, servo_id: int, error: int) -> None:
        if error and self.config.raise_on_fault:
            flags = self._fault_flags(servo_id, error)
            raise ServoFault(servo_id, flags, error)

    # -- public API -------------------------------------------------------------------------
    def ping(self, servo_id: int, retries: int | None = None) -> ServoInfo:
        """Model number and firmware of `servo_id` (raises NoResponse when absent)."""
        _check_id(servo_id)
        return self._transact(lambda: self._ping_once(servo_id), retries)

    def scan(self, ids: Iterable[int] = range(MAX_SERVO_ID + 1)) -> list[ServoInfo]:
        """Ping every id in `ids` once (no retries); the servos that answered, by id."""
        found = []
        for servo_id in ids:
            try:
                found.append(self.ping(servo_id, retries=0))
            except (NoResponse, CorruptPacket):
                continue
        return found

    def read(self, servo_id: int, name: str) -> int:
        """Decoded value of register `name` of one servo."""
        _check_id(servo_id)
        reg = self.table[name]

        def attempt() -> int:
            data, error = self._read_once(servo_id, reg.addr, reg.size)
            self._check(servo_id, error)
            return reg.decode(data)

        return self._transact(attempt)

    def write(self, servo_id: int, name: str, value: int) -> None:
        """Write register `name` of one servo and wait for its status."""
        _check_id(servo_id)
        reg = self.table[name]
        raw = _encode(reg, name, servo_id, value)

        def attempt() -> None:
            self._check(servo_id, self._write_once(servo_id, reg.addr, raw))

        self._transact(attempt)

    def sync_write(self, name: str, values: Mapping[int, int]) -> None:
        """One broadcast sync-write of register `name` ({id: value})."""
        if not values:
            return
        reg = self.table[name]
        for servo_id in values:
            _check_id(servo_id)
        data = {i: _encode(reg, name, i, v) for i, v in values.items()}
        self._transact(lambda: self._sync_write_once(reg.addr, reg.size, data))

    def sync_read(self, name: str, ids: Sequence[int]) -> dict[int, int]:
        """One sync-read of register `name` from `ids` ({id: value})."""
        reg = self.table[name]
        raw = self._sync_read_span(reg.addr, reg.size, ids)
        return {i: reg.decode(data) for i, data in raw.items()}

    def set_torque(self, ids: Iterable[int], enabled: bool) -> None:
        """Torque on/off for each servo (one acknowledged write each)."""
        for servo_id in ids:
            self.write(servo_id, "torque_enable", 1 if enabled else 0)

    def torque_on(self, ids: Iterable[int]) -> None:
        self.set_torque(ids, True)

    def torque_off(self, ids: Iterable[int]) -> None:
        self.set_torque(ids, False)

    def sync_write_positions(self, goals_ticks: Mapping[int, int]) -> None:
        """Goal positions [ticks] for several servos in one broadcast packet."""
        self.sync_write("goal_position", goals_ticks)

    def sync_read_positions(self, ids: Sequence[int]) -> dict[int, int]:
        """Present positions [ticks] of `ids` in one sync-read."""
        return self.sync_read("present_position", ids)

    def read_status(self, ids: Sequence[int]) -> dict[int, ServoStatus]:
        """Load, voltage, temperature and hardware-error flags of `ids` (never raises ServoFault:
        the flags are the answer)."""
        names = ("present_load", "present_voltage", "present_temperature", "hardware_error")
        regs = [self.table[n] for n in names]
        blocks: dict[int, dict[int, bytes]] = {}
        for lo, hi in _spans(regs):
            got = self._sync_read_span(lo, hi - lo, ids, check_faults=False)
            for servo_id, data in got.items():
                blocks.setdefault(servo_id, {})[lo] = data

        def value(servo_id: int, reg: Register) -> int:
            for lo, data in blocks.get(servo_id, {}).items():
                if lo <= reg.addr and reg.addr + reg.size <= lo + len(data):
                    return reg.decode(data[reg.addr - lo : reg.addr - lo + reg.size])
            raise CorruptPacket(
                f"status of servo {servo_id}: no bytes for register at {reg.addr}+{reg.size}",
                servo_id,
            )

        out = {}
        for servo_id in ids:
            load, volt, temp, err = (value(servo_id, r) for r in regs)
            out[servo_id] = ServoStatus(
                servo_id=servo_id,
                load_pct=regs[0].to_physical(load),
                voltage_v=regs[1].to_physical(volt),
                temperature_c=regs[2].to_physical(temp),
                error_flags=decode_flags(err, self.table.hardware_error_bits),
                error_raw=err,
            )
        return out

    def _sync_read_span(
        self, addr: int, length: int, ids: Sequence[int], check_faults: bool = True
    ) -> dict[int, bytes]:
        ids = list(ids)
        if not ids:
            return {}
        for servo_id in ids:
            _check_id(servo_id)

        def attempt() -> dict[int, bytes]:
            got = self._sync_read_once(addr, length, ids)
            if check_faults:
                for servo_id, (_, error) in got.items():
                    self._check(servo_id, error)
            return {i: data for i, (data, _) in got.items()}

        return self._transact(attempt)


def _check_id(servo_id: int) -> None:
    bounded_int("servo id", servo_id, 0, MAX_SERVO_ID)


def _encode(reg: Register, name: str, servo_id: int, value: object) -> bytes:
    try:
        return reg.encode(operator.index(value))  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise InvalidSetting(f"{name} for servo {servo_id}", f"{value!r}: {exc}") from None


def _spans(regs: Sequence[Register], max_gap: int = 8) -> list[tuple[int, int]]:
    """Merge registers into contiguous [lo, hi) address spans, bridging gaps <= max_gap bytes."""
    spans: list[tuple[int, int]] = []
    for reg in sorted(regs, key=lambda r: r.addr):
        lo, hi = reg.addr, reg.addr + reg.size
        if spans and lo - spans[-1][1] <= max_gap:
            spans[-1] = (spans[-1][0], max(spans[-1][1], hi))
        else:
            spans.append((lo, hi))
    return spans

"""The bus's time budget: the loop rate a servo bus can sustain for a robot, and why.

Every player tick (`hardware.play.player.Player._tick`) puts on the bus:

1. one SYNC WRITE of the goal positions (no replies; the line is busy for its bytes);
2. one read of the present positions: a SYNC READ (Protocol 2.0, Feetech STS), one BULK READ
   (Protocol 1.0 MX / EX models) or one READ per servo (Protocol 1.0 AX: no sync read);
3. every `status_every_ticks` ticks, the status reads of `ServoBus.read_status` (load, voltage,
   temperature, error flags: one read per contiguous register span).

One exchange that waits for replies costs, on a half-duplex line at `baud` (8N1: 10 bits per
byte): the request's bytes, then per reply the servo's Return Delay Time and the reply's bytes
(servo after servo), then the USB adapter's latency timer — an FTDI adapter (ROBOTIS U2D2, most
Feetech boards) holds received bytes up to that long (default 16 ms; 1 ms when lowered through
/sys/bus/usb-serial/devices/ttyUSB*/latency_timer) before the host sees them, so it is paid once
per exchange. Packet sizes come from the codecs themselves (`hardware.bus.protocol`).

The mean tick (status reads spread over `status_every_ticks`) gives the rate a run asked above it
achieves (the player skips passed deadlines, it does not burst); the status tick, the longest,
gives the rate held without any overrun. Host CPU time is not part of the bus budget: the tick's
own work (≈ 1-3 ms on a loaded 2-core machine, see `hardware.play.commands`) and ≈ 0.5 ms of driver
Python per exchange (measured: 12 AX reads on the in-process virtual bus, load average 5). It
matters when a tick holds many exchanges: 12 AX servos behind a 1 ms adapter are budgeted at
44.7 Hz and played at 32.6 Hz; behind the factory 16 ms, 4.5 Hz and 4.4 Hz.

Checked against the player on the virtual bus with wire-time emulation
(`hardware.bus.virtual.WireTiming`, `benchmarks/bus_budget_check.py`, factory settings, 16 ms
adapter, --rate 100): quad12 budget 51.6 Hz, played 49.5 Hz (-4 %); hex18 budget 26.8 Hz,
played 26.2-26.5 Hz (-1 to -2 %).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from hardware.bus.control_table import DYNAMIXEL1_BULK_READ_MODELS, table_for_protocol
from hardware.bus.protocol import dynamixel1, dynamixel2, feetech
from hardware.bus.servo_bus import MAX_BAUD, MIN_BAUD, _spans, bounded, bounded_int

# Factory Return Delay Time per protocol [µs]: X-series and AX/MX 250 × 2 µs, Feetech STS 0.
FACTORY_RETURN_DELAY_US: Mapping[str, float] = {
    "dynamixel1": 500.0,
    "dynamixel2": 500.0,
    "feetech_sts": 0.0,
}
FTDI_DEFAULT_LATENCY_MS = 16.0
LOWEST_LATENCY_S = 0.001  # the FTDI latency timer's lowest setting (1 ms)
STATUS_REGISTERS = ("present_load", "present_voltage", "present_temperature", "hardware_error")
DYNAMIXEL1_STATUS_REGISTERS = ("present_load", "present_voltage", "present_temperature")
DEFAULT_STATUS_EVERY_TICKS = 10  # hardware.play.watchdog.WatchdogLimits.status_every_ticks


@dataclass(frozen=True)
class Exchange:
    """One kind of bus transaction: bytes out, bytes back per reply, how often per tick."""

    what: str
    request_bytes: int
    reply_bytes: tuple[int, ...]  # one entry per status packet expected
    per_tick: float  # how many per tick on average (status reads: 1 / status_every_ticks)
    on_status_ticks_only: bool = False

    @property
    def waits(self) -> bool:
        """Whether the host waits for replies (then it pays the adapter latency)."""
        return bool(self.reply_bytes)


@dataclass(frozen=True)
class TickTerms:
    """Time of one tick [s], split by cause."""

    wire_s: float
    return_delay_s: float
    adapter_latency_s: float

    @property
    def total_s(self) -> float:
        return self.wire_s + self.return_delay_s + self.adapter_latency_s

    def as_dict(self) -> dict[str, float]:
        return {
            "wire time": self.wire_s,
            "return delay": self.return_delay_s,
            "USB adapter latency": self.adapter_latency_s,
        }


@dataclass(frozen=True)
class BusBudget:
    """The loop rate a bus sustains for one robot, with the terms it is made of."""

    protocol: str
    n_servos: int
    baud: int
    return_delay_s: float
    adapter_latency_s: float
    status_every_ticks: int
    exchanges: tuple[Exchange, ...]
    mean: TickTerms  # a tick, status reads spread over status_every_ticks
    status_tick: TickTerms  # a tick with the status reads in it (the longest)

    @property
    def mean_rate_hz(self) -> float:
        """The rate a run asked faster than this achieves (bus time only)."""
        return 1.0 / self.mean.total_s

    @property
    def overrun_free_rate_hz(self) -> float:
        """The highest rate at which not even a status tick overruns."""
        return 1.0 / self.status_tick.total_s

    @property
    def bytes_per_tick(self) -> float:
        return sum(e.per_tick * (e.request_bytes + sum(e.reply_bytes)) for e in self.exchanges)

    @property
    def dominant(self) -> str:
        terms = self.mean.as_dict()
        return max(terms, key=lambda k: terms[k])

    def advice(self) -> str:
        """What to change to go faster, aimed at the dominant term."""
        dom = self.dominant
        reads = [e for e in self.exchanges if e.waits]
        waits = sum(e.per_tick for e in reads)
        if dom == "USB adapter latency":
            what = (
                f"{waits:.1f} exchanges per tick each wait out the adapter's "
                f"{self.adapter_latency_s * 1e3:g} ms latency timer"
            )
            fixes = []
            if self.adapter_latency_s > LOWEST_LATENCY_S:
                fixes.append(
                    "lower it to 1 ms: echo 1 | sudo tee /sys/bus/usb-serial/devices/ttyUSB0/"
                    'latency_timer (or a udev rule: ATTR{latency_timer}="1")'
                )
            if self.protocol == "dynamixel1" and any(e.what.startswith("READ ×") for e in reads):
                fixes.append(
                    "Protocol 1.0 AX servos take one READ each (no sync read); MX models "
                    "answer one BULK READ"
                )
            if not fixes:
                fixes.append("read status less often (fewer exchanges per tick)")
            return f"{what}; {'; '.join(fixes)}"
        if dom == "return delay":
            return (
                f"each reply waits the servos' Return Delay Time ({self.return_delay_s * 1e6:g} "
                "µs); set it to 0-20 µs (register return_delay: 0 = no delay) on every servo"
            )
        return (
            f"{self.bytes_per_tick:.0f} bytes per tick at {self.baud} bit/s; raise the baud "
            "rate (servos and --baud) if the servos allow it, or read status less often"
        )

    def report(self) -> str:
        lines = [
            f"{self.n_servos} × {self.protocol} servos at {self.baud} bit/s, return delay "
            f"{self.return_delay_s * 1e6:g} µs, USB adapter latency "
            f"{self.adapter_latency_s * 1e3:g} ms, status every {self.status_every_ticks} ticks",
        ]
        for e in self.exchanges:
            replies = f", {len(e.reply_bytes)} × {e.reply_bytes[0]} B back" if e.reply_bytes else ""
            how = f"every {self.status_every_ticks} ticks" if e.on_status_ticks_only else "per tick"
            lines.append(f"  {e.what}: {e.request_bytes} B out{replies}, {how}")
        lines.append("  mean tick [ms]: " + _terms_text(self.mean))
        lines.append("  status tick [ms]: " + _terms_text(self.status_tick))
        lines.append(
            f"sustains {self.mean_rate_hz:.1f} Hz (mean tick {self.mean.total_s * 1e3:.2f} ms); "
            f"without overruns on status ticks: {self.overrun_free_rate_hz:.1f} Hz"
        )
        lines.append(f"dominant: {self.dominant} — {self.advice()}")
        return "\n".join(lines)


def _terms_text(t: TickTerms) -> str:
    parts = ", ".join(f"{k} {v * 1e3:.2f}" for k, v in t.as_dict().items())
    return f"{parts} = {t.total_s * 1e3:.2f}"


def exchanges_for(
    protocol: str,
    servo_ids: Sequence[int],
    model_numbers: Sequence[int],
    status_every_ticks: int = DEFAULT_STATUS_EVERY_TICKS,
) -> tuple[Exchange, ...]:
    """The player's bus traffic per tick for servos `servo_ids` (models `model_numbers`)."""
    table = table_for_protocol(protocol)
    ids = list(servo_ids)
    n = len(ids)
    goal = table["goal_position"]
    pos = table["present_position"]
    status_share = 1.0 / status_every_ticks
    write = _sync_write_bytes(protocol, goal.size, ids)
    out = [Exchange("SYNC WRITE goal positions", write, (), 1)]
    if protocol == "dynamixel1":
        regs = [table[r] for r in DYNAMIXEL1_STATUS_REGISTERS]
        spans = [(min(r.addr for r in regs), max(r.addr + r.size for r in regs))]
        bulk = all(m in DYNAMIXEL1_BULK_READ_MODELS for m in model_numbers) and n > 1
    else:
        spans = _spans([table[r] for r in STATUS_REGISTERS])
        bulk = False
    reads: list[tuple[str, int, float, bool]] = [("present positions", pos.size, 1.0, False)]
    reads += [(f"status {lo}+{hi - lo}", hi - lo, status_share, True) for lo, hi in spans]
    for label, size, share, status_only in reads:
        reply = _status_bytes(protocol, size)
        replies: tuple[int, ...]
        if protocol == "dynamixel1" and not bulk:
            request = _read_bytes(protocol, size, ids[:1])
            what, replies, count = f"READ × {n} ({label})", (reply,), share * n
        else:
            request = _read_bytes(protocol, size, ids, bulk)
            kind = "BULK READ" if bulk else "SYNC READ"
            what, replies, count = f"{kind} {label}", (reply,) * n, share
        out.append(Exchange(what, request, replies, count, status_only))
    return tuple(out)


def compute(
    protocol: str,
    servo_ids: Sequence[int],
    model_numbers: Sequence[int],
    baud: int,
    return_delay_us: float | None = None,
    latency_ms: float = FTDI_DEFAULT_LATENCY_MS,
    status_every_ticks: int = DEFAULT_STATUS_EVERY_TICKS,
) -> BusBudget:
    """The budget of a bus of `servo_ids` speaking `protocol` (see the module docstring)."""
    bounded_int("baud", baud, MIN_BAUD, MAX_BAUD)
    delay_us = FACTORY_RETURN_DELAY_US[protocol] if return_delay_us is None else return_delay_us
    bounded("return delay", delay_us, 0.0, 508.0, " µs")  # one byte of 2 µs units
    bounded("adapter latency", latency_ms, 0.0, 255.0, " ms")
    bounded_int("status_every_ticks", status_every_ticks, 1, 1_000_000)
    if not servo_ids:
        raise ValueError("a bus budget needs at least one servo")
    ex = exchanges_for(protocol, servo_ids, model_numbers, status_every_ticks)
    byte_s, delay_s, latency_s = 10.0 / baud, delay_us * 1e-6, latency_ms * 1e-3

    def terms(weights: Sequence[float]) -> TickTerms:
        wire = sum(
            w * (e.request_bytes + sum(e.reply_bytes)) for w, e in zip(weights, ex, strict=True)
        )
        delays = sum(w * len(e.reply_bytes) for w, e in zip(weights, ex, strict=True))
        waits = sum(w for w, e in zip(weights, ex, strict=True) if e.waits)
        return TickTerms(wire * byte_s, delays * delay_s, waits * latency_s)

    mean = terms([e.per_tick for e in ex])
    status_tick = terms(
        [e.per_tick * (status_every_ticks if e.on_status_ticks_only else 1) for e in ex]
    )
    return BusBudget(
        protocol, len(servo_ids), int(baud), delay_s, latency_s, status_every_ticks, ex, mean,
        status_tick,
    )  # fmt: skip


def for_robot(
    robot: object,
    baud: int | None = None,
    return_delay_us: float | None = None,
    latency_ms: float = FTDI_DEFAULT_LATENCY_MS,
    status_every_ticks: int = DEFAULT_STATUS_EVERY_TICKS,
) -> BusBudget:
    """`compute` for a loaded robot (`robots.Robot`): its bus ids, servo models and baud."""
    joints = list(robot.joints)  # type: ignore[attr-defined]
    protocol = joints[0].servo.protocol
    return compute(
        protocol,
        [j.bus_id for j in joints],
        [j.servo.model_number for j in joints],
        int(baud or robot.bus_baud),  # type: ignore[attr-defined]
        return_delay_us,
        latency_ms,
        status_every_ticks,
    )


# -- packet sizes, from the codecs -------------------------------------------------------------
def _sync_write_bytes(protocol: str, size: int, ids: Sequence[int]) -> int:
    items = {i: bytes(size) for i in ids}
    codec = _codec(protocol)
    return len(codec.sync_write(0, size, items))


def _read_bytes(protocol: str, size: int, ids: Sequence[int], bulk: bool = False) -> int:
    if protocol == "dynamixel1":
        if bulk:
            return len(dynamixel1.bulk_read((i, 0, size) for i in ids))
        return len(dynamixel1.read(ids[0], 0, size))
    codec = _codec(protocol)
    return len(codec.sync_read(0, size, ids))


def _status_bytes(protocol: str, size: int) -> int:
    if protocol == "dynamixel2":
        return len(dynamixel2.build_status(1, 0, bytes(size)))
    return len(_codec(protocol).build_status(1, 0, bytes(size)))


def _codec(protocol: str):  # type: ignore[no-untyped-def]
    return {"dynamixel1": dynamixel1, "dynamixel2": dynamixel2, "feetech_sts": feetech}[protocol]


def rate_check(budget: BusBudget, rate_hz: float) -> str | None:
    """The warning for a run asked at `rate_hz` on this bus (None: within budget)."""
    if rate_hz <= budget.overrun_free_rate_hz or not math.isfinite(rate_hz):
        return None
    if rate_hz <= budget.mean_rate_hz:
        return (
            f"WARNING: --rate {rate_hz:g}: the bus holds it on average, but ticks with status "
            f"reads take {budget.status_tick.total_s * 1e3:.1f} ms and overrun (without overruns: "
            f"{budget.overrun_free_rate_hz:.0f} Hz); see `gaitsmith-play budget`"
        )
    return (
        f"WARNING: --rate {rate_hz:g} is beyond what this bus sustains: about "
        f"{budget.mean_rate_hz:.0f} Hz ({budget.dominant} dominates: {budget.advice()}); the "
        "loop will overrun and play slower than asked; see `gaitsmith-play budget`"
    )

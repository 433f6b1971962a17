"""`--fault` for `gaitsmith-play run --virtual`: rehearse a safe stop without hardware.

One fault per option (repeat the option for several); each maps onto a `FaultPlan` field of the
virtual bus::

    drop=P           each reply lost with probability P in [0, 1]        drop_probability
    corrupt=P        one byte of each reply flipped with probability P   corrupt_probability
    delay=S          every reply S seconds late (compare --timeout-ms)   delay_s
    sag=V            the supply droops by V volts                        voltage_sag_v
    vanish=ID        servo ID stops answering (a cut cable)              vanished
    overload=ID      servo ID reports an overload                        overload
    overheat=ID      servo ID reports overheating                        overheat
    voltage-error=ID servo ID reports an input-voltage error             voltage_error
    status-lost      no reply to the status reads (load, voltage,        drop_reads_of
                     temperature, error flags); positions still read
    unplug           the serial adapter itself vanishes: every read and  (the port, not
                     write on it fails with OSError EIO, like a pulled   the plan: needs
                     USB adapter (no value; normally with @T)            `attach_port`)

Values must be finite and sensible: P in [0, 1], delay in [0, 10] s, sag in [0, 50] V, start
times in [0, 86400] s (one day: the longest run pre-flight accepts).

Each may end in ``@T``: the fault starts T seconds into the run (the telemetry's t_actual_s;
0 = the first tick of the ramp-in), at the end of the first tick at or after T. Without ``@T``
it is there from the start, so the pre-flight checks see it (e.g. ``vanish=3`` refuses to
start, which is what the real robot would do). A later probability / delay / sag replaces an
earlier one (``drop=0.01 --fault drop=0.3@2`` escalates); servo ids add up.

Times are run-relative on purpose: `FaultPlan.vanish_at_s` is bus-clock time, which on a real-time
run is the machine's monotonic clock, meaningless on a command line.
"""

from __future__ import annotations

import errno
import math
import os
from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace
from typing import Any

from hardware.virtual.bus import VirtualServoBus
from hardware.virtual.faults import FaultPlan

FORMS = (
    "drop=P, corrupt=P (probability 0..1), delay=S [s], sag=V [V], vanish=ID, overload=ID, "
    "overheat=ID, voltage-error=ID, status-lost, unplug; each optionally followed by @T "
    "(seconds into the run), e.g. drop=0.01, vanish=3@2.0, overheat=5@1.5, status-lost@1, "
    "unplug@2"
)
_PROBABILITY = ("drop", "corrupt")
_AMOUNT = ("delay", "sag")
_SERVO = ("vanish", "overload", "overheat", "voltage-error")
_NO_VALUE = ("status-lost", "unplug")
_RANGES = {"delay": (0.0, 10.0, "s"), "sag": (0.0, 50.0, "V")}
MAX_START_S = 86400.0
_STATUS_REGISTER = "present_temperature"  # in both control tables; any status register would do


class FaultSpecError(ValueError):
    """A `--fault` value that does not parse; the message names it and the accepted forms."""

    def __init__(self, text: str, problem: str) -> None:
        self.text = text
        self.problem = problem
        super().__init__(f"--fault {text!r}: {problem}; accepted: {FORMS}")


@dataclass(frozen=True)
class FaultSpec:
    """One parsed `--fault`: `kind` (a key of the table above), its value, start time [s]."""

    text: str
    kind: str
    value: float | int | None
    at_s: float | None  # None: from the start (before pre-flight)

    def apply(self, plan: FaultPlan) -> FaultPlan:
        """`plan` with this fault added."""
        k, x = self.kind, self.value
        if k == "unplug":
            return plan  # the port's business: FaultSchedule.unplug
        if k == "status-lost" or x is None:
            return replace(plan, drop_reads_of=plan.drop_reads_of | {_STATUS_REGISTER})
        if k == "drop":
            return replace(plan, drop_probability=float(x))
        if k == "corrupt":
            return replace(plan, corrupt_probability=float(x))
        if k == "delay":
            return replace(plan, delay_s=float(x))
        if k == "sag":
            return replace(plan, voltage_sag_v=float(x))
        one = frozenset({int(x)})
        if k == "vanish":
            return replace(plan, vanished=plan.vanished | one)
        if k == "overload":
            return replace(plan, overload=plan.overload | one)
        if k == "overheat":
            return replace(plan, overheat=plan.overheat | one)
        return replace(plan, voltage_error=plan.voltage_error | one)

    def describe(self) -> str:
        when = "from the start" if self.at_s is None else f"at {self.at_s:g} s"
        return f"{self.text.partition('@')[0]} {when}"


def _number(text: str, spec: str, what: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise FaultSpecError(spec, f"{what} {text!r} is not a number") from None
    if not math.isfinite(x):
        raise FaultSpecError(spec, f"{what} must be finite, got {text!r}")
    return x


def parse_fault(text: str, servo_ids: Collection[int] | None = None) -> FaultSpec:
    """Parse one `--fault` value (raises FaultSpecError); `servo_ids`: the ids on the bus."""
    spec = text.strip()
    body, at, when = spec.partition("@")
    at_s: float | None = None
    if at:
        at_s = _number(when.strip(), text, "start time")
        if not 0 <= at_s <= MAX_START_S:
            why = f"start time must lie in [0, {MAX_START_S:g}] s, got {at_s:g}"
            raise FaultSpecError(text, why)
    kind, eq, raw = (p.strip() for p in body.partition("="))
    kind = kind.lower().replace("_", "-")
    if kind in _NO_VALUE:
        if eq:
            why = "it loses every servo's" if kind == "status-lost" else "it loses the adapter"
            raise FaultSpecError(text, f"{kind} takes no value ({why})")
        return FaultSpec(spec, kind, None, at_s)
    if kind not in _PROBABILITY and kind not in _AMOUNT and kind not in _SERVO:
        raise FaultSpecError(text, f"unknown fault {kind!r}" if kind else "no fault named")
    if not eq or not raw:
        raise FaultSpecError(text, f"{kind} needs a value ({kind}=...)")
    if kind in _SERVO:
        try:
            servo_id = int(raw)
        except ValueError:
            raise FaultSpecError(text, f"servo id {raw!r} is not an integer") from None
        if servo_ids is not None and servo_id not in servo_ids:
            ids = sorted(servo_ids)
            raise FaultSpecError(text, f"no servo {servo_id} on this bus (ids {_ranges(ids)})")
        return FaultSpec(spec, kind, servo_id, at_s)
    value = _number(raw, text, kind)
    if kind in _PROBABILITY and not 0.0 <= value <= 1.0:
        raise FaultSpecError(text, f"{kind} is a probability in [0, 1], got {value:g}")
    if value < 0:
        raise FaultSpecError(text, f"{kind} must be >= 0, got {value:g}")
    if kind in _RANGES:
        lo, hi, unit = _RANGES[kind]
        if not lo <= value <= hi:
            raise FaultSpecError(text, f"{kind} must lie in [{lo:g}, {hi:g}] {unit}, got {value:g}")
    parsed = FaultSpec(spec, kind, value, at_s)
    try:  # FaultPlan's own bounds (e.g. sag=1e308, delay=1e9): refused here, in one line
        parsed.apply(FaultPlan())
    except ValueError as exc:
        raise FaultSpecError(text, str(exc)) from None
    return parsed


class FaultSchedule:
    """Faults for one run: `initial` goes onto the bus before pre-flight; `on_tick` (a player
    tick hook) adds each timed fault once the run reaches its start time."""

    def __init__(self, specs: Sequence[FaultSpec], base: FaultPlan | None = None) -> None:
        self.specs = tuple(specs)
        plan = base or FaultPlan()
        for s in self.specs:
            if s.at_s is None:
                plan = s.apply(plan)
        self.initial = plan
        self.pending = sorted((s for s in self.specs if s.at_s is not None), key=_start)
        self.applied: list[tuple[FaultSpec, float]] = []  # (spec, run time [s] it took effect)
        self.vbus: VirtualServoBus | None = None
        self.port: Any = None

    @property
    def unplugs_at_start(self) -> bool:
        return any(s.kind == "unplug" and s.at_s is None for s in self.specs)

    @property
    def timed(self) -> bool:
        return bool(self.pending)

    def attach(self, vbus: VirtualServoBus) -> None:
        """Put the initial faults on `vbus`; timed ones follow through `on_tick`."""
        vbus.faults = self.initial
        self.vbus = vbus

    def attach_port(self, bus: Any) -> None:
        """Remember the connected driver's port (`bus.port`, the in-process `VirtualPort`)
        so that `unplug` can fail it; an untimed `unplug` fails it at once."""
        self.port = getattr(bus, "port", None)
        if self.unplugs_at_start:
            self.unplug()

    def unplug(self) -> None:
        """The adapter vanishes: every port call raises OSError(EIO) from now on."""
        if self.port is None:
            return

        def eio(*_: Any, **__: Any) -> Any:
            raise OSError(errno.EIO, os.strerror(errno.EIO))

        for name in ("readPort", "writePort", "clearPort", "getBytesAvailable"):
            setattr(self.port, name, eio)

    def on_tick(self, tick: int, t_s: float) -> None:
        while self.pending and self.vbus is not None and _start(self.pending[0]) <= t_s:
            spec = self.pending.pop(0)
            if spec.kind == "unplug":
                self.unplug()
            self.vbus.faults = spec.apply(self.vbus.faults)
            self.applied.append((spec, t_s))

    def describe(self) -> str:
        return "; ".join(s.describe() for s in sorted(self.specs, key=lambda s: s.at_s or -1.0))


def _start(spec: FaultSpec) -> float:
    return 0.0 if spec.at_s is None else spec.at_s


def _ranges(ids: Sequence[int]) -> str:
    """[1, 2, 3, 7] → "1-3, 7"."""
    runs: list[list[int]] = []
    for i in ids:
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    return ", ".join(f"{r[0]}-{r[-1]}" if len(r) > 1 else str(r[0]) for r in runs)

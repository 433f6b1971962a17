"""Fault injection plan for the virtual servo bus (a value; swap it live: `bus.faults = plan`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from hardware.bus import MAX_SERVO_ID, bounded, bounded_int
from hardware.errors import InvalidSetting

MAX_DELAY_S = 60.0  # a reply later than a minute is a lost one: say drop
MAX_SAG_V = 100.0  # above any servo supply
MAX_NOISE_BYTES = 64


@dataclass(frozen=True)
class FaultPlan:
    """What goes wrong on the virtual bus.

    drop_probability: each status packet is lost with this probability.
    corrupt_probability: each status packet gets one byte (after the header) flipped.
    delay_s: every status packet is released this late [s] (wall clock; compare with the
        driver's timeout); applied with probability `delay_probability`.
    delay_jitter_s: a delayed packet is released a further uniform [0, delay_jitter_s] later
        (replies stay in order: a late one holds back those after it, as in a serial stream).
    noise_probability: before each status packet, with this probability, 1..noise_max_bytes
        random bytes appear on the line (stray bytes: noise, a glitching servo).
    vanished: servo ids that never answer (a cut cable).
    vanish_at_s: {servo id: bus-clock time [s]} from which that servo stops answering.
    overload / overheat / voltage_error: servo ids that report that hardware error.
    drop_reads_of: register names (e.g. {"present_temperature"}): every reply to a READ or
        SYNC_READ whose address range overlaps one of them is lost, whatever the servo; other
        packets are untouched. Lets a test lose the periodic status reads (load, voltage,
        temperature, error flags) while position reads still succeed. Names are checked against
        the bus's control table when the plan is set.
    voltage_sag_v: the supply droops by this much [V]; a servo whose present voltage falls below
        its catalogue minimum reports a voltage error by itself.
    adapter_lost_at_s: bus-clock time [s] from which the port itself fails — every read and
        write raises OSError EIO, as when the USB adapter is unplugged (`VirtualPort`; the
        `PtyServer` closes its side of the pty, so a client's own port sees the same).
    seed: seeds the RNG used for drop / corrupt / delay decisions (reset when the plan is set).

    Magnitudes are bounded (non-finite or absurd values raise `InvalidSetting`, a ValueError):
    probabilities in [0, 1], delays in [0, 60] s, sag in [0, 100] V, servo ids 0..252.
    """

    drop_probability: float = 0.0
    corrupt_probability: float = 0.0
    delay_s: float = 0.0
    delay_probability: float = 1.0
    vanished: frozenset[int] = frozenset()
    vanish_at_s: Mapping[int, float] = field(default_factory=dict)
    overload: frozenset[int] = frozenset()
    overheat: frozenset[int] = frozenset()
    voltage_error: frozenset[int] = frozenset()
    drop_reads_of: frozenset[str] = frozenset()
    voltage_sag_v: float = 0.0
    delay_jitter_s: float = 0.0
    noise_probability: float = 0.0
    noise_max_bytes: int = 8
    adapter_lost_at_s: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        def check(name: str, lo: float, hi: float, unit: str = "") -> None:
            value = bounded(f"FaultPlan.{name}", getattr(self, name), lo, hi, unit)
            object.__setattr__(self, name, value)

        for name in (
            "drop_probability",
            "corrupt_probability",
            "delay_probability",
            "noise_probability",
        ):
            check(name, 0.0, 1.0)
        check("delay_s", 0.0, MAX_DELAY_S, " s")
        check("delay_jitter_s", 0.0, MAX_DELAY_S, " s")
        check("voltage_sag_v", 0.0, MAX_SAG_V, " V")
        bounded_int("FaultPlan.noise_max_bytes", self.noise_max_bytes, 1, MAX_NOISE_BYTES)
        bounded_int("FaultPlan.seed", self.seed, -(2**63), 2**63 - 1)
        for name in ("vanished", "overload", "overheat", "voltage_error"):
            ids = frozenset(getattr(self, name))
            for i in ids:
                bounded_int(f"FaultPlan.{name}", i, 0, MAX_SERVO_ID)
            object.__setattr__(self, name, ids)
        object.__setattr__(self, "drop_reads_of", frozenset(self.drop_reads_of))
        for i, t in self.vanish_at_s.items():
            bounded_int("FaultPlan.vanish_at_s", i, 0, MAX_SERVO_ID)
            _check_time(f"FaultPlan.vanish_at_s[{i}]", t)
        if self.adapter_lost_at_s is not None:
            _check_time("FaultPlan.adapter_lost_at_s", self.adapter_lost_at_s)

    def is_adapter_lost(self, now_s: float) -> bool:
        """Whether the port has failed (unplugged) at bus-clock time `now_s`."""
        return self.adapter_lost_at_s is not None and now_s >= self.adapter_lost_at_s

    def is_vanished(self, servo_id: int, now_s: float) -> bool:
        """Whether `servo_id` has stopped answering at bus-clock time `now_s`."""
        if servo_id in self.vanished:
            return True
        at = self.vanish_at_s.get(servo_id)
        return at is not None and now_s >= at


def _check_time(what: str, t: object) -> None:
    """A bus-clock time: any number but NaN (+inf = never)."""
    try:
        x = float(t)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InvalidSetting(what, f"{t!r} is not a number") from None
    if math.isnan(x):
        raise InvalidSetting(what, "NaN is not a time")


NO_FAULTS = FaultPlan()

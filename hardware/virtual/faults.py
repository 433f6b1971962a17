"""Fault injection plan for the virtual servo bus (a value; swap it live: `bus.faults = plan`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field


@dataclass(frozen=True)
class FaultPlan:
    """What goes wrong on the virtual bus.

    drop_probability: each status packet is lost with this probability.
    corrupt_probability: each status packet gets one byte (after the header) flipped.
    delay_s: every status packet is released this late [s] (wall clock; compare with the
        driver's timeout); applied with probability `delay_probability`.
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
    seed: seeds the RNG used for drop / corrupt / delay decisions (reset when the plan is set).
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
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("drop_probability", "corrupt_probability", "delay_probability"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"{name} must lie in [0, 1], got {p}")
        if self.delay_s < 0 or self.voltage_sag_v < 0:
            raise ValueError("delay_s and voltage_sag_v must be >= 0")
        for name in ("vanished", "overload", "overheat", "voltage_error", "drop_reads_of"):
            object.__setattr__(self, name, frozenset(getattr(self, name)))

    def is_vanished(self, servo_id: int, now_s: float) -> bool:
        """Whether `servo_id` has stopped answering at bus-clock time `now_s`."""
        if servo_id in self.vanished:
            return True
        at = self.vanish_at_s.get(servo_id)
        return at is not None and now_s >= at


NO_FAULTS = FaultPlan()

"""Contact schedules: when each foot is on the ground during one gait cycle.

Each foot touches down once per cycle (W&P 2009 §4: one contact interval per foot, start and
duration as fractions of the period).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robots.errors import RobotsError

#: phase distance within which a touchdown or lift-off counts as sitting on a knot
KNOT_TOL = 1e-9


class ScheduleError(RobotsError, ValueError):
    """A contact schedule with bad timing values."""


@dataclass(frozen=True)
class ContactSchedule:
    """Per-foot contact timing over one cycle.

    `touchdown_phase[f]` ∈ [0, 1) is when foot f lands, `duty_factor[f]` ∈ (0, 1] the fraction of
    the period it stays down. Foot f is in stance at phase s when (s − touchdown) mod 1 < duty.
    """

    period_s: float
    feet: tuple[str, ...]
    touchdown_phase: tuple[float, ...]
    duty_factor: tuple[float, ...]

    def __post_init__(self) -> None:
        if not (
            isinstance(self.period_s, (int, float))
            and math.isfinite(self.period_s)
            and self.period_s > 0
        ):
            raise ScheduleError(f"period_s must be a positive number, got {self.period_s!r}")
        n = len(self.feet)
        if n == 0 or len(set(self.feet)) != n:
            raise ScheduleError("feet must be a non-empty list of distinct names")
        if len(self.touchdown_phase) != n or len(self.duty_factor) != n:
            raise ScheduleError("touchdown_phase and duty_factor need one value per foot")
        for f, (ph, d) in enumerate(zip(self.touchdown_phase, self.duty_factor, strict=True)):
            if not (math.isfinite(ph) and 0.0 <= ph < 1.0):
                raise ScheduleError(f"touchdown_phase[{f}] must be in [0, 1), got {ph!r}")
            if not (math.isfinite(d) and 0.0 < d <= 1.0):
                raise ScheduleError(f"duty_factor[{f}] must be in (0, 1], got {d!r}")

    @property
    def n_feet(self) -> int:
        return len(self.feet)

    def in_stance(self, foot: int, phase: float) -> bool:
        return ((phase - self.touchdown_phase[foot]) % 1.0) < self.duty_factor[foot]

    def contact_matrix(self, n_knots: int) -> np.ndarray:
        """Boolean (n_knots × n_feet): foot f in stance at knot k (phase k/n_knots)."""
        phase = np.arange(n_knots)[:, None] / n_knots
        td = np.asarray(self.touchdown_phase)[None, :]
        # boundaries within KNOT_TOL of a knot count as on it, on both sides: a knot on a
        # touchdown is in stance, a knot on a lift-off is not, whichever way the phases rounded
        # (a touchdown at 0.6000000000000001 still holds knot 18 of 30; without the shift it
        # lost it, and that foot stood one knot shorter than the others)
        return ((phase - td + KNOT_TOL) % 1.0) < np.asarray(self.duty_factor)[None, :]

    def with_period(self, period_s: float) -> ContactSchedule:
        return ContactSchedule(period_s, self.feet, self.touchdown_phase, self.duty_factor)

"""The sweep table's flight column: the planned share of the cycle with no foot down."""

from __future__ import annotations

import math

import pytest

from planner.search.speed_sweep import SweepRow, flight_fraction, to_markdown
from robots import ContactSchedule

FEET = ("left", "right")


@pytest.mark.parametrize(("duty", "expected"), [(0.6, 0.0), (0.5, 0.0), (0.45, 0.1), (0.35, 0.3)])
def test_flight_fraction_of_a_half_period_biped_schedule(duty: float, expected: float) -> None:
    schedule = ContactSchedule(0.5, FEET, (0.0, 0.5), (duty, duty))
    assert flight_fraction(schedule) == pytest.approx(expected, abs=2e-3)


def test_flight_fraction_of_a_pronk_and_a_stand() -> None:
    assert flight_fraction(ContactSchedule(0.5, FEET, (0.0, 0.0), (0.4, 0.4))) == \
        pytest.approx(0.6, abs=2e-3)
    assert flight_fraction(ContactSchedule(0.5, FEET, (0.0, 0.0), (1.0, 1.0))) == 0.0


def test_the_table_shows_the_flight_fraction() -> None:
    row = SweepRow(0.5, 0.1, "biped_run", "biped_run", 0.48, 0.42, 1.0, 1.0, 0.5, True, 10,
                   60.0, flight_fraction=0.16)
    table = to_markdown([row])
    assert "| flight |" in table.splitlines()[0]
    assert "| 0.42 | 0.16 | 0.480 |" in table
    assert math.isnan(SweepRow(0.5, 0.1, "w", "w", 1, 1, 1, 1, 1, True, 1, 1).flight_fraction)

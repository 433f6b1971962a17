"""robots.schedule.ContactSchedule.contact_matrix: boundaries that sit on knots."""

from __future__ import annotations

import numpy as np
import pytest

from robots import ContactSchedule


@pytest.mark.parametrize("nudge", [-1e-15, 0.0, 1e-15])
def test_a_touchdown_on_a_knot_holds_it_whichever_way_it_rounded(nudge: float) -> None:
    # 2·4/5 mod 1 = 0.6000000000000001: a hair after knot 18 of 30, which it used to lose
    sched = ContactSchedule(1.0, ("a", "b"), (0.0, 0.6 + nudge), (0.58, 0.58))
    contact = sched.contact_matrix(30)
    assert contact[:, 0].sum() == contact[:, 1].sum() == 18
    assert contact[18, 1] and not contact[17, 1]
    np.testing.assert_array_equal(np.roll(contact[:, 0], 18), contact[:, 1])


@pytest.mark.parametrize("nudge", [-1e-15, 0.0, 1e-15])
def test_a_lift_off_on_a_knot_is_swing_there(nudge: float) -> None:
    sched = ContactSchedule(1.0, ("a",), (0.0,), (0.5 + nudge,))
    contact = sched.contact_matrix(10)
    np.testing.assert_array_equal(contact[:, 0], [True] * 5 + [False] * 5)


def test_a_touchdown_at_phase_zero_and_a_full_duty_foot() -> None:
    sched = ContactSchedule(1.0, ("a", "b"), (0.0, 0.999999999999), (1.0, 0.5))
    contact = sched.contact_matrix(8)
    assert contact[:, 0].all()
    np.testing.assert_array_equal(contact[:, 1], [True] * 4 + [False] * 4)

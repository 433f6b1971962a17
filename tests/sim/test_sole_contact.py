"""The flat soles' contact log (`sim.sole_contact`): a standing biped stands flat on both soles."""

from __future__ import annotations

import math

import numpy as np
import pytest

import robots
from planner.library import stand_gait
from sim.errors import SimConfigError
from sim.sole_contact import edge_shares, sole_contact_log


def test_a_stand_is_flat_on_both_soles_with_the_cop_inside() -> None:
    bot = robots.load("biped")
    log = sole_contact_log(stand_gait(bot, 0.5), bot, cycles=2)
    held = log.gait_phase >= 0  # after the entry
    assert len(log.feet) == 2
    assert np.all(log.contacts[held] == 4)
    np.testing.assert_allclose(log.normal_force_n[held].sum(axis=1), log.weight_n, rtol=0.05)
    assert np.nanmax(np.abs(log.cop_fraction[held])) < 0.5
    shares = edge_shares(log, 0.0, 2.0)
    assert shares.steps == 0 and math.isnan(shares.on_edge)  # never on one foot


def test_point_feet_have_no_soles_to_log() -> None:
    bot = robots.load("quad12")
    with pytest.raises(SimConfigError, match="no flat feet"):
        sole_contact_log(stand_gait(bot, 0.5), bot, cycles=1)

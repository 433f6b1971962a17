"""`gaitsmith.gait_choice.commanded_gait`: turns and side-steps on robots whose default gait
stands on a support line plan a static walk; everything else keeps its gait and options."""

from __future__ import annotations

import pytest

import robots
from gaitsmith.gait_choice import (
    MEAN_FOOTPRINT_LEG_LENGTHS,
    STATIC_DUTY,
    STATIC_MARGIN_LEG_LENGTHS,
    always_on_polygon,
    commanded_gait,
    tips_on_a_line,
)
from planner.nlp.config import PlannerOptions
from tests.zoo.fixtures import ZOO

OPTIONS = PlannerOptions(mu=0.4)


@pytest.mark.parametrize("robot", ["quad12", str(ZOO / "spotmicro"), str(ZOO / "bittle8")])
@pytest.mark.parametrize(("vy", "yaw_rate"), [(0.05, 0.0), (0.0, 0.6), (0.0, -0.3)])
def test_quadrupeds_turn_and_side_step_with_a_static_walk(
    robot: str, vy: float, yaw_rate: float
) -> None:
    bot = robots.load(robot)
    choice = commanded_gait(bot, None, vy, yaw_rate, OPTIONS)
    assert choice.gait.endswith("walk") and choice.duty_factor == STATIC_DUTY
    assert always_on_polygon(bot, choice.gait, choice.duty_factor)
    assert not always_on_polygon(bot, "trot") and tips_on_a_line(bot, "trot")
    assert choice.options.static_margin_leg_lengths == STATIC_MARGIN_LEG_LENGTHS
    assert choice.options.mean_footprint_leg_lengths == MEAN_FOOTPRINT_LEG_LENGTHS
    assert choice.options.mu == 0.4  # the caller's options otherwise


def test_straight_explicit_and_polygon_gaits_are_kept() -> None:
    quad, hexa = robots.load("quad12"), robots.load("hex18")
    straight = commanded_gait(quad, None, 0.0, 0.0, OPTIONS)
    assert (straight.gait, straight.duty_factor, straight.options) == ("trot", None, OPTIONS)
    asked = commanded_gait(quad, "trot", 0.05, 0.5, OPTIONS)
    assert (asked.gait, asked.duty_factor, asked.options) == ("trot", None, OPTIONS)
    tripod = commanded_gait(hexa, None, 0.0, 0.6, OPTIONS)  # three feet down at every phase
    assert (tripod.gait, tripod.duty_factor, tripod.options) == ("tripod", None, OPTIONS)
    # star5's ripple stands on two feet for 0.14 τ at a time: short enough, and it turns in
    # MuJoCo; the static wave would not even plan
    star = robots.load(ZOO / "star5")
    assert not always_on_polygon(star, "ripple") and not tips_on_a_line(star, "ripple")
    ripple = commanded_gait(star, None, 0.0, 0.6, OPTIONS)
    assert (ripple.gait, ripple.duty_factor, ripple.options) == ("ripple", None, OPTIONS)


def test_bipeds_never_count_as_on_a_polygon() -> None:
    bot = robots.load(ZOO / "humanoid20")
    assert not always_on_polygon(bot, commanded_gait(bot, None, 0.0, 0.0, OPTIONS).gait)
    assert commanded_gait(bot, None, 0.05, 0.0, OPTIONS).duty_factor is None

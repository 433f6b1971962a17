"""The servo-limited template timing (planner.servo_limited): only where the swing slack < 1."""

from __future__ import annotations

import pytest

import robots
from planner.nlp.config import PlannerOptions
from planner.servo_limited import (
    SERVO_LIMITED_DUTY,
    SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS,
    SERVO_LIMITED_MAX_TILT_RAD,
    SERVO_LIMITED_ROTOR_RESERVE,
    SERVO_LIMITED_SLACK,
    servo_limited_schedule,
    servo_limited_timing,
)
from planner.swing_slack import swing_slack
from planner.templates import default_gait_for, make_schedule


def test_knee8_gets_the_shortest_period_with_the_slack() -> None:
    bot = robots.load("tests/zoo/knee8")
    timing = servo_limited_timing(bot, "walk", 0.182)
    assert timing is not None
    assert timing.template_slack == pytest.approx(
        swing_slack(bot, make_schedule(bot, "walk"), 0.182).ratio) and timing.template_slack < 1
    assert timing.duty_factor == SERVO_LIMITED_DUTY
    schedule = servo_limited_schedule(bot, timing)
    assert schedule.period_s == timing.period_s
    assert all(d == SERVO_LIMITED_DUTY for d in schedule.duty_factor)
    assert swing_slack(bot, schedule, 0.182).ratio >= SERVO_LIMITED_SLACK
    shorter = make_schedule(bot, "walk", period_s=timing.period_s - 0.005,
                            duty_factor=SERVO_LIMITED_DUTY)
    assert swing_slack(bot, shorter, 0.182).ratio < SERVO_LIMITED_SLACK
    assert 1.3 < timing.period_s < 1.4  # heavy_rotor.md §9: 1.373 s
    assert "servo-limited walk, duty 0.6" in timing.summary()


@pytest.mark.parametrize(("name", "speed"), [("quad12", 0.25), ("tests/zoo/bittle8", 0.13),
                                             ("tests/zoo/star5", 0.117)])
def test_robots_whose_servos_make_the_swing_are_untouched(name: str, speed: float) -> None:
    bot = robots.load(name)
    assert servo_limited_timing(bot, default_gait_for(bot), speed) is None


def test_no_timing_when_no_period_reaches_the_slack() -> None:
    # quad12's trot at 0.4 m/s: slack 0.99 at its template, already at duty 0.6, and no period
    # at that duty reaches the rule's slack: the template is kept (it passes MuJoCo there)
    bot = robots.load("quad12")
    assert swing_slack(bot, make_schedule(bot, "trot"), 0.4).ratio < 1
    assert servo_limited_timing(bot, "trot", 0.4) is None


def test_the_users_options_win() -> None:
    bot = robots.load("tests/zoo/knee8")
    timing = servo_limited_timing(bot, "walk", 0.182)
    assert timing is not None
    ruled = timing.options(PlannerOptions())
    assert ruled.rotor_reserve == SERVO_LIMITED_ROTOR_RESERVE
    assert ruled.line_capture_margin_leg_lengths == SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS
    assert ruled.max_tilt_rad == SERVO_LIMITED_MAX_TILT_RAD < PlannerOptions().max_tilt_rad
    own = timing.options(PlannerOptions(rotor_reserve=0.05, line_capture_margin_leg_lengths=0.1,
                                        max_tilt_rad=0.2))
    assert (own.rotor_reserve, own.line_capture_margin_leg_lengths) == (0.05, 0.1)
    assert own.max_tilt_rad == 0.2  # a tighter bound is kept

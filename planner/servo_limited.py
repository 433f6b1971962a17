"""A template timing for robots whose servos cannot make the template's swing.

`planner.swing_slack` compares a schedule's swing time with the fastest swing of its stride the
servo envelope allows. Below 1 the NLP is infeasible or sits on its envelope at the swing's
ends, where a heavy rotor then takes MuJoCo's peak torque over the verdict's limit
(docs/results/heavy_rotor.md §1, §6). On such a robot, and only there, the default command
plans the template at a servo-limited timing instead (`servo_limited_timing`):

- duty `SERVO_LIMITED_DUTY` = 0.6, the duty of the template library's dynamic gaits (trot,
  pace, tripod, biped walk). The swing's mean joint speed grows with d/(1 − d) whatever the
  period (the foot returns v·d·T in (1 − d)·T), so the duty, not the period, is what brings
  the swing under the servo's speed; at a four-beat walk's 0.75 no period gives knee8 slack 1
  below 10 s;
- the shortest period at that duty whose swing slack is at least `SERVO_LIMITED_SLACK`: the
  period only trades the rotor's acceleration (∝ 1/T at a fixed duty) against the stride
  (∝ T), so it is set by the slack it buys, with the rest of the envelope kept for the lift,
  gravity and the body's motion;
- the rotor reserve `SERVO_LIMITED_ROTOR_RESERVE` (`PlannerOptions.rotor_reserve`): the swing's
  ends are then rotor-dominated and MuJoCo's servo delivers the planned rotor torque with
  ≈ +0.04 of stall on average and ±0.06 from cycle to cycle (heavy_rotor.md §1); with the rotor
  share grown by ρ the plan keeps ≈ 0.8·ρ/(1 + ρ) of stall (0.10 at ρ 0.15) for that;
- the line-capture margin `SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS`
  (`PlannerOptions.line_capture_margin_leg_lengths`): a walk below duty 0.75 stands on two feet
  for 3 − 4d of its cycle, and an open-loop body whose capture point starts a line phase on
  the line falls back over the foot that has just lifted (heavy_rotor.md §7);
- the tilt bound `SERVO_LIMITED_MAX_TILT_RAD` (0.3 rad against the default 0.35, the verdict's
  20°): a hip-and-knee walk on lateral pairs balances by rolling the body onto the bound, and
  MuJoCo's body follows to 19.6–20.1° (heavy_rotor.md §9: at 0.35 the +1 % speed re-plan fails
  the tilt by 0.1°).

The constants are the values measured on knee8, the only zoo robot whose default template has
slack < 1 at issue #14's Froude number 0.02 (heavy_rotor.md §9: the window around them, in
which the knife-edge check gives 2–5 of 7, is narrow, so they are fitted to that one robot).
The user's own --gait, --period, --duty, --phases, --schedule, --rotor-reserve and
--line-capture-margin always win over the rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.nlp.config import GRAVITY_M_S2, PlannerOptions
from planner.swing_slack import swing_slack
from planner.templates import make_schedule
from robots import ContactSchedule, Robot

#: duty of the servo-limited timing (the templates' dynamic-gait duty)
SERVO_LIMITED_DUTY = 0.6
#: swing slack the servo-limited period gives (the shortest period at the duty reaching it)
SERVO_LIMITED_SLACK = 1.46
#: rotor reserve of the servo-limited timing (`PlannerOptions.rotor_reserve`)
SERVO_LIMITED_ROTOR_RESERVE = 0.15
#: line-capture margin of the servo-limited timing, in leg lengths
SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS = 0.16
#: the plan's tilt bound under the rule [rad] (`PlannerOptions.max_tilt_rad`, default 0.35 =
#: the verdict's 20°): the servo-limited walk rolls the body onto that bound to balance over its
#: lateral pairs, and MuJoCo's body follows it to 19.6–20.1°
SERVO_LIMITED_MAX_TILT_RAD = 0.3
#: the longest period the rule gives, in √(L/g) (a quadruped walk's template is 5)
MAX_PERIOD_SQRT_L_G = 20.0


@dataclass(frozen=True)
class ServoLimitedTiming:
    """The template timing and options the rule gives, and the slacks it was chosen from."""

    gait: str
    period_s: float
    duty_factor: float
    rotor_reserve: float
    line_capture_margin_leg_lengths: float
    template_slack: float  # the template's own timing
    slack: float  # at period_s, duty_factor
    joint: str  # the tightest joint at the template timing

    def options(self, options: PlannerOptions) -> PlannerOptions:
        """`options` with the rule's reserve and margin where the user left them unset."""
        from dataclasses import replace

        return replace(
            options,
            max_tilt_rad=min(options.max_tilt_rad, SERVO_LIMITED_MAX_TILT_RAD),
            rotor_reserve=(self.rotor_reserve if options.rotor_reserve is None
                           else options.rotor_reserve),
            line_capture_margin_leg_lengths=(
                self.line_capture_margin_leg_lengths
                if options.line_capture_margin_leg_lengths is None
                else options.line_capture_margin_leg_lengths))

    def summary(self) -> str:
        return (f"swing slack {self.template_slack:.2f} < 1 on {self.joint} at the template's "
                f"timing: servo-limited {self.gait}, duty {self.duty_factor:g}, period "
                f"{self.period_s:.3f} s (slack {self.slack:.2f}), rotor reserve "
                f"{self.rotor_reserve:g}, line-capture margin "
                f"{self.line_capture_margin_leg_lengths:g} L")


def servo_limited_timing(robot: Robot, gait: str, speed_m_s: float,
                         options: PlannerOptions | None = None) -> ServoLimitedTiming | None:
    """The rule's timing for the template `gait` at `speed_m_s`, or None when the template's
    own timing has swing slack ≥ 1 (then nothing changes) or no period up to
    `MAX_PERIOD_SQRT_L_G`·√(L/g) reaches `SERVO_LIMITED_SLACK` at `SERVO_LIMITED_DUTY`."""
    options = options or PlannerOptions()
    template = make_schedule(robot, gait)
    before = swing_slack(robot, template, speed_m_s, options)
    if before.ratio >= 1.0:
        return None
    t_max = MAX_PERIOD_SQRT_L_G * math.sqrt(robot.leg_length_m / GRAVITY_M_S2)

    def slack_at(period_s: float) -> float:
        s = make_schedule(robot, gait, period_s=period_s, duty_factor=SERVO_LIMITED_DUTY)
        return swing_slack(robot, s, speed_m_s, options).ratio

    if slack_at(t_max) < SERVO_LIMITED_SLACK:
        return None
    lo, hi = 0.0, t_max  # slack grows with the period at a fixed duty
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slack_at(mid) < SERVO_LIMITED_SLACK else (lo, mid)
    return ServoLimitedTiming(gait, hi, SERVO_LIMITED_DUTY, SERVO_LIMITED_ROTOR_RESERVE,
                              SERVO_LIMITED_LINE_CAPTURE_LEG_LENGTHS, before.ratio,
                              slack_at(hi), before.joint)


def servo_limited_schedule(robot: Robot, timing: ServoLimitedTiming) -> ContactSchedule:
    """The template schedule at the rule's timing."""
    return make_schedule(robot, timing.gait, period_s=timing.period_s,
                         duty_factor=timing.duty_factor)

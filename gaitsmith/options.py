"""Checks of option values and output paths, run before any expensive work.

Every check raises an `OptionError` (or `OutputError`) whose one-line message names the option,
the accepted range and the value given, so `gaitsmith.cli.main` can print it and exit with 2.
The ranges are those the planner and simulator accept (the limits they check themselves, late).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from gaitsmith.errors import OptionError, OutputError
from robots.errors import OutputWriteError
from robots.files import check_writable

if TYPE_CHECKING:
    from robots.robot import Robot

MAX_SPEED_M_S = 10.0  # planner.nlp.spacetime's own bound
KNOTS_RANGE = (8, 200)  # planner.nlp.spacetime's own bound
RATE_HZ_RANGE = (1.0, 10000.0)  # sim.rollout's own bound
MAX_LATENCY_MS = 1000.0  # sim.rollout's own bound (1 s)
MAX_CYCLES = 100_000
MAX_PERIOD_S = 60.0  # gait cycle period


def _interval(lo: float, hi: float, lo_open: bool, hi_open: bool) -> str:
    return f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def check_number(option: str, value: float | None, lo: float, hi: float, *,
                 lo_open: bool = False, hi_open: bool = False, unit: str = "") -> None:
    """`value` (None: not given, nothing to check) must be finite and in the interval."""
    if value is None:
        return
    above = value > lo if lo_open else value >= lo
    below = value < hi if hi_open else value <= hi
    if not (math.isfinite(value) and above and below):
        interval = _interval(lo, hi, lo_open, hi_open) + (f" {unit}" if unit else "")
        raise OptionError(f"{option} must be a number in {interval}, got {value:g}")


def check_integer(option: str, value: int | None, lo: int, hi: int) -> None:
    """`value` (None: not given) must lie in [lo, hi]."""
    if value is not None and not lo <= value <= hi:
        raise OptionError(f"{option} must be an integer in [{lo}, {hi}], got {value}")


def check_choice(option: str, value: str, choices: tuple[str, ...]) -> None:
    """`value` must be one of `choices`."""
    if value not in choices:
        raise OptionError(f"{option} must be one of {', '.join(choices)}, got {value!r}")


def check_speed(option: str, value: float, *, allow_zero: bool = True) -> None:
    """A forward speed: ≥ 0 (> 0 when cost of transport and Froude number must exist)."""
    check_number(option, value, 0.0, MAX_SPEED_M_S, lo_open=not allow_zero, unit="m/s")


def check_velocity(option: str, value: float) -> None:
    """A body-frame velocity component that may be negative (backwards, to the right)."""
    check_number(option, value, -MAX_SPEED_M_S, MAX_SPEED_M_S, unit="m/s")


#: The largest yaw rate the CLI plans, in units of √(g/L) (L: the robot's leg length). The feet
#: stand about a leg length from the turning centre, so they sweep at W·L: at W = 0.5·√(g/L)
#: that is a Froude number (W·L)²/(g·L) = 0.25, half the walk-to-run transition (Fr ≈ 0.5,
#: Alexander & Jayes 1983) — a turning speed no walking gait reaches. 3.7 rad/s at L = 0.18 m.
MAX_YAW_RATE_SQRT_G_PER_L = 0.5


def max_yaw_rate_rad_s(robot: Robot) -> float:
    """`MAX_YAW_RATE_SQRT_G_PER_L`·√(g/L) for `robot`'s leg length L."""
    return MAX_YAW_RATE_SQRT_G_PER_L * math.sqrt(9.81 / robot.leg_length_m)


def check_yaw_rate(option: str, value: float, robot: Robot) -> None:
    """A yaw rate [rad/s] within ±`max_yaw_rate_rad_s` (scaled with the robot's leg length)."""
    bound = max_yaw_rate_rad_s(robot)
    check_number(option, value, -bound, bound,
                 unit=f"rad/s (0.5·√(g/L) for {robot.name}'s {robot.leg_length_m:.3f} m legs)")


def check_knots(option: str, value: int) -> None:
    check_integer(option, value, *KNOTS_RANGE)


def check_friction(option: str, value: float | None) -> None:
    check_number(option, value, 0.0, 10.0, lo_open=True)


def check_cycles(option: str, value: int) -> None:
    """Simulated cycles: more than the warm-up cycles the verdict skips (sim.validate)."""
    from sim.validate import PassCriteria  # lazy: only commands that simulate pay for MuJoCo

    check_integer(option, value, PassCriteria().warmup_cycles + 1, MAX_CYCLES)


def check_output_file(option: str, path: Path) -> None:
    """The file `path` can be written later: its folder exists or can be created, is writable
    and not full — checked now so that a long run does not end in a write error."""
    try:
        check_writable(path)
    except OutputWriteError as exc:
        raise OutputError(f"{option} {exc}") from None


def check_output_dir(option: str, path: Path) -> None:
    """Like `check_output_file` for an output folder."""
    try:
        check_writable(path, directory=True)
    except OutputWriteError as exc:
        raise OutputError(f"{option} {exc}") from None


def check_supply_v(option: str, value: float | None, robot: Robot) -> None:
    """A supply voltage (None: not given) every servo of `robot` accepts."""
    from robots.voltage import voltage_range_v

    if value is None:
        return
    lo, hi = voltage_range_v(robot)
    if lo > hi:
        raise OptionError(f"{option}: the servos of {robot.name} share no supply voltage range")
    servos = ", ".join(sorted({j.servo.name for j in robot.joints}))
    check_number(option, value, lo, hi, unit=f"V (the supply range of {servos})")

"""Checks of option values and output paths, run before any expensive work.

Every check raises an `OptionError` (or `OutputError`) whose one-line message names the option,
the accepted range and the value given, so `gaitsmith.cli.main` can print it and exit with 2.
The ranges are those the planner and simulator accept (the limits they check themselves, late).
"""

from __future__ import annotations

import math
from pathlib import Path

from gaitsmith.errors import OptionError, OutputError
from robots.errors import OutputWriteError
from robots.files import check_writable

MAX_SPEED_M_S = 10.0  # planner.spacetime's own bound
KNOTS_RANGE = (8, 200)  # planner.spacetime's own bound
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


def check_speed(option: str, value: float, *, allow_zero: bool = True) -> None:
    """A forward speed: ≥ 0 (> 0 when cost of transport and Froude number must exist)."""
    check_number(option, value, 0.0, MAX_SPEED_M_S, lo_open=not allow_zero, unit="m/s")


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

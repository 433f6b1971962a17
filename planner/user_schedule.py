"""A contact schedule given by the user: `--phases`/`--duty` on the command line or a file.

Command line (values in `robot.legs` order, the order of robot.toml's ``[legs.*]`` tables)::

    gaitsmith plan DIR --phases 0,0.5,0.25,0.75 --duty 0.6          # one duty for every leg
    gaitsmith plan DIR --phases 0,0.5,0.25,0.75 --duty 0.6,0.6,0.7,0.7
    gaitsmith plan DIR --gait wave --duty 0.7,0.7,0.8,0.8,0.8       # per-leg duty on a template

File (`--schedule FILE`, JSON or TOML by suffix), keyed by leg name; ``period_s`` optional::

    period_s = 0.8
    [legs.fl]
    touchdown_phase = 0.0
    duty_factor = 0.6
    ...

    {"period_s": 0.8, "legs": {"fl": {"touchdown_phase": 0.0, "duty_factor": 0.6}, ...}}

Every error is one line naming the option or file field and the leg at fault.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

from planner.errors import PlannerConfigError
from planner.templates import default_period_s, label_gait
from robots import ContactSchedule, Robot

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise PlannerConfigError(f"{where} must be a number, got {value!r}")
    return float(value)


def _phase(value: Any, where: str) -> float:
    v = _number(value, where)
    if not 0.0 <= v < 1.0:
        raise PlannerConfigError(f"{where} must be a touchdown phase in [0, 1), got {v:g}")
    return v


def _duty(value: Any, where: str) -> float:
    v = _number(value, where)
    if not 0.0 < v <= 1.0:
        raise PlannerConfigError(f"{where} must be a duty factor in (0, 1], got {v:g}")
    return v


def _split(text: str, option: str) -> list[Any]:
    out: list[Any] = []
    for i, cell in enumerate(text.split(",")):
        try:
            out.append(float(cell.strip()))
        except ValueError:
            raise PlannerConfigError(
                f"{option}: value {i + 1} ({cell.strip()!r}) is not a number; give numbers "
                "separated by commas"
            ) from None
    return out


def parse_duty(text: str, robot: Robot) -> tuple[float, ...]:
    """`--duty 0.6` (every leg) or `--duty 0.6,0.7,…` (one per leg, robot.legs order)."""
    values = _split(text, "--duty")
    legs = robot.foot_names
    if len(values) == 1:
        return (_duty(values[0], "--duty"),) * len(legs)
    if len(values) != len(legs):
        raise PlannerConfigError(
            f"--duty has {len(values)} values, {robot.name} has {len(legs)} legs "
            f"({', '.join(legs)}); give one value or one per leg in that order"
        )
    return tuple(_duty(v, f"--duty for leg {leg}") for v, leg in zip(values, legs, strict=True))


def parse_phases(text: str, robot: Robot) -> tuple[float, ...]:
    """`--phases 0,0.5,…`: one touchdown phase per leg in robot.legs order."""
    values = _split(text, "--phases")
    legs = robot.foot_names
    if len(values) != len(legs):
        raise PlannerConfigError(
            f"--phases has {len(values)} values, {robot.name} has {len(legs)} legs "
            f"({', '.join(legs)}); give one touchdown phase per leg in that order"
        )
    return tuple(_phase(v, f"--phases for leg {leg}") for v, leg in zip(values, legs, strict=True))


def default_user_period_s(
    robot: Robot, phases: tuple[float, ...], duty: tuple[float, ...]
) -> float:
    """The period of the template the schedule is closest to (`label_gait`), for this robot."""
    probe = ContactSchedule(1.0, robot.foot_names, phases, duty)
    return default_period_s(robot, label_gait(probe, robot))


def schedule_from_options(
    robot: Robot, phases: str, duty: str | None, period_s: float | None
) -> ContactSchedule:
    """The schedule of `--phases` (+ `--duty`, default 0.6, + `--period`)."""
    ph = parse_phases(phases, robot)
    du = parse_duty(duty, robot) if duty is not None else (0.6,) * len(ph)
    period = default_user_period_s(robot, ph, du) if period_s is None else period_s
    return ContactSchedule(float(period), robot.foot_names, ph, du)


def load_schedule_file(
    path: str | Path, robot: Robot, period_s: float | None = None
) -> ContactSchedule:
    """A schedule file (JSON or TOML) keyed by leg name; `period_s` overrides the file's."""
    p = Path(path)
    name = str(p)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PlannerConfigError(f"--schedule {name}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PlannerConfigError(f"--schedule {name}: cannot read it ({exc})") from None
    data: Any
    try:
        if p.suffix.lower() == ".toml":
            data = tomllib.loads(text)
        elif p.suffix.lower() == ".json":
            data = json.loads(text)
        else:
            raise PlannerConfigError(f"--schedule {name}: use a .json or .toml file")
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise PlannerConfigError(f"{name}: not valid {p.suffix[1:].upper()}: {exc}") from None
    if not isinstance(data, dict):
        raise PlannerConfigError(f"{name}: the top level must be a table/object")
    unknown = sorted(set(data) - {"period_s", "legs"})
    if unknown:
        raise PlannerConfigError(f"{name}: unknown field {unknown[0]!r}; allowed: legs, period_s")
    legs = data.get("legs")
    if not isinstance(legs, dict) or not legs:
        raise PlannerConfigError(
            f"{name}: legs: missing; give one table per leg ({', '.join(robot.foot_names)}) "
            "with touchdown_phase and duty_factor"
        )
    for leg in legs:
        if leg not in robot.foot_names:
            raise PlannerConfigError(
                f"{name}: legs.{leg}: {robot.name} has no leg {leg!r}; its legs: "
                f"{', '.join(robot.foot_names)}"
            )
    phases, duties = [], []
    for leg in robot.foot_names:
        entry = legs.get(leg)
        where = f"{name}: legs.{leg}"
        if entry is None:
            raise PlannerConfigError(f"{where}: missing; every leg needs touchdown_phase and "
                                     "duty_factor")
        if not isinstance(entry, dict):
            raise PlannerConfigError(f"{where}: must be a table with touchdown_phase and "
                                     "duty_factor")
        extra = sorted(set(entry) - {"touchdown_phase", "duty_factor"})
        if extra:
            raise PlannerConfigError(f"{where}.{extra[0]}: unknown field; allowed: "
                                     "touchdown_phase, duty_factor")
        for key in ("touchdown_phase", "duty_factor"):
            if key not in entry:
                raise PlannerConfigError(f"{where}.{key}: missing")
        phases.append(_phase(entry["touchdown_phase"], f"{where}.touchdown_phase"))
        duties.append(_duty(entry["duty_factor"], f"{where}.duty_factor"))
    period = period_s
    if period is None and "period_s" in data:
        period = _number(data["period_s"], f"{name}: period_s")
        if period <= 0:
            raise PlannerConfigError(f"{name}: period_s must be positive, got {period:g}")
    if period is None:
        period = default_user_period_s(robot, tuple(phases), tuple(duties))
    return ContactSchedule(float(period), robot.foot_names, tuple(phases), tuple(duties))


def command_schedule(
    robot: Robot,
    gait: str,
    *,
    phases: str | None = None,
    duty: str | None = None,
    schedule_file: str | Path | None = None,
    period_s: float | None = None,
) -> tuple[ContactSchedule, str]:
    """The schedule `gaitsmith plan` solves and the gait label it writes.

    `--schedule FILE` or `--phases` (with optional `--duty`) replace the template (label
    ``"custom"``); otherwise the template `gait` with `--duty` (one value or one per leg) and
    `--period` applied.
    """
    from planner.templates import make_schedule

    if schedule_file is not None:
        if phases is not None or duty is not None:
            raise PlannerConfigError(
                "--schedule gives every leg's phase and duty factor; drop --phases/--duty"
            )
        return load_schedule_file(schedule_file, robot, period_s), "custom"
    if phases is not None:
        return schedule_from_options(robot, phases, duty, period_s), "custom"
    schedule = make_schedule(robot, gait, period_s=period_s)
    if duty is not None:
        schedule = ContactSchedule(
            schedule.period_s, schedule.feet, schedule.touchdown_phase, parse_duty(duty, robot)
        )
    return schedule, gait

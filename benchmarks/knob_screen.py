"""Screen planner knobs one at a time: plan a template, validate it in MuJoCo, print one row.

    python benchmarks/knob_screen.py tests/zoo/humanoid20 0.215 base
    python benchmarks/knob_screen.py tests/zoo/humanoid20 0.215 tm0.6 torque_margin=0.6 knots=36

Arguments: robot (built-in name or folder), commanded speed [m/s], a row label, then any number
of `key=value`: `knots`, `period` [s], `duty`, `gait` (default: the robot's default gait),
`mirror` (0/1, `PlannerOptions.half_cycle_mirror`), `cycles` (default 20), and any float field of
`planner.nlp.config.PlannerOptions` (torque_margin, speed_margin, swing_clearance_m,
min_base_height_fraction, cop_sole_fraction, …). Prints one JSON row (verdict, each check's
detail, the three joints with the highest MuJoCo peak torque, wall time) and appends it to
`--out` (default knob_screen.jsonl in the working directory). Used for docs/results/zoo_gaits.md
"Session 23: humanoid20".
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import robots
from gaitsmith.gait_choice import default_gait
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.user_schedule import command_schedule
from sim.validate import validate

INT_KEYS = ("knots", "cycles")
STR_KEYS = ("duty", "gait")


def parse(pairs: list[str]) -> dict[str, Any]:
    """`key=value` pairs → typed keyword arguments of `screen`."""
    out: dict[str, Any] = {}
    for pair in pairs:
        key, value = pair.split("=", 1)
        if key == "mirror":
            out[key] = value == "1"
        elif key in INT_KEYS:
            out[key] = int(value)
        elif key in STR_KEYS:
            out[key] = value
        else:
            out[key] = float(value)
    return out


def screen(robot: str, speed_m_s: float, label: str, *, knots: int = 30,
           period: float | None = None, duty: str | None = None, gait: str | None = None,
           mirror: bool = False, cycles: int = 20, **options: float) -> dict[str, Any]:
    """Plan (`GaitPlanner`, the template schedule with the given period/duty) and validate."""
    t0 = time.perf_counter()
    bot = robots.load(robot)
    gait = gait or default_gait(bot)
    schedule, label_gait = command_schedule(bot, gait, duty=duty, period_s=period)
    planner = GaitPlanner(bot, n_knots=knots,
                          options=PlannerOptions(half_cycle_mirror=mirror, **options))  # type: ignore[arg-type]
    result = planner.solve(schedule, speed_m_s)
    row: dict[str, Any] = {"label": label, "gait": gait, "period_s": round(schedule.period_s, 3),
                           "duty": schedule.duty_factor[0], "knots": knots,
                           "feasible": result.feasible, "message": result.message}
    if result.feasible:
        v = validate(planner.to_gait(result, label_gait), bot, cycles)
        row.update(passed=v.passed, reasons=list(v.reasons),
                   checks={name: detail for name, _, detail in v.checks},
                   top_torque=[(j.name, round(j.peak_torque_fraction, 2)) for j in
                               sorted(v.joints, key=lambda j: -j.peak_torque_fraction)[:3]])
    row["wall_s"] = round(time.perf_counter() - t0, 1)
    return row


def main(argv: list[str]) -> None:
    out = Path("knob_screen.jsonl")
    if "--out" in argv:
        i = argv.index("--out")
        out = Path(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    if len(argv) < 3 or argv[0] in ("-h", "--help"):
        print(__doc__)
        raise SystemExit(0 if argv and argv[0] in ("-h", "--help") else 2)
    robot, speed, label, *pairs = argv
    try:
        speed_m_s = float(speed)
    except ValueError:
        raise SystemExit(f"error: speed {speed!r} is not a number [m/s]") from None
    row = screen(robot, speed_m_s, label, **parse(pairs))
    print(json.dumps(row), flush=True)
    with out.open("a") as f:
        f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])

"""IPOPT/MUMPS linear-algebra options on one planner (docs/results/planner_speed_rows.md).

    python benchmarks/ipopt_linear_screen.py --robot quad12 --variants base,refine0

Every variant is its own IPOPT instance on the same built NLP; the robot's templates (and
`--random` random schedules) are solved cold, the variants alternating schedule by schedule.
Prints per schedule the iterations, cost and process CPU, then per variant the iterations, CPU
per iteration against the first variant and on how many schedules the iterates were the same
(x bit for bit and the same iteration count).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from planner.errors import PlannerConfigError
from planner.nlp import spacetime
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.templates import default_gait_for, make_schedule, templates_for

sys.path.insert(0, str(Path(__file__).resolve().parent))
from planner_bench import random_schedule

#: IPOPT options added to the planner's own (`planner.nlp.spacetime.ipopt_options`)
VARIANTS: dict[str, dict[str, Any]] = {
    "base": {},
    "refine0": {"min_refinement_steps": 0},
    "pivtol1e-8": {"mumps_pivtol": 1e-8},
    "pivtol0": {"mumps_pivtol": 0.0},
}


def _with_extra(original: Callable[[PlannerOptions, bool], dict[str, Any]],
                extra: dict[str, Any], options: PlannerOptions, warm: bool) -> dict[str, Any]:
    return {**original(options, warm), **extra}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--random", type=int, default=0)
    ap.add_argument("--variants", default="base,refine0")
    args = ap.parse_args()
    names = [v.strip() for v in args.variants.split(",") if v.strip()]
    unknown = [v for v in names if v not in VARIANTS]
    if unknown or not names:
        ap.error(f"--variants {args.variants!r}: name some of {', '.join(VARIANTS)}")
    robot = robots.load(args.robot)
    planner = GaitPlanner(robot, 30, PlannerOptions())
    original = spacetime.ipopt_options
    solvers = {}
    for name in names:
        spacetime.ipopt_options = partial(_with_extra, original, VARIANTS[name])
        solvers[name] = planner._make_solver()
    spacetime.ipopt_options = original
    rng = np.random.default_rng(0)
    base = make_schedule(robot, default_gait_for(robot))
    schedules = [(t, make_schedule(robot, t)) for t in templates_for(robot)]
    schedules += [(f"random{i}", random_schedule(base, rng)) for i in range(args.random)]
    cpu = {n: 0.0 for n in names}
    its = {n: 0 for n in names}
    same = {n: 0 for n in names}
    count = 0
    for label, schedule in schedules:
        results: dict[str, tuple[PlanResult, float]] = {}
        for name in names:
            planner._solver = solvers[name]
            try:
                t0 = time.process_time()
                res = planner.solve(schedule, args.speed, warm_start=False)
            except PlannerConfigError:
                break  # e.g. "stand" at a moving speed
            results[name] = (res, time.process_time() - t0)
        if len(results) < len(names):
            continue
        count += 1
        first = results[names[0]][0]
        line = []
        for name, (res, c) in results.items():
            cpu[name] += c
            its[name] += res.iterations
            same[name] += bool(res.iterations == first.iterations
                               and np.array_equal(res.warm_start.x, first.warm_start.x))
            verdict = "feasible" if res.feasible else res.status
            line.append(f"{name} {res.iterations} it {res.cost:.7g} {verdict} CPU {c:.2f} s")
        print(f"  {label}: " + " | ".join(line), flush=True)
    ms0 = 1e3 * cpu[names[0]] / max(1, its[names[0]])
    for name in names:
        ms = 1e3 * cpu[name] / max(1, its[name])
        print(f"{name}: {its[name]} it, CPU {cpu[name]:.2f} s, {ms:.1f} ms/it "
              f"({ms / ms0:.3f}x), same iterates {same[name]}/{count}")


if __name__ == "__main__":
    main()

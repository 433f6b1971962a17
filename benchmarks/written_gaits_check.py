"""Issue #16 "the written gaits pass MuJoCo as before": every template, planned on each
derivative path, written as a gait file and validated in MuJoCo as `gaitsmith plan --simulate`
does (same cycles, default pass criteria).

    python benchmarks/written_gaits_check.py [--robot quad12] [--paths expanded,knot]
                                             [--knots 30] [--out out/written_gaits]

One planner per path (built once), cold solves of every template at the robot's benchmark speed
(quad12 0.25 m/s, hex18 0.15 m/s, as `planner_bench.py --section compare`). Prints per template
and path the cost, the MuJoCo verdict and achieved speed, the largest joint-angle difference
between the two paths' written gaits, and whether every verdict agrees with the first path's.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from gaitsmith.plan_cmd import simulated_cycles
from planner.errors import PlannerConfigError
from planner.nlp.config import DERIVATIVE_PATHS, PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule, templates_for
from sim.validate import validate

SPEEDS_M_S = {"quad12": 0.25, "hex18": 0.15}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", choices=tuple(SPEEDS_M_S), default="quad12")
    ap.add_argument("--paths", default="expanded,knot")
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--out", type=Path, default=Path("out/written_gaits"))
    args = ap.parse_args()
    paths = [p.strip() for p in args.paths.split(",") if p.strip()]
    if len(paths) < 2 or any(p not in DERIVATIVE_PATHS for p in paths):
        ap.error(f"--paths {args.paths!r}: name two or more of {', '.join(DERIVATIVE_PATHS)}")
    bot = robots.load(args.robot)
    speed = SPEEDS_M_S[args.robot]
    out = args.out / args.robot
    out.mkdir(parents=True, exist_ok=True)
    print(f"{args.robot} N={args.knots} at {speed} m/s, paths {', '.join(paths)}, "
          f"{time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC, load average "
          f"{os.getloadavg()[0]:.2f}", flush=True)
    planners = {}
    for p in paths:
        planners[p] = GaitPlanner(bot, args.knots, PlannerOptions(derivatives=p))
        print(f"  build {p}: {planners[p].build_time_s:.1f} s", flush=True)
    agree = total = 0
    for name in templates_for(bot):
        schedule = make_schedule(bot, name)
        cells, verdicts, angles = [], [], []
        try:
            for p in paths:
                res = planners[p].solve(schedule, speed, warm_start=False)
                gait = planners[p].to_gait(res, name)
                cycles, _ = simulated_cycles(gait, None)
                v = validate(gait, bot, cycles)
                gait = gait.with_validation(v.to_dict())
                robots.gait.save(gait, out / f"{name}_{p}.json")
                verdicts.append(v.passed)
                angles.append(np.asarray(res.joint_angles_rad))
                cells.append(
                    f"{p} cost {res.cost:.6g} {'feasible' if res.feasible else res.status}, "
                    f"MuJoCo {'pass' if v.passed else 'FAIL'} "
                    f"{v.metrics.achieved_speed_m_s:.3f} m/s"
                    + ("" if v.passed else f" ({v.reasons[0][:60]})"))
        except PlannerConfigError as exc:  # e.g. "stand" at a moving speed
            print(f"  {name}: not a plan ({exc})", flush=True)
            continue
        total += 1
        same = all(v == verdicts[0] for v in verdicts)
        agree += same
        dq = max(float(np.max(np.abs(a - angles[0]))) for a in angles[1:])
        print(f"  {name}: " + " | ".join(cells) + f" | max |Δq| {dq:.1e} rad | "
              f"{'same verdict' if same else 'VERDICT DIFFERS'}", flush=True)
    print(f"  same MuJoCo verdict on {agree}/{total} templates; gaits written to {out}")


if __name__ == "__main__":
    main()

"""MUMPS fill-reducing orderings on the planner's KKT systems: one process, alternating.

    python benchmarks/mumps_order_screen.py [--cases quad12:trot:12,quad12:trot:30,...]
                                            [--orders 5,0,2,4,6] [--reps 2]

Per case (robot:template:knots) one planner is built; for every MUMPS ordering
(IPOPT's ``mumps_pivot_order``: 0 AMD, 2 AMF, 3 SCOTCH, 4 PORD, 5 METIS (the planner's),
6 QAMD, 7 automatic) an IPOPT instance of the same NLP is made, and the template is solved cold
with each in turn, `--reps` rounds, so the orderings share the load. Prints iterations, cost
and CPU seconds per iteration (this process, `time.process_time`) per ordering, and the median
ratio to METIS.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import robots
from planner.nlp import spacetime
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule

ORDER_NAMES = {0: "AMD", 2: "AMF", 3: "SCOTCH", 4: "PORD", 5: "METIS", 6: "QAMD", 7: "auto"}


def solver_with_order(planner: GaitPlanner, order: int) -> Any:
    """An IPOPT instance of `planner`'s NLP whose MUMPS uses `order`."""
    base = spacetime.ipopt_options

    def patched(options: PlannerOptions, warm: bool) -> dict[str, Any]:
        out = base(options, warm)
        out["mumps_pivot_order"] = order
        return out

    spacetime.ipopt_options = patched  # type: ignore[assignment]
    try:
        return planner._make_solver()
    finally:
        spacetime.ipopt_options = base  # type: ignore[assignment]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default="quad12:trot:12,quad12:trot:30,hex18:tripod:12,"
                                       "hex18:tripod:30")
    ap.add_argument("--orders", default="5,0,2,4,6")
    ap.add_argument("--reps", type=int, default=2)
    args = ap.parse_args()
    orders = [int(o) for o in args.orders.split(",")]
    bad = [o for o in orders if o not in ORDER_NAMES]
    if bad:
        raise SystemExit(f"--orders: expected values of {sorted(ORDER_NAMES)}, got {bad}")
    print(f"load {os.getloadavg()[0]:.2f}, {time.strftime('%H:%M:%S', time.gmtime())} UTC",
          flush=True)
    for case in args.cases.split(","):
        name, template, knots = case.split(":")
        robot = robots.load(name)
        planner = GaitPlanner(robot, int(knots), PlannerOptions())
        schedule = make_schedule(robot, template)
        solvers = {o: solver_with_order(planner, o) for o in orders}
        per_it: dict[int, list[float]] = {o: [] for o in orders}
        seen: dict[int, tuple[int, float]] = {}
        for _ in range(args.reps):
            for o in orders:
                planner._solver = solvers[o]
                c0 = time.process_time()
                r = planner.solve(schedule, 0.25 if name == "quad12" else 0.15, warm_start=False)
                cpu = time.process_time() - c0
                per_it[o].append(cpu / max(r.iterations, 1))
                seen[o] = (r.iterations, r.cost)
        ref = statistics.median(per_it[5]) if 5 in per_it else None
        for o in orders:
            med = statistics.median(per_it[o])
            ratio = f"{med / ref:.2f}" if ref else "-"
            runs = ", ".join(f"{1e3 * v:.1f}" for v in per_it[o])
            print(f"{case:20s} {ORDER_NAMES[o]:6s} {seen[o][0]:3d} it cost {seen[o][1]:.6f} "
                  f"{1e3 * med:6.1f} ms CPU/it (runs {runs}) ratio to METIS {ratio}", flush=True)
    print(f"load {os.getloadavg()[0]:.2f}, {time.strftime('%H:%M:%S', time.gmtime())} UTC")


if __name__ == "__main__":
    main()

"""Gait-search benchmark: one full basin-CMA search for quad12 at one speed, serial vs process pool.

    python benchmarks/gait_search_bench.py [--speed 0.25] [--generations 6] [--workers 2]
                                           [--sim-accept]

Target (issue 5): a full search finishes in ≤60 s on 2 cores. "Full" is what `gaitsmith plan
ROBOT --speed V --search` runs by default: template seeds, 6 basin-CMA generations of the coarse
(12-knot) NLP, then the final 30-knot solve of the best timings; `--sim-accept` adds the MuJoCo
acceptance check of every feasible sample and of the final gait (the command line's default).
Prints wall time (process start-up and every NLP build included), local solves, solves per
second and the process-pool speed-up over serial measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import robots
from planner.search.gait_search import search_gait
from sim.acceptance import SimAcceptance
from sim.validate import PassCriteria


def run(
    executor: str, speed: float, generations: int, workers: int, seed: int, sim_accept: bool
) -> tuple[float, int, str, float]:
    robot = robots.load("quad12")
    root = str(robot.root_dir)
    acceptance = (
        {"acceptance": SimAcceptance(root),
         "final_acceptance": SimAcceptance(root, 20, PassCriteria())}
        if sim_accept else {}
    )
    t0 = time.perf_counter()
    result = search_gait(
        robot, speed, max_generations=generations, seed=seed, executor=executor, workers=workers,
        **acceptance,  # type: ignore[arg-type]
    )
    wall = time.perf_counter() - t0
    return (
        wall,
        result.cma.n_local_solves + len(result.template_costs),
        result.label,
        result.search_cost,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--generations", type=int, default=6)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sim-accept", action="store_true", help="MuJoCo acceptance of samples")
    args = ap.parse_args()
    print(
        f"quad12 gait search at {args.speed} m/s, {args.generations} generations, "
        f"sim acceptance {'on' if args.sim_accept else 'off'}, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    times = {}
    for executor in ("serial", "process"):
        wall, solves, label, cost = run(
            executor, args.speed, args.generations, args.workers, args.seed, args.sim_accept
        )
        times[executor] = wall
        print(
            f"  {executor:8s} {wall:7.1f} s  {solves:4d} solves  {solves / wall:5.2f} solves/s  "
            f"best {label} search cost {cost:.5g}  {'OK' if wall <= 60 else 'over'} the 60 s target"
        )
    print(
        f"  process-pool speed-up over serial: {times['serial'] / times['process']:.2f}x "
        f"({args.workers} workers)"
    )


if __name__ == "__main__":
    main()

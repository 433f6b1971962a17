"""Gait-search benchmark: one full basin-CMA search for quad12 at one speed, serial vs process pool.

    python benchmarks/gait_search_bench.py [--speed 0.25] [--generations 4] [--workers 2]

Target (issue 5): a full search finishes in ≤60 s on 2 cores. Prints wall time, local solves,
solves per second and the process-pool speed-up over serial measured in the same run (the pool's
workers each build their NLP once; that build time is part of the pool's wall time).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import robots
from planner.gait_search import search_gait


def run(
    executor: str, speed: float, generations: int, workers: int, seed: int
) -> tuple[float, int, str, float]:
    robot = robots.load("quad12")
    t0 = time.perf_counter()
    result = search_gait(
        robot, speed, max_generations=generations, seed=seed, executor=executor, workers=workers
    )
    wall = time.perf_counter() - t0
    return (
        wall,
        result.cma.n_local_solves + len(result.template_costs),
        result.label,
        result.best.cost,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--generations", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(
        f"quad12 gait search at {args.speed} m/s, {args.generations} generations, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    times = {}
    for executor in ("serial", "process"):
        wall, solves, label, cost = run(
            executor, args.speed, args.generations, args.workers, args.seed
        )
        times[executor] = wall
        print(
            f"  {executor:8s} {wall:7.1f} s  {solves:4d} solves  {solves / wall:5.2f} solves/s  "
            f"best {label} cost {cost:.5g}  {'OK' if wall <= 60 else 'over'} the 60 s target"
        )
    print(
        f"  process-pool speed-up over serial: {times['serial'] / times['process']:.2f}x "
        f"({args.workers} workers)"
    )


if __name__ == "__main__":
    main()

"""CPU and wall time per call of each NLP function IPOPT evaluates, solver paths side by side.

    python benchmarks/nlp_function_times.py quad12 trot knot,knot-t2 3

Builds one planner per `planner_bench.PATHS` name (N = 30) and cold-solves the robot's template
`reps` times, the paths in turn, at 0.25 m/s. Per solve and as medians it prints, for
``nlp_hess_l``, ``nlp_jac_g``, ``nlp_grad_f``, ``nlp_g`` and ``nlp_f``, CasADi's
``t_proc/n_call`` and ``t_wall/n_call`` in ms: CPU time per call barely moves with the load of a
shared machine, wall time does (docs/results/planner_speed_threads.md).
"""

from __future__ import annotations

import os
import statistics
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

from planner_bench import PATHS

import robots
from planner.templates import make_schedule

FUNCTIONS = ("nlp_hess_l", "nlp_jac_g", "nlp_grad_f", "nlp_g", "nlp_f")


def main() -> None:
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    robot_name, gait, names, reps = sys.argv[1], sys.argv[2], sys.argv[3].split(","), sys.argv[4]
    robot = robots.load(robot_name)
    planners = {name: PATHS[name](robot, 30) for name in names}
    schedule = make_schedule(robot, gait)
    rows: dict[str, list[dict[str, tuple[float, float]]]] = {name: [] for name in names}
    solves: dict[str, list[tuple[float, int, float]]] = {name: [] for name in names}
    for _ in range(int(reps)):
        for name, planner in planners.items():
            result = planner.solve(schedule, 0.25, warm_start=False)
            stats = planner._solver.stats()
            row = {
                f: (stats[f"t_proc_{f}"] / stats[f"n_call_{f}"] * 1e3,
                    stats[f"t_wall_{f}"] / stats[f"n_call_{f}"] * 1e3)
                for f in FUNCTIONS
            }
            rows[name].append(row)
            solves[name].append((result.solve_time_s, result.iterations, result.cost))
            print(f"{name} solve {result.solve_time_s:.2f} s {result.iterations} it cost "
                  f"{result.cost:.9g} " + " ".join(
                      f"{f[4:]} {cpu:.1f}/{wall:.1f}" for f, (cpu, wall) in row.items()),
                  flush=True)
    print(f"median per call (ms, CPU/wall), {robot_name} {gait} N=30, {reps} reps, "
          f"load {os.getloadavg()[0]:.1f}")
    for name in names:
        cells = " ".join(
            f"{f[4:]} {statistics.median(r[f][0] for r in rows[name]):.1f}/"
            f"{statistics.median(r[f][1] for r in rows[name]):.1f}" for f in FUNCTIONS)
        time_s = statistics.median(s[0] for s in solves[name])
        print(f"{name} {cells} solve median {time_s:.2f} s, {solves[name][0][1]} it")


if __name__ == "__main__":
    main()

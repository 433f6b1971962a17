"""Replay a recorded gait search's coarse local solves on several planner paths, interleaved in
one process, and check that every path takes the search's course: the same iterates.

    python benchmarks/search_replay.py REC.pkl [--paths knot,compiled] [--limit K]

REC.pkl is a search recorded by ``benchmarks/search_budget.py --save`` (every sample's timing and
local result). Each path builds the search's coarse planner (`search_gait`'s `search_knots`,
`search_max_iter` and the options ``gaitsmith plan ROBOT --search`` uses with no flags) and solves
every recorded sample cold, as a search worker does (`TimingSolver`; the allocator tuned as in
the pool's workers, `planner.search.executors`). The paths' solves alternate sample by sample
(the order flips every sample), so a load change on a shared machine hits them alike; CPU seconds
(`time.process_time`) are the measure.

Paths: "knot" — J and H of the knot built in this process as SX (the default planner when the
cache holds no compiled library; built here from an empty cache folder so a compiled entry is
not picked up), "compiled" — the compiled J and H of ``gaitsmith cache build ROBOT``
(`PlannerOptions.derivatives="compiled"`; compiles first, minutes, if the cache lacks it).

Printed per path: CPU seconds of the solves, IPOPT iterations, ms per iteration, the CPU ratio to
the first path and, against the first path, the samples whose solution is not bit-identical
(x, cost, iterations, status), the largest relative difference of x and of the cost, and the
samples whose iterations or feasibility differ. The first path's iterations are checked against
the recording (the search is deterministic).

Measured in docs/results/planner_speed_search.md, session 27.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pickle
import tempfile
import time
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from gaitsmith.stance_options import stance_shaped
from planner.errors import PlannerConfigError
from planner.nlp.config import CostWeights, PlannerOptions
from planner.nlp.solver_cache import cache_folder
from planner.nlp.spacetime import GaitPlanner
from planner.search.executors import _tune_worker_malloc
from planner.search.gait_search import DEFAULT_SEARCH_KNOTS, DEFAULT_SEARCH_MAX_ITER, TimingSpace

PATHS = ("knot", "compiled")


def build(robot: robots.Robot, options: PlannerOptions, path: str, empty: str) -> GaitPlanner:
    """The coarse search planner on `path` (module docstring)."""
    if path == "knot":
        with cache_folder(empty):
            return GaitPlanner(robot, DEFAULT_SEARCH_KNOTS, options)
    return GaitPlanner(robot, DEFAULT_SEARCH_KNOTS,
                       dataclasses.replace(options, derivatives="compiled"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recording", help="a search recorded by search_budget.py --save")
    ap.add_argument("--paths", default="knot,compiled",
                    help=f"comma-separated, from {', '.join(PATHS)}; the first is the reference")
    ap.add_argument("--limit", type=int, help="replay only the first K samples")
    args = ap.parse_args()
    paths = args.paths.split(",")
    if not paths or any(p not in PATHS for p in paths) or len(set(paths)) != len(paths):
        ap.error(f"--paths: distinct names from {', '.join(PATHS)}")
    with open(args.recording, "rb") as fh:
        rec = pickle.load(fh)
    _tune_worker_malloc()  # as in the search's pool workers
    robot = robots.load(rec["robot"])
    shaped = stance_shaped(robot, None, None, None, None)
    options = PlannerOptions(
        weights=CostWeights() if shaped.bounce is None else CostWeights(bounce_s2_m2=shaped.bounce),
        normal_force_rate_weights_per_t0=shaped.force_rate or None,
        max_iter=DEFAULT_SEARCH_MAX_ITER)
    space = TimingSpace.for_robot(robot, rec["symmetric"])
    records = rec["records"][: args.limit] if args.limit else rec["records"]
    planners: dict[str, GaitPlanner] = {}
    with tempfile.TemporaryDirectory(prefix="search_replay_") as empty:
        for p in paths:
            t0, c0 = time.perf_counter(), time.process_time()
            planners[p] = build(robot, options, p, empty)
            print(f"build {p}: {time.perf_counter() - t0:.2f} s wall, "
                  f"{time.process_time() - c0:.2f} s CPU ({planners[p].derivative_cache})",
                  flush=True)
    print(f"{rec['robot']} at {rec['speed']} m/s, seed {rec['seed']}: {len(records)} samples, "
          f"load average {os.getloadavg()[0]:.2f}, "
          f"{time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC", flush=True)
    cpu = dict.fromkeys(paths, 0.0)
    solved: dict[str, list[Any]] = {p: [] for p in paths}
    for i, (x, _) in enumerate(records):
        schedule = space.decode(np.clip(np.asarray(x, dtype=float), *space.bounds()))
        for p in paths if i % 2 == 0 else paths[::-1]:
            c0 = time.process_time()
            try:
                res = planners[p].solve(schedule, rec["speed"], warm_start=False)
            except PlannerConfigError:  # as TimingSolver: a timing the NLP cannot take
                solved[p].append(None)
                continue
            cpu[p] += time.process_time() - c0
            solved[p].append(res)
    ref = paths[0]
    for p in paths:
        its = sum(r.iterations for r in solved[p] if r is not None)
        other = dx = df = 0.0
        n_iter = n_feas = 0
        for a, b in zip(solved[ref], solved[p], strict=True):
            if a is None or b is None:
                other += (a is None) != (b is None)
                continue
            xa, xb = a.warm_start.x, b.warm_start.x
            other += not (np.array_equal(xa, xb) and a.cost == b.cost
                          and a.iterations == b.iterations and a.status == b.status)
            dx = max(dx, float(np.max(np.abs(xa - xb) / (1.0 + np.abs(xa)))))
            df = max(df, abs(a.cost - b.cost) / (1.0 + abs(a.cost)))
            n_iter += a.iterations != b.iterations
            n_feas += a.feasible != b.feasible
        print(f"  {p:9s} {cpu[p]:7.2f} s CPU, {its:5d} iterations, "
              f"{1e3 * cpu[p] / max(its, 1):5.1f} ms/it, CPU ratio {cpu[p] / cpu[ref]:.3f}; "
              f"vs {ref}: {int(other)} of {len(records)} samples not bit-identical, max rel "
              f"|dx| {dx:.1e}, |df| {df:.1e}, iterations differ in {n_iter}, feasibility in "
              f"{n_feas}", flush=True)
    recorded = [max(r.n_fevals - 1, 0) for _, r in records]
    replayed = [r.iterations if r is not None else 0 for r in solved[ref]]
    off = sum(a != b for a, b in zip(recorded, replayed, strict=True))
    print(f"  recorded iterations {sum(recorded)}, {ref} replayed {sum(replayed)}"
          + ("" if off == 0 else f": {off} samples differ from the recording"))


if __name__ == "__main__":
    main()

"""Screen search warm starts on a recorded search: every recorded sample solved cold and from
each warm policy's start, in one process, alternating.

    python benchmarks/warm_screen.py REC.pkl [--policies nearest,nearest-retimed,...]

REC.pkl is `benchmarks/search_budget.py --save`'s recording (its samples in search order:
templates, then λ per generation). Batch by batch, each sample is solved cold, then from the
start each policy picks (`planner.search.gait_search.WarmStartExecutor.start`) among the cold
solutions of the earlier batches — the recorded course, so every policy sees the same samples and
the same history (a real warm search takes another course once a projection changes; this
screens the start points, `gait_search_bench.py --warm-starts` measures the searches). No MuJoCo
acceptance: iterations, CPU, NLP verdict and cost per sample. Prints one line per sample and the
totals per policy.
"""

from __future__ import annotations

import argparse
import os
import pickle
import time
from dataclasses import replace
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from gaitsmith.stance_options import stance_shaped
from planner.nlp.config import CostWeights, PlannerOptions
from planner.search.executors import SerialExecutor
from planner.search.gait_search import (
    DEFAULT_SEARCH_KNOTS,
    DEFAULT_SEARCH_MAX_ITER,
    DEFAULT_TIPPING_WEIGHT,
    SEARCH_WARM_STARTS,
    TimingResult,
    TimingSolverFactory,
    WarmStartExecutor,
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recording")
    ap.add_argument("--policies", default=",".join(SEARCH_WARM_STARTS[1:]))
    args = ap.parse_args()
    policies = [p for p in args.policies.split(",") if p]
    bad = [p for p in policies if p not in SEARCH_WARM_STARTS[1:]]
    if bad:
        raise SystemExit(f"--policies: expected a subset of {', '.join(SEARCH_WARM_STARTS[1:])}, "
                         f"got {', '.join(bad)}")
    with open(args.recording, "rb") as fh:
        rec: dict[str, Any] = pickle.load(fh)
    robot = robots.load(rec["robot"])
    shaped = stance_shaped(robot, None, None, None, None)
    options = PlannerOptions(
        weights=CostWeights() if shaped.bounce is None else CostWeights(bounce_s2_m2=shaped.bounce),
        normal_force_rate_weights_per_t0=shaped.force_rate or None)
    options = replace(options, max_iter=DEFAULT_SEARCH_MAX_ITER)
    factory = TimingSolverFactory(str(robot.root_dir), DEFAULT_SEARCH_KNOTS, rec["speed"],
                                  rec["symmetric"], options, DEFAULT_TIPPING_WEIGHT,
                                  warm_start="nearest")
    solver = factory()
    pickers = {p: WarmStartExecutor(SerialExecutor(), solver.space, p) for p in policies}
    records = rec["records"]
    nt, lam = rec["n_templates"], rec["lam"]
    batches = [records[:nt]] + [records[nt + lam * g: nt + lam * (g + 1)]
                                for g in range(rec["generations"])]
    print(f"{rec['robot']} {rec['speed']} m/s seed {rec['seed']}: {len(records)} samples, "
          f"policies {', '.join(policies)}, load {os.getloadavg()[0]:.2f}, "
          f"{time.strftime('%H:%M:%S', time.gmtime())} UTC", flush=True)
    tot: dict[str, list[float]] = {p: [0.0] * 5 for p in ["cold", *policies]}
    for b, batch in enumerate(batches):
        cold_out: list[TimingResult] = []
        for i, (x, _) in enumerate(batch):
            row = []
            res: dict[str, TimingResult] = {}
            for p in ["cold", *policies]:
                item = x if p == "cold" else pickers[p].start(np.asarray(x, dtype=float))
                r = solver(item)
                res[p] = r
                it = max(r.n_fevals - 1, 0)
                t = tot[p]
                t[0] += it
                t[1] += r.cpu_s
                t[2] += int(r.plan_feasible)
                if p != "cold":
                    same = r.plan_feasible == res["cold"].plan_feasible
                    t[3] += int(not same)
                    if same and r.plan_feasible:
                        t[4] += int(abs(r.cost - res["cold"].cost) > 1e-4 * abs(res["cold"].cost))
                row.append(f"{p} {it:3d} it {r.cpu_s:5.2f} s "
                           f"{'F' if r.plan_feasible else 'i'} {r.cost:.4g}")
            cold_out.append(res["cold"])
            print(f"b{b} s{i}: " + " | ".join(row), flush=True)
        for picker in pickers.values():
            # the history every policy sees: the cold solutions of the batches so far
            for (x, _), r in zip(batch, cold_out, strict=True):
                picker.remember(np.asarray(x, dtype=float), r)
    for p, (its, cpu, feas, flipped, moved) in tot.items():
        print(f"{p:18s} {int(its):5d} iterations, {cpu:6.1f} CPU-s, {int(feas)} plan-feasible, "
              f"{int(flipped)} verdicts differ from cold, {int(moved)} costs off cold by > 1e-4")
    print(f"load {os.getloadavg()[0]:.2f}, {time.strftime('%H:%M:%S', time.gmtime())} UTC")


if __name__ == "__main__":
    main()

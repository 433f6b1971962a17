"""Which of a gait search's local solves change its answer: a search recorded sample by sample,
and basin-CMA stall stops evaluated on the recording exactly.

    python benchmarks/search_budget.py [--robot quad12] [--speed 0.25] [--seed 0]
                                       [--generations 6] [--workers 2] [--no-sim-accept]
                                       [--save REC.pkl]

Runs `search_gait` as `gaitsmith plan ROBOT --speed V --search` does (process executor, MuJoCo
acceptance with the command line's settings) and prints:

- the samples by outcome — accepted, rejected by MuJoCo (feasible plan), NLP-infeasible (and how
  many stopped at the coarse NLP's iteration cap) — with their IPOPT iterations and worker time;
- per generation, the cheapest accepted sample and whether it improved on the incumbent (the
  cheapest accepted timing so far, the templates included);
- for stall stops P = 1…5 ("stop basin-CMA after P generations in a row without a new
  incumbent", counted once something is accepted): where the search would have stopped, the
  solves and iterations it would have spent, and whether its final phase would start from the
  same candidates up to the winner. This is exact, not a re-run: the search is deterministic
  (seeded CMA, cold IPOPT solves with `OMP_NUM_THREADS=1`), so a search stopped after generation
  k *is* the recorded one truncated there, and its final phase re-solves the cheapest accepted
  samples of the truncated record (`RecordingExecutor.best_feasible`).

`--save` pickles the recording for `benchmarks/search_skip.py` (a timing-only rejection
predictor replayed exactly on it). The search uses the options `gaitsmith plan ROBOT --search`
uses with no flags (the stance-compliance rule and its entry cycles).

Measured in docs/results/planner_speed_search.md §4 (session 25): the stall stop saved 40–44 % of
the iterations where the templates win, and lost a 30 % cheaper trot at quad12 0.35 m/s that the
search finds in its last generation.
"""

from __future__ import annotations

import argparse
import math
import os
import pickle
import resource
import time
from collections.abc import Sequence

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from gaitsmith.plan_cmd import DEFAULT_CYCLES
from gaitsmith.search_options import sim_acceptance
from gaitsmith.stance_options import stance_shaped
from planner.nlp.config import CostWeights, PlannerOptions
from planner.search.basin_cma import LocalResult
from planner.search.gait_search import FINAL_CANDIDATES, final_candidates_of, search_gait

Record = tuple[np.ndarray, LocalResult]


def outcome(r: LocalResult) -> str:
    """"accepted", "rejected" (feasible plan, failed acceptance) or "infeasible"."""
    if r.feasible:
        return "accepted"
    return "rejected" if getattr(r, "plan_feasible", False) else "infeasible"


def candidates(records: Sequence[Record], k: int = FINAL_CANDIDATES) -> list[tuple[float, bool]]:
    """(search cost, accepted) of the final phase's candidates, as `best_feasible` picks them."""
    return [(round(res.cost, 6), res.feasible) for _, res in final_candidates_of(records, k)]


def stall_stop(generation_bests: Sequence[float], incumbent: float, patience: int) -> int:
    """Generations a stall stop with `patience` runs (all of them if it never stops)."""
    since = 0
    for g, best in enumerate(generation_bests):
        if best < incumbent:
            incumbent, since = best, 0
        elif math.isfinite(incumbent):
            since += 1
        if since >= patience:
            return g + 1
    return len(generation_bests)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--generations", type=int, default=6)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-sim-accept", action="store_true")
    ap.add_argument("--save", help="pickle the recorded search (samples, results, winner) here")
    args = ap.parse_args()
    robot = robots.load(args.robot)
    # the options `gaitsmith plan ROBOT --search` uses with no flags (stance-compliance rule)
    shaped = stance_shaped(robot, None, None, None, None)
    options = PlannerOptions(
        weights=CostWeights() if shaped.bounce is None else CostWeights(bounce_s2_m2=shaped.bounce),
        normal_force_rate_weights_per_t0=shaped.force_rate or None)
    print(f"{args.robot} at {args.speed} m/s, seed {args.seed}, {args.generations} generations, "
          f"load average {os.getloadavg()[0]:.2f}, "
          f"{time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC", flush=True)
    t0, c0 = time.perf_counter(), time.process_time()
    w0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    res = search_gait(robot, args.speed, max_generations=args.generations, seed=args.seed,
                      executor="process", workers=args.workers, options=options,
                      **sim_acceptance(robot, not args.no_sim_accept, DEFAULT_CYCLES,
                                       shaped.entry or 1))
    w1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = time.process_time() - c0 + (w1.ru_utime + w1.ru_stime) - (w0.ru_utime + w0.ru_stime)
    records: list[Record] = list(res.samples)
    n_templates = len(res.template_costs)
    generations = res.cma.n_generations
    lam = (len(records) - n_templates) // max(generations, 1)
    its = [max(r.n_fevals - 1, 0) for _, r in records]
    print(f"  {time.perf_counter() - t0:.1f} s wall, {cpu:.1f} s CPU; {len(records)} solves "
          f"({n_templates} templates + {generations} × {lam}), {sum(its)} iterations; winner "
          f"{res.label}, search cost {res.search_cost:.5g} → final {res.best.cost:.6g}, "
          f"accepted {res.accepted}")
    for kind in ("accepted", "rejected", "infeasible"):
        sel = [(r, i) for (_, r), i in zip(records, its, strict=True) if outcome(r) == kind]
        capped = sum(getattr(r, "status", "") == "Maximum_Iterations_Exceeded" for r, _ in sel)
        print(f"  {kind:10s} {len(sel):3d} samples, {sum(i for _, i in sel):5d} iterations "
              f"({sum(i for _, i in sel) / max(sum(its), 1):4.0%}), "
              f"{sum(float(getattr(r, 'solve_s', 0.0)) for r, _ in sel):6.1f} worker-s solving, "
              f"{capped} at the iteration cap")
    if args.save:
        with open(args.save, "wb") as fh:
            pickle.dump({"robot": args.robot, "speed": args.speed, "seed": args.seed,
                         "records": records, "n_templates": n_templates, "lam": lam,
                         "generations": generations, "symmetric": res.symmetric,
                         "winner": (res.label, round(res.search_cost, 6),
                                    round(float(res.best.cost), 6), res.accepted),
                         "n_final": len(res.final_solves), "cpu_s": cpu}, fh)
    incumbent = min(res.template_costs.values())
    bests: list[float] = []
    run_best = incumbent
    for g in range(generations):
        gen = records[n_templates + lam * g: n_templates + lam * (g + 1)]
        best = min((r.cost for _, r in gen if r.feasible), default=math.inf)
        bests.append(best)
        new = best < run_best
        run_best = min(run_best, best)
        print(f"  generation {g}: cheapest accepted {best:.5g}{'  new incumbent' if new else ''}")
    full = candidates(records)
    winner = next((i for i, (_, ok) in enumerate(full) if ok), len(full) - 1)
    print(f"  final candidates {full} (the winner came from {len(res.final_solves)} re-solves)")
    for patience in range(1, 6):
        g = stall_stop(bests, incumbent, patience)
        cut = records[: n_templates + lam * g]
        same = candidates(cut)[: len(res.final_solves)] == full[: len(res.final_solves)]
        print(f"  stall stop P={patience}: {g} generations, {len(cut)} solves, "
              f"{sum(its[: len(cut)])} iterations ({sum(its[: len(cut)]) / sum(its):.2f}); "
              + ("same final candidates up to the winner" if same
                 else f"OTHER final candidates {candidates(cut)[: winner + 1]}"))


if __name__ == "__main__":
    main()

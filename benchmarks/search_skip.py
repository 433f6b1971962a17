"""A rejection predictor that needs no solve, evaluated exactly on recorded searches.

    python benchmarks/search_skip.py REC.pkl [REC.pkl ...] [--thresholds 2.4,3,4,6]

REC.pkl: `benchmarks/search_budget.py --save` (a search recorded sample by sample). The rule:
skip the local solve of a sample whose open-loop tipping amplification
(`TippingCost.amplification`, a function of the timing alone) exceeds a threshold A, and hand
basin-CMA a result ranked after every solved sample ("last": violation ∞, as an NLP-infeasible
sample that reported no violation) or right after the MuJoCo-rejected ones ("rejected": as a
rejected sample of badness `SKIP_BADNESS`). The search is deterministic (seeded CMA, cold
solves), so the rule keeps the recorded course exactly iff in every generation the µ elites, in
order, are the same samples (the Lamarckian update, W&P eqs 26-27, sees only them; the timings
are not changed by the projection), no accepted sample or template is skipped, and the final
phase's candidates (`RecordingExecutor.best_feasible`) are the same up to the ones it re-solved.
Prints, per search and threshold: the samples skipped by outcome, the iterations saved, and
whether the course (elites), the candidates and hence the winner are kept.
"""

from __future__ import annotations

import argparse
import math
import pickle
from collections.abc import Sequence

import numpy as np

import robots
from planner.search.basin_cma import LocalResult, _rank_key
from planner.search.gait_search import (
    DEFAULT_TIPPING_WEIGHT,
    FINAL_CANDIDATES,
    REJECTED_VIOLATION,
    TimingSpace,
    final_candidates_of,
)
from planner.search.support import TippingCost

ZOO = {"spotmicro": "tests/zoo/spotmicro"}
#: badness (failed criteria) given to a skipped sample in the "rejected" ranking: above any real one
SKIP_BADNESS = 100.0


def outcome(r: LocalResult) -> str:
    if r.feasible:
        return "accepted"
    return "rejected" if getattr(r, "plan_feasible", False) else "infeasible"


def skipped_key(r: LocalResult, mode: str) -> tuple[int, float, float]:
    if mode == "last":
        return (1, math.inf, math.inf)
    return (1, REJECTED_VIOLATION * (1.0 + SKIP_BADNESS), math.inf)


def key(r: LocalResult, skipped: bool, mode: str) -> tuple[int, float, float]:
    """basin-CMA's rank key of a recorded result, or of a skipped sample in `mode`."""
    return skipped_key(r, mode) if skipped else _rank_key(r.cost, r.feasible, r.violation)


def candidates(records: Sequence[tuple[np.ndarray, LocalResult]], skip: Sequence[bool],
               k: int = FINAL_CANDIDATES) -> list[tuple[float, bool]]:
    kept = [rec for rec, s in zip(records, skip, strict=True) if not s]
    return [(round(res.cost, 6), res.feasible) for _, res in final_candidates_of(kept, k)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recordings", nargs="+")
    ap.add_argument("--thresholds", default="2.2,2.4,3,4,6,10")
    args = ap.parse_args()
    thresholds = [float(t) for t in args.thresholds.split(",")]
    for path in args.recordings:
        with open(path, "rb") as fh:
            rec = pickle.load(fh)
        robot = robots.load(ZOO.get(rec["robot"], rec["robot"]))
        space = TimingSpace.for_robot(robot, rec["symmetric"])
        tip = TippingCost.for_robot(robot, DEFAULT_TIPPING_WEIGHT)
        records = rec["records"]
        nt, lam, gens = rec["n_templates"], rec["lam"], rec["generations"]
        mu = max(1, math.ceil(lam / 3))
        amp = [tip.amplification(space.decode(np.clip(x, *space.bounds()))) for x, _ in records]
        its = [max(r.n_fevals - 1, 0) for _, r in records]
        kinds = [outcome(r) for _, r in records]
        print(f"{rec['robot']} {rec['speed']} m/s seed {rec['seed']}: {len(records)} solves, "
              f"{sum(its)} iterations, winner {rec['winner']} ({rec['n_final']} final solves)")
        for kind in ("accepted", "rejected", "infeasible"):
            a = sorted(round(v, 2) for v, k in zip(amp, kinds, strict=True) if k == kind)
            print(f"  amplification of the {kind} samples: {a}")
        n_final = min(rec["n_final"], FINAL_CANDIDATES)
        full = candidates(records, [False] * len(records))
        for thr in thresholds:
            skip = [v > thr for v in amp]
            saved = sum(i for i, s in zip(its, skip, strict=True) if s)
            by = {k: sum(1 for kk, s in zip(kinds, skip, strict=True) if s and kk == k)
                  for k in ("accepted", "rejected", "infeasible")}
            skipped_templates_ok = not any(skip[i] and kinds[i] == "accepted" for i in range(nt))
            for mode in ("last", "rejected"):
                diverged = None
                for g in range(gens):
                    idx = range(nt + lam * g, nt + lam * (g + 1))

                    before = sorted(idx, key=lambda i: key(records[i][1], False, mode))[:mu]
                    after = sorted(idx, key=lambda i: key(records[i][1], skip[i], mode))[:mu]
                    if before != after:
                        diverged = g
                        break
                cut = candidates(records, skip)
                same_cand = cut[:n_final] == full[:n_final]
                verdict = ("KEPT" if diverged is None and same_cand and by["accepted"] == 0
                           and skipped_templates_ok else "changed")
                print(f"  A > {thr:5.2f} [{mode:8s}]: skip {by['accepted']} accepted, "
                      f"{by['rejected']} rejected, {by['infeasible']} infeasible; "
                      f"{saved} iterations saved ({saved / max(sum(its), 1):.0%}); elites "
                      + ("same" if diverged is None else f"DIFFER in generation {diverged}")
                      + f"; final candidates {'same' if same_cand else 'DIFFER'} → {verdict}")


if __name__ == "__main__":
    main()

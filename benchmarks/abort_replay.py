"""Rules that abandon a coarse solve of the gait search early, replayed exactly on recordings.

    python benchmarks/abort_replay.py REC.pkl [REC.pkl ...]

REC.pkl: `benchmarks/search_budget.py --save` (a search recorded sample by sample, with every
sample's IPOPT iterates in `TimingResult.iteration_log`: objective, inf_pr, inf_du). A rule looks
at a solve's iterates as IPOPT makes them and may stop it at iteration k; the stopped sample is
handed to basin-CMA ranked after every solved sample (an NLP-infeasible result with violation
∞) and never re-solved in the final phase. IPOPT's iterates up to k do not depend on the rule,
so the search with the rule is the recorded one with those samples replaced — exactly, as long
as no stopped sample was one of a generation's µ elites (W&P eqs 26–27 see only them, in rank
order; the timings are not changed by the projection) or a template (the best template is CMA's
start) or one of the final phase's candidates up to the one that won. Rules:

- `stall(K, V)`: session 26's rule — at k ≥ K, inf_pr_k > V and inf_pr_k ≥ ½·min(inf_pr over
  the 5 iterations before): the constraint violation has stopped falling;
- `costly(K, P, R)`: at k ≥ K, inf_pr_k ≤ P (feasibility close) and the objective plus the
  timing's support term is ≥ R × the incumbent (the cheapest accepted sample of the earlier
  generations, templates included): a solve that cannot win (the brief's route 2);
- `cap(L)`: a lower coarse iteration cap, evaluated only as "which samples would it touch"
  (a capped point is judged and may still pass, so its course is not replayable).

Prints, per recording and rule: the samples stopped by outcome, the iterations saved, and
whether the course (every generation's elites), the templates and the final candidates up to
the winner are kept (elites that differ only in the last generation change no later sample: the
winner is then kept if the candidates are).
"""

from __future__ import annotations

import argparse
import math
import pickle
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

import robots
from planner.search.basin_cma import LocalResult, _rank_key
from planner.search.gait_search import (
    DEFAULT_TIPPING_WEIGHT,
    FINAL_CANDIDATES,
    TimingSpace,
    final_candidates_of,
)
from planner.search.support import TippingCost

Record = tuple[np.ndarray, LocalResult]
#: a rule: (iteration log so far, support term of the timing, incumbent) → stop now?
Rule = Callable[[Sequence[tuple[float, float, float]], float, float], bool]
ZOO = {"spotmicro": "tests/zoo/spotmicro"}


def outcome(r: LocalResult) -> str:
    if r.feasible:
        return "accepted"
    return "rejected" if getattr(r, "plan_feasible", False) else "infeasible"


def stall(after: int, min_violation: float, window: int = 5) -> Rule:
    def fires(log: Sequence[tuple[float, float, float]], tip: float, inc: float) -> bool:
        k = len(log) - 1
        if k < after or log[k][1] <= min_violation:
            return False
        recent = [v for _, v, _ in log[max(0, k - window): k]]
        return bool(recent) and log[k][1] >= 0.5 * min(recent)
    return fires


def costly(after: int, pr_tol: float, ratio: float) -> Rule:
    def fires(log: Sequence[tuple[float, float, float]], tip: float, inc: float) -> bool:
        k = len(log) - 1
        return (k >= after and math.isfinite(inc) and log[k][1] <= pr_tol
                and log[k][0] + tip >= ratio * inc)
    return fires


def cap(limit: int) -> Rule:
    def fires(log: Sequence[tuple[float, float, float]], tip: float, inc: float) -> bool:
        return len(log) - 1 >= limit
    return fires


@dataclass(frozen=True)
class Replay:
    stopped: tuple[int | None, ...]  # per sample: the iteration the rule stops it at, or None
    saved: int
    by_outcome: dict[str, int]
    diverged: int | None  # first generation whose elites change (None: none)
    templates_ok: bool
    candidates_ok: bool

    last_generation: int = -1

    @property
    def kept(self) -> bool:
        return self.diverged is None and self.templates_ok and self.candidates_ok

    @property
    def same_winner(self) -> bool:
        """Elites that differ only in the last generation change no later sample: the final
        phase, and hence the winner, stays the same if its candidates do."""
        return (self.diverged is None or self.diverged == self.last_generation) and \
            self.templates_ok and self.candidates_ok


def replay(rec: dict, rule: Rule, tips: Sequence[float]) -> Replay:
    records: list[Record] = rec["records"]
    nt, lam, gens = rec["n_templates"], rec["lam"], rec["generations"]
    mu = max(1, math.ceil(lam / 3))
    stopped: list[int | None] = []
    for i, (_, r) in enumerate(records):
        g = -1 if i < nt else (i - nt) // lam
        earlier = records[: nt + lam * g] if g >= 0 else []
        inc = min((rr.cost for _, rr in earlier if rr.feasible), default=math.inf)
        log = list(getattr(r, "iteration_log", ()))
        at = None
        for k in range(1, len(log) - 1):  # the last entry is where IPOPT stopped anyway
            if rule(log[: k + 1], tips[i], inc):
                at = k
                break
        stopped.append(at)
    its = [max(r.n_fevals - 1, 0) for _, r in records]
    saved = sum(its[i] - k for i, k in enumerate(stopped) if k is not None)
    by = {o: sum(1 for i, k in enumerate(stopped) if k is not None
                 and outcome(records[i][1]) == o) for o in ("accepted", "rejected", "infeasible")}

    def key(i: int, with_rule: bool) -> tuple[int, float, float]:
        r = records[i][1]
        if with_rule and stopped[i] is not None:
            return (1, math.inf, math.inf)
        return _rank_key(r.cost, r.feasible, r.violation)

    diverged = None
    for g in range(gens):
        idx = range(nt + lam * g, nt + lam * (g + 1))
        if sorted(idx, key=lambda i: key(i, False))[:mu] != \
                sorted(idx, key=lambda i: key(i, True))[:mu]:
            diverged = g
            break
    templates_ok = all(stopped[i] is None or outcome(records[i][1]) == "infeasible"
                       for i in range(nt))
    n_final = min(rec["n_final"], FINAL_CANDIDATES)

    def cands(recs: Sequence[Record]) -> list[tuple[float, bool]]:
        return [(round(r.cost, 6), r.feasible) for _, r in final_candidates_of(recs, n_final)]

    kept_recs = [rr for rr, k in zip(records, stopped, strict=True) if k is None]
    return Replay(tuple(stopped), saved, by, diverged, templates_ok,
                  cands(kept_recs) == cands(records), gens - 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recordings", nargs="+")
    args = ap.parse_args()
    rules: list[tuple[str, Rule]] = []
    for after in (20, 25, 30):
        for v in (0.01, 0.03, 0.1):
            rules.append((f"stall(K={after}, V={v:g})", stall(after, v)))
    for after in (5, 10, 15, 20):
        for pr in (1e-3, 1e-2):
            for ratio in (1.25, 1.5, 2.0, 3.0):
                rules.append((f"costly(K={after}, P={pr:g}, R={ratio:g})",
                              costly(after, pr, ratio)))
    for limit in (30, 40, 50):
        rules.append((f"cap(L={limit})", cap(limit)))
    recs = []
    for path in args.recordings:
        with open(path, "rb") as fh:
            recs.append(pickle.load(fh))
    tips_all = []
    for rec in recs:
        robot = robots.load(ZOO.get(rec["robot"], rec["robot"]))
        space = TimingSpace.for_robot(robot, rec["symmetric"])
        tip = TippingCost.for_robot(robot, DEFAULT_TIPPING_WEIGHT)
        tips_all.append([tip(space.decode(np.clip(x, *space.bounds())))
                         for x, _ in rec["records"]])
        records = rec["records"]
        its = [max(r.n_fevals - 1, 0) for _, r in records]
        # the objective IPOPT reports vs the search cost: the support term is added after
        gaps = [abs(r.cost - (r.iteration_log[-1][0] + t)) for (_, r), t
                in zip(records, tips_all[-1], strict=True)
                if getattr(r, "iteration_log", ()) and math.isfinite(r.cost)]
        print(f"{rec['robot']} {rec['speed']} m/s seed {rec['seed']}: {len(records)} solves, "
              f"{sum(its)} iterations, winner {rec['winner']}; |cost − (last obj + support)| "
              f"≤ {max(gaps, default=math.nan):.2e}")
    print(f"{'rule':34s} " + " | ".join(f"{r['robot'][:9]:>9s} saved  kept" for r in recs))
    for name, rule in rules:
        cells = []
        for rec, tips in zip(recs, tips_all, strict=True):
            rp = replay(rec, rule, tips)
            total = sum(max(r.n_fevals - 1, 0) for _, r in rec["records"])
            why = "" if rp.kept else ("A" if rp.by_outcome["accepted"] else "") + (
                f"g{rp.diverged}" if rp.diverged is not None else "") + (
                "" if rp.templates_ok else "T") + ("" if rp.candidates_ok else "C")
            verdict = "KEPT" if rp.kept else why + ("*" if rp.same_winner else "")
            cells.append(f"{rp.saved:5d} {rp.saved / max(total, 1):4.0%} {verdict:>6s}")
        print(f"{name:34s} " + " | ".join(cells))
    print("kept: every generation's elites, the templates and the final candidates unchanged; "
          "else A = an accepted sample stopped, gN = elites differ from generation N, "
          "T = a template stopped, C = final candidates differ; * = only the last generation's "
          "elites differ, so the final candidates and the winner are the same")


if __name__ == "__main__":
    main()

"""Where the final phase's full-cycle retry lands: the half-cycle plan's own point, or another.

    python benchmarks/retry_points.py DIR/*__halfretry.pkl [--final-candidates 4]

For each recording saved by `search_outcomes.py run --settings halfretry --save DIR`, replays its
final phase exactly as `search_outcomes.py replay --final-half-cycle retry` does (in this process)
and prints, for every retried candidate (its half-cycle re-solve infeasible or failing the final
check, then re-solved on the full NLP, `search_gait(final_retry_full=True)`): both verdicts and
costs, and max |Δ| of the base pose and joint angles between the two plans — ≈ 1e-13 when the
full solve stayed on the mirror subspace (the same point, so the same deterministic MuJoCo
verdict), up to IPOPT's tolerance (≈ 1e-5) for the same optimum reached by another path, larger
for another local optimum. Then a count per class and how many retries the full plan rescued.
Measured in docs/results/planner_speed_search.md, session 39 (lead).
"""

from __future__ import annotations

import argparse
import math
import os
import pickle
import sys
from collections import Counter
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np
import search_outcomes as so

from planner.nlp.spacetime import PlanResult
from planner.search.defaults import FINAL_CHOICE_CHEAPEST_OF_2, FINAL_RETRY_ALL
from planner.search.final_phase import FinalOutcome, FinalTask


def distance(a: PlanResult, b: PlanResult) -> float:
    """max |Δ| of base pose and joint angles (nan unless both plans are feasible)."""
    if not (a.feasible and b.feasible):
        return math.nan
    return float(max(np.abs(a.joint_angles_rad - b.joint_angles_rad).max(),
                     np.abs(a.base_pose - b.base_pose).max()))


def point_class(d: float) -> str:
    if math.isnan(d):
        return "half or full plan infeasible"
    if d <= 1e-9:
        return "the same point (<= 1e-9)"
    return "the same optimum (< 1e-3)" if d < 1e-3 else "another point (>= 1e-3)"


def retried(recording: Path, final_candidates: int) -> list[tuple[FinalTask, FinalOutcome]]:
    """The retried candidates of the recording's final phase, replayed with the retry on."""
    rec = pickle.loads(recording.read_bytes())
    replayer = so.FinalReplayer(so.Search(**rec["search"]), "rows", rec["knots"], True,
                                 FINAL_RETRY_ALL)
    solve = replayer.outcomes
    seen: list[tuple[FinalTask, FinalOutcome]] = []

    def logged(tasks: list[FinalTask]):  # type: ignore[no-untyped-def]
        for task, out in zip(tasks, solve(tasks), strict=False):
            seen.append((task, out))
            yield out

    replayer.outcomes = logged  # type: ignore[method-assign]
    replayer.truncated(rec, rec["generations"], final_candidates,
                       choice=FINAL_CHOICE_CHEAPEST_OF_2)
    return [(t, o) for t, o in seen if o.half_tried is not None]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recordings", nargs="+", type=Path)
    ap.add_argument("--final-candidates", type=int, default=so.FINAL_CANDIDATES)
    args = ap.parse_args()
    if args.final_candidates < 1:
        raise SystemExit(f"--final-candidates must be ≥ 1, got {args.final_candidates}")
    for path in args.recordings:
        if not path.is_file():
            raise SystemExit(f"{path}: no such recording (save them with `search_outcomes.py run "
                             "--settings halfretry --save DIR`)")
    classes: Counter[str] = Counter()
    rescued: Counter[str] = Counter()
    for path in args.recordings:
        print(f"## {path.name}")
        for task, out in retried(path, args.final_candidates):
            half = out.half_tried
            assert half is not None
            d = distance(half.plan, out.plan)
            cls = point_class(d)
            classes[cls] += 1
            rescued[cls] += bool(out.ok)
            print(f"  period {task.schedule.period_s:.3f} s: half ok={half.ok} cost "
                  f"{half.plan.cost:.6f} | full ok={out.ok} cost {out.plan.cost:.6f} | "
                  f"max |Δ| {d:.2e} ({cls})")
    for cls, n in classes.items():
        print(f"{cls}: {n} retries, {rescued[cls]} rescued")


if __name__ == "__main__":
    main()

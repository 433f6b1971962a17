"""The half-cycle solve beside the full NLP, per template: cost, iterations, CPU per iteration.

    python benchmarks/half_cycle_bench.py [--robot quad12] [--speed 0.25] [--knots 12,30]
                                          [--gaits trot,pace,walk] [--reps 1] [--search-cap]

For each knot count, builds two planners with the options `gaitsmith plan ROBOT --search` gives
its NLPs (`gait_search_bench.cli_search_options`), one with `PlannerOptions.half_cycle_solve`
(`planner.nlp.half_cycle`), and cold-solves each template on both, alternating, `--reps` times.
Prints per solve: iterations, cost, feasibility and process CPU of each, the CPU ratio, the cost
difference, whether the reduced NLP was used, and how far the full NLP's solution is from its own
mirror image (max |x − E·x[half]|: ≈ 1e-12 when IPOPT's iterates stayed symmetric, and then the two
paths take the same iterates; "—" for a schedule that is not symmetric, which both solve in full;
a template the NLP refuses at the speed, e.g. a stand, is printed as refused). `--search-cap`:
the search's coarse iteration cap (`DEFAULT_SEARCH_MAX_ITER`) instead of the NLP's own.
Measured in docs/results/planner_speed_search.md, session 36 (lead).

`--against FIELD=VALUE[,FIELD=VALUE…]` compares two half-cycle planners instead: the first
column is the planner above with `half_cycle_solve` on, the second the same with those
`PlannerOptions` fields replaced (strings, e.g. ``swing_wrench=bounds``; the asymmetry column
is then the first one's). docs/results/planner_speed_coldstart.md, session 41.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np
from gait_search_bench import cli_search_options

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.half_cycle import HalfCycleNLP
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.search.gait_search import DEFAULT_SEARCH_MAX_ITER
from planner.templates import make_schedule, templates_for


@dataclasses.dataclass(frozen=True)
class Timed:
    result: PlanResult
    cpu_s: float


def timed_solve(planner: GaitPlanner, schedule: robots.ContactSchedule, speed_m_s: float
                ) -> Timed:
    c0 = time.process_time()
    result = planner.solve(schedule, speed_m_s, warm_start=False)
    return Timed(result, time.process_time() - c0)


def asymmetry(planner: GaitPlanner, x: np.ndarray) -> float | None:
    """max |x − E·x[half]| with the reduced planner's map E (None: it has none)."""
    half = planner._half_cycle
    if not isinstance(half, HalfCycleNLP):
        return None
    return float(np.abs(half.mirror.expand(x[half.mirror.half]) - x).max())


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--knots", default="12,30")
    ap.add_argument("--gaits", default=None, help="templates (default: all of the robot's)")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--search-cap", action="store_true")
    ap.add_argument("--against", default=None,
                    help="FIELD=VALUE[,…]: half-cycle planner vs the same with these options")
    args = ap.parse_args(argv)
    against = _fields(args.against) if args.against is not None else None
    try:
        knots = [int(k) for k in args.knots.split(",")]
    except ValueError:
        raise SystemExit(f"--knots: {args.knots!r} is not a comma-separated list of integers "
                         "(e.g. 12,30)") from None
    if any(k % 2 or not 8 <= k <= 200 for k in knots):
        raise SystemExit(f"--knots: {args.knots!r} needs even knot counts in [8, 200]")
    if args.reps < 1:
        raise SystemExit(f"--reps must be ≥ 1, got {args.reps}")
    robot = robots.load(args.robot)
    known = templates_for(robot)
    gaits = known if args.gaits is None else args.gaits.split(",")
    unknown = [g for g in gaits if g not in known]
    if unknown:
        raise SystemExit(f"--gaits: {args.robot} has no template {', '.join(unknown)}; known: "
                         f"{', '.join(known)}")
    options, _ = cli_search_options(robot, speed_m_s=args.speed)
    if args.search_cap:
        options = dataclasses.replace(options, max_iter=DEFAULT_SEARCH_MAX_ITER)
    print(f"{args.robot} at {args.speed} m/s, {time.strftime('%H:%M:%S', time.gmtime())} UTC, "
          f"load {os.getloadavg()[0]:.2f}")
    first, second = ("full", "half") if against is None else ("half", args.against)
    print(f"| N | gait | {first} it | {first} cost | {second} it | {second} cost | rel. cost diff "
          f"| CPU {first} / {second} [s] | ratio | reduced | {first}'s asymmetry |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for n in knots:
        if against is None:
            full = GaitPlanner(robot, n, dataclasses.replace(options, half_cycle_solve=False))
            half = GaitPlanner(robot, n, dataclasses.replace(options, half_cycle_solve=True))
        else:  # "full" is the first half-cycle planner, "half" the one with `against`
            full = GaitPlanner(robot, n, dataclasses.replace(options, half_cycle_solve=True))
            half = GaitPlanner(robot, n, dataclasses.replace(options, half_cycle_solve=True,
                                                             **against))
        for gait in gaits:
            schedule = make_schedule(robot, gait)
            for rep in range(args.reps):
                pair = ((full, half) if rep % 2 == 0 else (half, full))
                try:
                    out = {id(p): timed_solve(p, schedule, args.speed) for p in pair}
                except PlannerConfigError as exc:  # e.g. a stand at a moving command
                    print(f"| {n} | {gait} | refused: {exc} |")
                    break
                a, b = out[id(full)], out[id(half)]
                rel = (b.result.cost - a.result.cost) / max(abs(a.result.cost), 1e-12)
                mapped = half if against is None else full
                asym = (asymmetry(mapped, a.result.warm_start.x) if b.result.stats["half_cycle"]
                        else None)  # a schedule that is not symmetric has no mirror image
                print(f"| {n} | {gait} | {a.result.iterations} | {a.result.cost:.8g}"
                      f"{'' if a.result.feasible else ' (infeasible)'} | {b.result.iterations} | "
                      f"{b.result.cost:.8g}{'' if b.result.feasible else ' (infeasible)'} | "
                      f"{rel:+.1e} | {a.cpu_s:.2f} / {b.cpu_s:.2f} | "
                      f"{b.cpu_s / max(a.cpu_s, 1e-9):.2f} | {b.result.stats['half_cycle']} | "
                      + ("—" if asym is None else f"{asym:.1e}") + " |", flush=True)
    print(f"load at the end {os.getloadavg()[0]:.2f}")


def _fields(text: str) -> dict[str, Any]:
    """``FIELD=VALUE,…`` as `PlannerOptions` keywords (the option fields that take a name, e.g.
    ``swing_wrench``, ``cold_mu_centrality``, or a float, e.g. ``hessian_shift_acc``), checked
    by `PlannerOptions`."""
    out: dict[str, Any] = {}
    for item in filter(None, text.split(",")):
        key, sep, value = item.partition("=")
        if not sep or key not in {f.name for f in dataclasses.fields(PlannerOptions)}:
            raise SystemExit(f"--against: {item!r} is not FIELD=VALUE of a PlannerOptions field")
        default = getattr(PlannerOptions(), key)
        if isinstance(default, float):  # a number, e.g. ``hessian_shift_acc=5e-7``
            try:
                out[key] = float(value)
            except ValueError:
                raise SystemExit(f"--against: {key}={value!r} is not a number") from None
            continue
        if not isinstance(default, str):
            raise SystemExit(f"--against: {key} is not a field that takes a name or a number")
        out[key] = value
    try:
        dataclasses.replace(PlannerOptions(), **out)  # type: ignore[arg-type]
    except PlannerConfigError as exc:
        raise SystemExit(f"--against: {exc}") from None
    return out


if __name__ == "__main__":
    main()

"""Screen IPOPT options on the planner as users run it: where do the last iterations go?

    python benchmarks/tail_screen.py --robot hex18 --templates tripod --random 0 \\
        base='{}' tol5='{"tol":1e-5}' afy='{"alpha_for_y":"bound-mult"}' [--warm 4 --symmetric]

One planner per variant with the options `gaitsmith plan ROBOT --search` gives its NLPs
(`gait_search_bench.cli_search_options`: the half-cycle solve where it fits, "knot" derivatives,
compiled C when `GAITSMITH_CACHE` holds them) and the variant's IPOPT options on top
(`PlannerOptions.ipopt_extra`, cold and warm solves alike; ``"tol"`` sets `PlannerOptions.tol`).
A variant is ``name=JSON``; the first is the baseline (normally ``base='{}'``, today's options).

Cold solves of the robot's templates (``--templates``: only these; "stand" is skipped, a moving
command refuses it) and of ``--random`` schedules drawn as `planner_bench compare` draws them
(seed ``--seed``, around ``--gait``), the variants alternating (their order rotates from one
schedule to the next). Then ``--warm K``: per variant, the gait's template cold and K perturbed
schedules (`planner_bench.perturbed`, or `symmetric_perturbed` with ``--symmetric``; seed+1 as
`planner_bench compare`), each warm-started from the previous optimum, the variants alternating
per step.

Prints per solve and variant: iterations, cost relative to the baseline's, "V!" where the
feasibility verdict differs, "c" where the solve stopped short of IPOPT's optimality test
(`PlanResult.optimal` False), the worst violation (`PlanResult.max_violation`) and process CPU;
then per variant the sums, medians and CPU ratio. ``--trace NAME``: also each solve's iteration
log (objective, inf_pr, inf_du) of that variant. IPOPT is deterministic: iteration counts
compare across runs; CPU only within one. Measured: docs/results/planner_speed_ipopt.md,
session 43.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np
from gait_search_bench import cli_search_options
from planner_bench import perturbed, random_schedule, symmetric_perturbed

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.templates import default_gait_for, make_schedule, mirror_permutation, templates_for

#: the chains' default speed per robot (0.25 m/s for others); the template: the robot's default
DEFAULT_SPEED_M_S = {"hex18": 0.15}


@dataclasses.dataclass(frozen=True)
class Variant:
    name: str
    options: PlannerOptions


@dataclasses.dataclass(frozen=True)
class Solve:
    iterations: int
    cost: float
    feasible: bool
    optimal: bool
    max_violation: float
    cpu_s: float
    status: str
    half_cycle: bool
    log: dict[str, list[float]]

    @staticmethod
    def of(result: PlanResult, cpu_s: float) -> Solve:
        it = result.stats.get("iterations") or {}
        log = {k: [float(v) for v in it.get(k, [])] for k in ("obj", "inf_pr", "inf_du")}
        return Solve(result.iterations, float(result.cost), bool(result.feasible),
                     bool(result.optimal), float(result.max_violation), cpu_s, result.status,
                     bool(result.stats.get("half_cycle")), log)


def parse_variant(text: str, base: PlannerOptions) -> Variant:
    """``name=JSON`` → the baseline options with the JSON's IPOPT options as `ipopt_extra`
    (``tol`` as `PlannerOptions.tol`); SystemExit with the reason if it does not parse."""
    name, sep, spec = text.partition("=")
    if not sep or not name:
        raise SystemExit(f"variant {text!r}: use name=JSON, e.g. tol5='{{\"tol\": 1e-5}}'")
    try:
        extra = json.loads(spec)
    except json.JSONDecodeError as exc:
        raise SystemExit(f"variant {name}: {exc}") from None
    if not isinstance(extra, dict):
        raise SystemExit(f"variant {name}: {spec!r} is not a JSON object")
    tol = extra.pop("tol", base.tol)
    try:
        options = dataclasses.replace(base, tol=float(tol), ipopt_extra=tuple(extra.items()))
    except PlannerConfigError as exc:
        raise SystemExit(f"variant {name}: {exc}") from None
    return Variant(name, options)


def timed(planner: GaitPlanner, schedule: robots.ContactSchedule, speed_m_s: float,
          warm: bool) -> Solve:
    c0 = time.process_time()
    result = planner.solve(schedule, speed_m_s, warm_start=None if warm else False)
    return Solve.of(result, time.process_time() - c0)


def cell(s: Solve, b: Solve) -> str:
    """One solve beside the baseline's: iterations, relative cost, flags."""
    rel = (s.cost - b.cost) / max(abs(b.cost), 1e-12)
    flags = ("" if s.optimal else "c") + ("" if s.feasible == b.feasible else " V!")
    return f"{s.iterations}{flags} {rel:+.1e}"


def report(title: str, names: list[str], rows: list[tuple[str, dict[str, Solve]]]) -> None:
    base = names[0]
    print(f"\n{title}")
    print("| schedule | " + " | ".join(names) + " | worst violation | CPU [s] |")
    print("|---" * (len(names) + 3) + "|")
    for label, solves in rows:
        b = solves[base]
        cells = [cell(solves[n], b) for n in names]
        worst = " / ".join(f"{solves[n].max_violation:.0e}" for n in names)
        cpu = " / ".join(f"{solves[n].cpu_s:.2f}" for n in names)
        feas = "" if b.feasible else " (infeasible)"
        print(f"| {label}{feas} | " + " | ".join(cells) + f" | {worst} | {cpu} |")
    print("| variant | sum it | median it | sum CPU [s] | CPU / base | iterations / base | "
          "verdicts differ | not optimal | cost > +1e-4 rel | lower < -1e-4 |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    base_cpu = sum(s[base].cpu_s for _, s in rows)
    base_it = sum(s[base].iterations for _, s in rows)
    for n in names:
        its = [s[n].iterations for _, s in rows]
        total_cpu_s = sum(s[n].cpu_s for _, s in rows)
        differ = sum(s[n].feasible != s[base].feasible for _, s in rows)
        short = sum(not s[n].optimal for _, s in rows)
        rels = [(s[n].cost - s[base].cost) / max(abs(s[base].cost), 1e-12)
                for _, s in rows if s[n].feasible and s[base].feasible]
        print(f"| {n} | {sum(its)} | {statistics.median(its) if its else 0:g} | "
              f"{total_cpu_s:.2f} | {total_cpu_s / max(base_cpu, 1e-9):.3f} | "
              f"{sum(its) / max(base_it, 1):.3f} | {differ} | "
              f"{short} | {sum(r > 1e-4 for r in rels)} (worst {max(rels, default=0):+.1e}) | "
              f"{sum(r < -1e-4 for r in rels)} |", flush=True)


def trace(label: str, s: Solve) -> None:
    obj, pr, du = s.log["obj"], s.log["inf_pr"], s.log["inf_du"]
    if not obj:
        return
    final = obj[-1]
    print(f"  trace {label} ({s.iterations} it, {s.status}): it obj-rel inf_pr inf_du")
    for k, (o, p, d) in enumerate(zip(obj, pr, du, strict=False)):
        print(f"    {k:3d} {(o - final) / max(abs(final), 1e-12):+.1e} {p:.1e} {d:.1e}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("variants", nargs="+", help="name=JSON (module docstring); first: baseline")
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=None)
    ap.add_argument("--gait", default=None, help="random schedules' and chain's template")
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--templates", default=None, help="only these (comma-separated; '' none)")
    ap.add_argument("--random", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--warm", type=int, default=0)
    ap.add_argument("--symmetric", action="store_true")
    ap.add_argument("--trace", default=None, help="print this variant's iteration logs")
    ap.add_argument("--out", default=None, help="append one JSON line per solve")
    a = ap.parse_args(argv)
    speed = a.speed if a.speed is not None else DEFAULT_SPEED_M_S.get(a.robot, 0.25)
    robot = robots.load(a.robot)
    gait = a.gait or default_gait_for(robot)
    base_options, _ = cli_search_options(robot, speed_m_s=speed)
    variants = [parse_variant(v, base_options) for v in a.variants]
    names = [v.name for v in variants]
    if len(set(names)) != len(names):
        raise SystemExit("variant names must differ")
    known = templates_for(robot)
    only = known if a.templates is None else [t for t in a.templates.split(",") if t]
    if set(only) - set(known):
        raise SystemExit(f"--templates: {a.robot} has no {', '.join(set(only) - set(known))}")
    schedules = [(t, make_schedule(robot, t)) for t in only]
    rng = np.random.default_rng(a.seed)
    base = make_schedule(robot, gait)
    schedules += [(f"random{i}", random_schedule(base, rng)) for i in range(a.random)]
    print(f"{a.robot} N={a.knots} at {speed} m/s, "
          f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.2f}; "
          + "; ".join(f"{v.name}: tol {v.options.tol:g} {dict(v.options.ipopt_extra)}"
                      for v in variants), flush=True)
    planners = {v.name: GaitPlanner(robot, a.knots, v.options) for v in variants}
    out = open(a.out, "a") if a.out else None

    def record(kind: str, label: str, name: str, s: Solve) -> None:
        if out is not None:
            out.write(json.dumps({"robot": a.robot, "kind": kind, "schedule": label,
                                  "variant": name, **{k: v for k, v in
                                                      dataclasses.asdict(s).items()
                                                      if k != "log"}}) + "\n")
            out.flush()
        if a.trace == name:
            trace(f"{kind} {label}", s)

    rows: list[tuple[str, dict[str, Solve]]] = []
    for i, (label, schedule) in enumerate(schedules):
        order = names[i % len(names):] + names[:i % len(names)]
        try:
            solves = {n: timed(planners[n], schedule, speed, warm=False) for n in order}
        except PlannerConfigError as exc:
            print(f"  {label}: skipped ({exc})")
            continue
        for n in names:
            record("cold", label, n, solves[n])
        rows.append((label, solves))
        print(f"  {label}: " + " | ".join(f"{n} {cell(solves[n], solves[names[0]])} "
                                          f"{solves[n].cpu_s:.2f}s" for n in names), flush=True)
    if rows:
        report("cold solves", names, rows)
    if a.warm:
        image = mirror_permutation(robot) if a.symmetric else None
        if a.symmetric and image is None:
            raise SystemExit(f"--symmetric: {a.robot} has no mirror map")
        warm_rng = np.random.default_rng(a.seed + 1)
        chain = [perturbed(base, warm_rng) if image is None
                 else symmetric_perturbed(base, image, warm_rng) for _ in range(a.warm)]
        for n in names:
            planners[n].solve(base, speed, warm_start=False)  # each chain starts here
        warm_rows: list[tuple[str, dict[str, Solve]]] = []
        for i, schedule in enumerate(chain):
            order = names[i % len(names):] + names[:i % len(names)]
            solves = {n: timed(planners[n], schedule, speed, warm=True) for n in order}
            for n in names:
                record("warm", f"s{i}", n, solves[n])
            warm_rows.append((f"s{i}", solves))
            print(f"  warm s{i}: " + " | ".join(f"{n} {cell(solves[n], solves[names[0]])} "
                                               f"{solves[n].cpu_s:.2f}s" for n in names),
                  flush=True)
        report(f"warm chain of {a.warm} ({gait}, {'symmetric ' if a.symmetric else ''}"
               "perturbed)", names, warm_rows)
    print(f"\nend {time.strftime('%H:%M:%S', time.gmtime())} UTC, load "
          f"{os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

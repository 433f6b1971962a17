"""Where an IPOPT iteration of the gait search's coarse NLP goes, and how it scales with knots.

    python benchmarks/coarse_profile.py [--robot quad12] [--speed 0.25] [--knots 12,30]
                                        [--gaits trot,walk] [--reps 2] [--timing]

For each knot count, builds the planner with the options ``gaitsmith plan ROBOT --search`` uses
with no flags (the search's iteration cap) and solves each template gait cold `--reps` times,
the knot counts alternating, then prints CPU ms per iteration (`time.process_time`), CasADi's
per-function statistics of the last solve (calls and CPU of ``nlp_hess_l``, ``nlp_jac_g``, …),
and which functions the NLP's Hessian and Jacobian call how often (the knot's H and J are each
evaluated once per knot). `--timing` re-solves the first gait once with IPOPT's
``print_timing_statistics`` (function evaluations vs linear solver vs the rest).

Measured in docs/results/planner_speed_search.md, session 27: a 12-knot iteration costs 0.41×
a 30-knot one in CPU; ≈ 50 % MUMPS + BLAS, ≈ 28 % the knot's H and J on CasADi's SX machine.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import casadi as ca

import robots
from gaitsmith.stance_options import stance_shaped
from planner.nlp.config import CostWeights, PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.search.gait_search import DEFAULT_SEARCH_MAX_ITER
from planner.templates import make_schedule

NLP_FUNCTIONS = ("nlp_hess_l", "nlp_jac_g", "nlp_grad_f", "nlp_g", "nlp_f")


def calls(function: ca.Function) -> dict[str, int]:
    """How often each function is called by the MX function `function`."""
    count: collections.Counter[str] = collections.Counter()
    for k in range(function.n_instructions()):
        if function.instruction_id(k) == ca.OP_CALL:
            count[function.instruction_MX(k).which_function().name()] += 1
    return dict(count)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--knots", default="12,30")
    ap.add_argument("--gaits", default="trot,walk")
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--timing", action="store_true",
                    help="one more solve with IPOPT's print_timing_statistics")
    args = ap.parse_args()
    robot = robots.load(args.robot)
    shaped = stance_shaped(robot, None, None, None, None)
    options = PlannerOptions(
        weights=CostWeights() if shaped.bounce is None else CostWeights(bounce_s2_m2=shaped.bounce),
        normal_force_rate_weights_per_t0=shaped.force_rate or None,
        max_iter=DEFAULT_SEARCH_MAX_ITER)
    knots = [int(k) for k in args.knots.split(",")]
    gaits = args.gaits.split(",")
    planners = {n: GaitPlanner(robot, n, options) for n in knots}
    print(f"{args.robot} at {args.speed} m/s, gaits {gaits}, load average "
          f"{os.getloadavg()[0]:.2f}, {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC")
    for n, planner in planners.items():
        print(f"  N = {n}: {planner.layout.size} variables, {planner._lbg.size} rows, "
              f"derivatives {planner.derivative_cache}")
    cpu = collections.defaultdict(list)
    iterations = collections.defaultdict(list)
    for rep in range(args.reps):
        for n in knots if rep % 2 == 0 else knots[::-1]:
            c0, its = time.process_time(), 0
            for gait in gaits:
                its += planners[n].solve(make_schedule(robot, gait), args.speed,
                                         warm_start=False).iterations
            cpu[n].append(time.process_time() - c0)
            iterations[n].append(its)
    for n in knots:
        per_it = [1e3 * c / max(i, 1) for c, i in zip(cpu[n], iterations[n], strict=True)]
        print(f"  N = {n}: {iterations[n][0]} iterations per round, CPU ms/it "
              + ", ".join(f"{v:.1f}" for v in per_it))
        stats = planners[n]._solver.stats()
        for name in NLP_FUNCTIONS:
            key = name.removeprefix("nlp_")
            print(f"    {name:11s} {stats.get(f'n_call_nlp_{key}', 0):3d} calls, "
                  f"{stats.get(f't_proc_nlp_{key}', 0.0):.3f} s CPU (last solve); calls "
                  f"{calls(planners[n]._solver.get_function(name))}")
    if args.timing:
        n = knots[0]
        timed = GaitPlanner(robot, n, dataclasses.replace(options, print_level=5))
        timed.solve(make_schedule(robot, gaits[0]), args.speed, warm_start=False)


if __name__ == "__main__":
    main()

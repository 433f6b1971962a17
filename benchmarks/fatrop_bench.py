"""EXPERIMENTAL stage-wise FATROP beside IPOPT + MUMPS (the "knot" path), in one run (issue #16).

    python benchmarks/fatrop_bench.py --robot quad12 --knots 8 --random 2
    python benchmarks/fatrop_bench.py --robot quad12 --knots 30 --random 0 --cold-iter 10 \
        --warm-iter 10

On the template schedule and `--random` random schedules (`planner_bench.random_schedule`) it
solves with IPOPT cold, then with FATROP (`planner.nlp.fatrop_solver`) twice: cold from the same
initial guess (at most `--cold-iter` iterations) and started at IPOPT's optimum (at most
`--warm-iter`: does FATROP recognise the optimum?). Per solve: time, iterations, ms/iteration,
the verdict on the planner's own NLP and the cost relative to IPOPT's; FATROP's time split
(search direction vs function evaluations); at the end the ms/iteration ratio FATROP/IPOPT over
all solves of the run. Prints the stage dimensions (nx, nu, rows per stage).

`--stagewise-ipopt` adds IPOPT (same options as the planner's) on the stage-wise NLP itself, cold:
whether the reformulation has the planner's optimum when solved from scratch, and what the larger
formulation costs IPOPT per iteration (solver versus formulation).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import casadi as ca
import numpy as np
from planner_bench import random_schedule

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.fatrop_solver import FatropPlanner
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.nlp.stagewise import stage_bounds
from planner.nlp.variables import initial_guess, parameter_vector
from planner.templates import make_schedule

GAITS = {"quad12": ("trot", 0.25), "hex18": ("tripod", 0.15)}


def _line(name: str, r: PlanResult, ref: PlanResult | None) -> str:
    per_it = 1e3 * r.solve_time_s / max(1, r.iterations)
    text = (f"{name} {r.solve_time_s:7.2f} s {r.iterations:4d} it {per_it:7.1f} ms/it "
            f"{'feasible' if r.feasible else 'not feasible'} ({r.status}, worst violation "
            f"{r.max_violation:.1e}) cost {r.cost:.6g}")
    if ref is not None:
        text += f" rel {(r.cost - ref.cost) / max(abs(ref.cost), 1e-12):+.1e}"
    fat = r.stats.get("fatrop")
    if fat:
        text += (f" | sd {fat['compute_sd_time']:.2f} s, jac {fat['eval_jac_time']:.2f} s, "
                 f"hess {fat['eval_hess_time']:.2f} s")
    return text


def _stagewise_ipopt(planner: FatropPlanner) -> ca.Function:
    """IPOPT with the planner's default options (its iteration cap too) on `planner`'s stage-wise
    NLP (expanded)."""
    sw = planner.stagewise
    assert sw is not None
    o = planner.options
    ipopt: dict[str, Any] = {
        "tol": o.tol, "acceptable_tol": 1e-4, "constr_viol_tol": 1e-5,
        "max_iter": o.max_iter_for(sw.w.numel()), "print_level": 0, "mu_strategy": "adaptive",
        "sb": "yes", "mumps_pivot_order": 5, "mu_init": 1e-2,
    }
    return ca.nlpsol("stagewise_ipopt", "ipopt", {"x": sw.w, "p": sw.p, "f": sw.f, "g": sw.g},
                     {"ipopt": ipopt, "expand": True, "print_time": False,
                      "error_on_fail": False})


def _solve_stagewise_ipopt(
    solver: ca.Function, planner: FatropPlanner, schedule: robots.ContactSchedule, speed: float
) -> PlanResult:
    sw = planner.stagewise
    assert sw is not None
    p = parameter_vector(schedule, planner.n_knots, speed, planner.swing_clearance_m)
    w0 = np.asarray(sw.to_stage(initial_guess(planner.layout, planner.model, schedule), p))
    bounds = planner.stage_solve_bounds()
    lbw, ubw = stage_bounds(sw, bounds.lbx, bounds.ubx)
    t0 = time.perf_counter()
    sol = solver(x0=w0, p=p, lbx=lbw, ubx=ubw, lbg=sw.lbg, ubg=sw.ubg)
    elapsed = time.perf_counter() - t0
    stats = solver.stats()
    x = np.asarray(sol["x"]).ravel()[sw.from_planner_index]
    plain = {"x": x, "lam_x": np.zeros_like(x), "lam_g": np.zeros_like(planner._lbg),
             "f": float(sol["f"])}
    return planner._result(schedule, speed, p, plain, stats, elapsed, bounds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--robot", choices=tuple(GAITS), default="quad12")
    ap.add_argument("--knots", type=int, default=8)
    ap.add_argument("--random", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cold-iter", type=int, default=150)
    ap.add_argument("--warm-iter", type=int, default=30)
    ap.add_argument("--stagewise-ipopt", action="store_true")
    args = ap.parse_args()
    robot = robots.load(args.robot)
    gait, speed = GAITS[args.robot]
    n = args.knots
    t0 = time.perf_counter()
    # the stage-wise NLP has no normal-force rate rows: both solve the NLP without them
    ipopt = GaitPlanner(robot, n, PlannerOptions(derivatives="knot",
                                                 normal_force_rate_weights_per_t0=None))
    ipopt_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    cold = FatropPlanner(robot, n, PlannerOptions(max_iter=args.cold_iter,
                                                  normal_force_rate_weights_per_t0=None))
    cold_build = time.perf_counter() - t0
    # started at IPOPT's optimum: a small barrier parameter and bound push (FATROP has no
    # warm_start_init_point option)
    warm = FatropPlanner(robot, n, PlannerOptions(max_iter=args.warm_iter,
                                                  normal_force_rate_weights_per_t0=None),
                         {"mu_init": 1e-6, "bound_push": 1e-8, "bound_frac": 1e-8})
    sw = cold.stagewise
    assert sw is not None
    print(f"{args.robot} {gait} N={n}: build IPOPT (knot) {ipopt_build:.2f} s, FATROP "
          f"{cold_build:.2f} s | stage nx {sw.nx[0]}, nu {sw.nu[0]}, rows {sw.ng[1]} per stage "
          f"({sum(sw.equality)} equalities of {len(sw.equality)}), {sw.size} variables vs "
          f"{ipopt.layout.size} in the planner's NLP")
    sw_ipopt = None
    if args.stagewise_ipopt:
        t0 = time.perf_counter()
        sw_ipopt = _stagewise_ipopt(cold)
        print(f"  build IPOPT on the stage-wise NLP {time.perf_counter() - t0:.2f} s")
        per_it_extra: list[float] = []
    rng = np.random.default_rng(args.seed)
    base = make_schedule(robot, gait)
    schedules = [(gait, base)] + [(f"random{i}", random_schedule(base, rng))
                                  for i in range(args.random)]
    per_it: dict[str, list[float]] = {"ipopt": [], "fatrop cold": [], "fatrop at optimum": []}
    for label, schedule in schedules:
        ref = ipopt.solve(schedule, speed, warm_start=False)
        print(f"  {label}:")
        print("    " + _line("ipopt            ", ref, None))
        per_it["ipopt"].append(ref.solve_time_s / max(1, ref.iterations))
        fc = cold.solve(schedule, speed, warm_start=False)
        print("    " + _line("fatrop cold      ", fc, ref))
        per_it["fatrop cold"].append(fc.solve_time_s / max(1, fc.iterations))
        fw = warm.solve(schedule, speed, warm_start=ref.warm_start)
        print("    " + _line("fatrop at optimum", fw, ref))
        per_it["fatrop at optimum"].append(fw.solve_time_s / max(1, fw.iterations))
        if sw_ipopt is not None:
            si = _solve_stagewise_ipopt(sw_ipopt, cold, schedule, speed)
            print("    " + _line("ipopt stage-wise ", si, ref))
            per_it_extra.append(si.solve_time_s / max(1, si.iterations))
    med = {k: 1e3 * statistics.median(v) for k, v in per_it.items()}
    print("  median ms/iteration: " + ", ".join(f"{k} {v:.1f}" for k, v in med.items())
          + f" | FATROP/IPOPT per iteration: cold {med['fatrop cold'] / med['ipopt']:.1f}, "
          f"at optimum {med['fatrop at optimum'] / med['ipopt']:.1f}")
    if sw_ipopt is not None:
        extra = 1e3 * statistics.median(per_it_extra)
        print(f"  IPOPT on the stage-wise NLP: {extra:.1f} ms/iteration, "
              f"/IPOPT on the planner's NLP {extra / med['ipopt']:.1f}")


if __name__ == "__main__":
    main()

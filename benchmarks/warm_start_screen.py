"""Screen warm starts onto a changed contact pattern (issue #16), on `planner_bench`'s warm chain.

    python benchmarks/warm_start_screen.py --robot quad12 --warm 8 --variants prev,retimed,...
    python benchmarks/warm_start_screen.py --robot quad12 --warm 8 --symmetric ...

One planner (default options). The template is solved cold, then a chain of `--warm` perturbed
schedules (`planner_bench.perturbed`: touchdown phases ±0.03, duty ±0.03, period ±5 %; with
`--symmetric` the perturbation is drawn per mirror pair so every schedule stays half-cycle
symmetric), each solved cold, then, per variant, each solved warm from the variant's own
previous optimum (a real chain). Every warm solve is compared against the cold solve of the
same schedule: the same feasibility verdict and a cost within `SAME_COST_RTOL` relative or lower.

A variant is ``START[+DUALS][+OPTION...]``:
- START: ``prev`` (the previous optimum as is), ``retimed`` (`variables.retimed_start`),
  ``perfoot`` (`planner.nlp.warm_start.per_foot_retimed`);
- DUALS: ``keep`` (the previous multipliers), ``keepz`` (kept, those of the rows and bounds
  whose value or bounds the new schedule changes zeroed); default: dropped (`WARM_START_DUALS`);
- OPTION: ``mu1``/``mu2``/``mu4``/``mu5``/``mu6`` (μ₀ 1e-1…1e-6), ``push1``/``push2``/
  ``push5``/``push6`` (the three warm bound pushes 1e-1, 1e-2, 1e-5, 1e-6), ``mono``
  (``mu_strategy monotone``), ``probing``/``loqo`` (``mu_oracle``), ``print5`` (IPOPT's
  iteration log), ``tol5``/``tol4`` (IPOPT's ``tol`` 1e-5 / 1e-4 instead of
  `PlannerOptions.tol`), ``cold`` (the cold solve's options), ``half`` (the half-cycle NLP where
  the schedule is symmetric, `--symmetric`), ``swb`` (the warm solve holds the swing feet's
  wrench at 0 by bounds, `PlannerOptions.swing_wrench`), ``fixrates`` (the start's lifted rates
  the cyclic differences of its poses), ``fix`` (the start's rates, wrench, torques and goal
  slopes recomputed from its poses and forces: `ColdStarter.consistent`).
Prints per solve the iterations, CPU and start infeasibility, and per variant the totals.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")

import numpy as np

import robots
from planner.nlp import spacetime
from planner.nlp.cold_start import StartCommand
from planner.nlp.command import VelocityCommand
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, PlanResult, WarmStart
from planner.nlp.variables import parameter_vector, retimed_start
from planner.nlp.warm_start import per_foot_retimed
from planner.templates import make_schedule, mirror_permutation

sys.path.insert(0, str(Path(__file__).resolve().parent))
from planner_bench import (
    SAME_COST_RTOL,
    add_chain_arguments,
    chain_defaults,
    perturbed,
    symmetric_perturbed,
)

OPTION_FLAGS: dict[str, dict[str, Any]] = {
    "mu1": {"mu_init": 1e-1},
    "mu2": {"mu_init": 1e-2},
    "mu4": {"mu_init": 1e-4},
    "mu5": {"mu_init": 1e-5},
    "mu6": {"mu_init": 1e-6},
    "push2": {k: 1e-2 for k in ("warm_start_bound_push", "warm_start_slack_bound_push",
                                "warm_start_mult_bound_push")},
    "push1": {k: 1e-1 for k in ("warm_start_bound_push", "warm_start_slack_bound_push",
                                "warm_start_mult_bound_push")},
    "push5": {k: 1e-5 for k in ("warm_start_bound_push", "warm_start_slack_bound_push",
                                "warm_start_mult_bound_push")},
    "push6": {k: 1e-6 for k in ("warm_start_bound_push", "warm_start_slack_bound_push",
                                "warm_start_mult_bound_push")},
    "mono": {"mu_strategy": "monotone"},
    "nowsip": {"warm_start_init_point": "no"},
    "mubased": {"bound_mult_init_method": "mu-based"},
    "lsduals": {"least_square_init_duals": "yes"},
    "bp3": {k: 1e-3 for k in ("bound_push", "bound_frac", "slack_bound_push", "slack_bound_frac")},
    "tol5": {"tol": 1e-5},
    "tol4": {"tol": 1e-4},
    "print5": {"print_level": 5, "print_timing_statistics": "no"},
    "probing": {"mu_oracle": "probing"},
    "loqo": {"mu_oracle": "loqo"},
}


@dataclass(frozen=True)
class Variant:
    name: str
    start: str
    duals: str
    ipopt: dict[str, Any]
    cold_options: bool
    half: bool
    fix: bool = False
    fix_rates: bool = False
    swing_wrench: str | None = None
    centred: bool = False

    @classmethod
    def parse(cls, name: str) -> Variant:
        start, *flags = name.split("+")
        if start not in ("prev", "retimed", "perfoot"):
            raise SystemExit(f"variant {name!r}: start {start!r} is not prev/retimed/perfoot")
        duals, extra, cold, half, fix, rates = "drop", {}, False, False, False, False
        wrench, centred = None, False
        for flag in flags:
            if flag in ("keep", "keepz"):
                duals = flag
            elif flag in OPTION_FLAGS:
                extra.update(OPTION_FLAGS[flag])
            elif flag == "cold":
                cold = True
            elif flag == "half":
                half = True
            elif flag == "fix":
                fix = True
            elif flag == "fixrates":
                rates = True
            elif flag == "swb":
                wrench = "bounds"
            elif flag == "centre":
                centred = True
            else:
                raise SystemExit(f"variant {name!r}: unknown flag {flag!r}")
        return cls(name, start, duals, extra, cold, half, fix, rates, wrench, centred)


def changed_rows(planner: GaitPlanner, x: np.ndarray, p_from: np.ndarray, p_to: np.ndarray,
                 b_from: spacetime.SolveBounds, b_to: spacetime.SolveBounds
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Rows whose value at `x` or whose bounds the new parameters change, and variables whose
    bounds change (boolean masks)."""
    g_from = np.asarray(planner._evaluate(x / planner._x_scale, p_from)[0]).ravel()
    g_to = np.asarray(planner._evaluate(x / planner._x_scale, p_to)[0]).ravel()
    rows = (~np.isclose(g_from, g_to, rtol=1e-9, atol=1e-12)
            | (b_from.lbg != b_to.lbg) | (b_from.ubg != b_to.ubg))
    cols = (b_from.lbx != b_to.lbx) | (b_from.ubx != b_to.ubx)
    return rows, cols


def start_groups(planner: GaitPlanner, x: np.ndarray, p: np.ndarray,
                 bounds: spacetime.SolveBounds, top: int = 4) -> str:
    """The constraint groups worst violated at `x` (scaled as IPOPT sees them)."""
    g = np.asarray(planner._evaluate(x / planner._x_scale, p)[0]).ravel()
    viol = np.maximum(bounds.lbg - g, 0.0) + np.maximum(g - bounds.ubg, 0.0)
    viol = viol / planner._g_scale
    worst = sorted(((float(viol[sl].max(initial=0.0)), name, int((viol[sl] > 1e-6).sum()))
                    for name, sl in planner._slices), reverse=True)[:top]
    return ", ".join(f"{name} {v:.2g} ({k} rows)" for v, name, k in worst if v > 0)


def fd_rates(planner: GaitPlanner, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """`x` with its lifted rates the cyclic differences of its poses (the NLP's own rows)."""
    layout = planner.layout
    out = np.array(x, dtype=float)
    layout.view(out, "vel")[:] = 0.0
    layout.view(out, "acc")[:] = 0.0
    fd = dict(planner._slices)["finite differences"]
    rates = -np.asarray(planner._evaluate(out / planner._x_scale, p)[0]).ravel()[fd]
    vel, acc = np.split(rates, 2)
    layout.view(out, "vel")[:] = vel.reshape(layout.n_knots, -1)
    layout.view(out, "acc")[:] = acc.reshape(layout.n_knots, -1)
    return out


def centred_duals(planner: GaitPlanner, x: np.ndarray, schedule: robots.ContactSchedule,
                  speed: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """Bound and inequality multipliers on the central path at `x`: μ / (distance to the
    nearer finite bound) in the solver's scaled units, signed as CasADi's (upper +, lower −);
    equality rows 0. Returned in physical units (`GaitPlanner.solve` scales them)."""
    b = planner._solve_bounds(schedule)
    xs, gs = planner._x_scale, planner._g_scale
    push = spacetime.TUNED_WARM_BOUND_PUSH

    def side(v: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        d_lo = np.where(np.isfinite(lo), v - lo, np.inf)
        d_hi = np.where(np.isfinite(hi), hi - v, np.inf)
        floor = push * np.maximum(1.0, np.abs(v))
        z_lo = mu / np.maximum(d_lo, floor)
        z_hi = mu / np.maximum(d_hi, floor)
        out = np.where(d_hi < d_lo, z_hi, -z_lo)
        out[(~np.isfinite(lo) & ~np.isfinite(hi)) | (lo == hi)] = 0.0
        return out

    p = parameter_vector(schedule, planner.n_knots, speed, planner.swing_clearance_m)
    g = np.asarray(planner._evaluate(x / xs, p)[0]).ravel()
    lam_x = side(x / xs, b.lbx / xs, b.ubx / xs) / xs  # solver's λ̃ = λ·xs
    lam_g = side(g / gs, b.lbg / gs, b.ubg / gs) / gs
    return lam_x, lam_g


def make_start(planner: GaitPlanner, v: Variant, prev: PlanResult,
               s_from: robots.ContactSchedule, s_to: robots.ContactSchedule,
               speed: float) -> WarmStart:
    x = prev.warm_start.x
    n = planner.n_knots
    if v.start == "retimed":
        x = retimed_start(planner.layout, x, s_from.period_s, s_to.period_s,
                          s_from.contact_matrix(n), s_to.contact_matrix(n))
    elif v.start == "perfoot":
        x = per_foot_retimed(planner.layout, planner.robot, x, s_from, s_to)
    if v.fix:
        p = parameter_vector(s_to, n, speed, planner.swing_clearance_m)
        x = planner._starter().consistent(
            x, s_to, StartCommand(VelocityCommand(speed), planner.swing_clearance_m), p)
    if v.fix_rates:
        x = fd_rates(planner, x, parameter_vector(s_to, n, speed, planner.swing_clearance_m))
    lam_x, lam_g = prev.warm_start.lam_x.copy(), prev.warm_start.lam_g.copy()
    if v.centred:
        lam_x, lam_g = centred_duals(planner, x, s_to, speed, v.ipopt.get("mu_init", 1e-3))
    if v.duals == "keepz":
        clear = planner.swing_clearance_m
        rows, cols = changed_rows(planner, x, parameter_vector(s_from, n, speed, clear),
                                  parameter_vector(s_to, n, speed, clear),
                                  planner._solve_bounds(s_from), planner._solve_bounds(s_to))
        lam_g[rows] = 0.0
        lam_x[cols] = 0.0
    return WarmStart(x, lam_x, lam_g)


def _options_for(v: Variant) -> Any:
    real = _REAL_IPOPT_OPTIONS

    def patched(options: PlannerOptions, warm: bool) -> dict[str, Any]:
        out = real(options, warm and not v.cold_options)
        if warm:
            out.update(v.ipopt)
        return out

    return patched


_REAL_IPOPT_OPTIONS = spacetime.ipopt_options


def run_variant(planner: GaitPlanner, v: Variant, base: robots.ContactSchedule,
                base_res: PlanResult, chain: list[robots.ContactSchedule],
                colds: list[tuple[PlanResult, float]], speed: float, verbose: bool
                ) -> dict[str, Any]:
    spacetime.ipopt_options = _options_for(v)
    spacetime.WARM_START_DUALS = v.duals != "drop"
    planner._warm_solver = None
    if planner._half_cycle not in (None, False):
        planner._half_cycle = None  # rebuilt with the variant's options if it uses them
    try:
        prev, s_prev = base_res, base
        out: dict[str, Any] = {"it": [], "cpu": [], "wall": [], "same": 0, "lower": 0,
                               "differs": [], "half": 0, "inf0": []}
        for i, (s, (cold, _)) in enumerate(zip(chain, colds, strict=True)):
            start = make_start(planner, v, prev, s_prev, s, speed)
            t0 = time.process_time()
            r = planner.solve(s, speed, warm_start=start, half_cycle=v.half,
                              swing_wrench=v.swing_wrench)
            cpu = time.process_time() - t0
            out["it"].append(r.iterations)
            out["cpu"].append(cpu)
            out["wall"].append(r.solve_time_s)
            out["half"] += bool(r.stats.get("half_cycle"))
            inf = r.stats["iterations"].get("inf_pr") or [float("nan")]
            out["inf0"].append(inf[0])
            rel = (r.cost - cold.cost) / max(abs(cold.cost), 1e-12)
            same = r.feasible == cold.feasible and (not cold.feasible or rel <= SAME_COST_RTOL)
            out["same"] += same
            out["lower"] += bool(r.feasible and cold.feasible and rel < -SAME_COST_RTOL)
            if not same:
                out["differs"].append(f"s{i} {'F' if r.feasible else r.status} rel {rel:+.1e}")
            if verbose:
                print(f"    {v.name} s{i}: {r.iterations} it, CPU {cpu:.2f} s, inf_pr0 "
                      f"{inf[0]:.2g}, cost {r.cost:.6g} rel {rel:+.1e}"
                      f"{' half' if r.stats.get('half_cycle') else ''}"
                      f"{'' if r.feasible else ' INFEASIBLE ' + r.status}", flush=True)
            if r.feasible:
                prev, s_prev = r, s
        return out
    finally:
        spacetime.ipopt_options = _REAL_IPOPT_OPTIONS
        spacetime.WARM_START_DUALS = False
        planner._warm_solver = None
        if planner._half_cycle not in (None, False):
            planner._half_cycle = None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_chain_arguments(ap)
    ap.add_argument("--warm", type=int, default=8)
    ap.add_argument("--symmetric", action="store_true")
    ap.add_argument("--variants", default="prev,retimed,perfoot")
    ap.add_argument("--diagnose", action="store_true",
                    help="print the worst violated groups at each variant's first start")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args()
    chain_defaults(args)
    gait, speed = args.gait, args.speed
    variants = [Variant.parse(v) for v in args.variants.split(",") if v]
    robot = robots.load(args.robot)
    print(f"{args.robot} {gait} {speed} m/s N={args.knots}, chain of {args.warm} "
          f"({'symmetric' if args.symmetric else 'perturbed'}, seed {args.seed}); "
          f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.2f}",
          flush=True)
    planner = GaitPlanner(robot, args.knots, PlannerOptions())
    base = make_schedule(robot, gait)
    t0 = time.process_time()
    base_res = planner.solve(base, speed, warm_start=False)
    print(f"  template cold: {base_res.iterations} it, CPU {time.process_time() - t0:.2f} s, "
          f"cost {base_res.cost:.6g}, half {base_res.stats['half_cycle']}", flush=True)
    rng = np.random.default_rng(args.seed + 1)  # planner_bench compare's chain
    if args.symmetric:
        image = mirror_permutation(robot)
        assert image is not None
        chain = [symmetric_perturbed(base, image, rng) for _ in range(args.warm)]
    else:
        chain = [perturbed(base, rng) for _ in range(args.warm)]
    colds: list[tuple[PlanResult, float]] = []
    for i, s in enumerate(chain):
        t0 = time.process_time()
        r = planner.solve(s, speed, warm_start=False)
        colds.append((r, time.process_time() - t0))
        if not args.quiet:
            print(f"    cold s{i}: {r.iterations} it, CPU {colds[-1][1]:.2f} s, cost "
                  f"{r.cost:.6g}{' half' if r.stats['half_cycle'] else ''}"
                  f"{'' if r.feasible else ' INFEASIBLE ' + r.status}", flush=True)
    if args.diagnose:
        n = args.knots
        for v in variants:
            start = make_start(planner, v, base_res, base, chain[0], speed)
            p = parameter_vector(chain[0], n, speed, planner.swing_clearance_m)
            worst = start_groups(planner, start.x, p, planner._solve_bounds(chain[0]))
            print(f"  start {v.start} onto s0: {worst}")
    cold_it = [r.iterations for r, _ in colds]
    cold_cpu = [c for _, c in colds]
    print(f"  cold: median {statistics.median(cold_it):.1f} it, CPU median "
          f"{statistics.median(cold_cpu):.2f} s, total {sum(cold_cpu):.2f} s "
          f"({sum(cold_it)} it), half {sum(bool(r.stats['half_cycle']) for r, _ in colds)}",
          flush=True)
    for v in variants:
        o = run_variant(planner, v, base, base_res, chain, colds, speed, not args.quiet)
        print(f"  {v.name}: median {statistics.median(o['it']):.1f} it (total {sum(o['it'])}, "
              f"/cold {sum(o['it']) / max(1, sum(cold_it)):.2f}), CPU median "
              f"{statistics.median(o['cpu']):.2f} s (total {sum(o['cpu']):.2f} s, /cold "
              f"{sum(o['cpu']) / sum(cold_cpu):.2f}), inf_pr0 median "
              f"{statistics.median(o['inf0']):.2g}, same optimum {o['same']}/{len(chain)} "
              f"({o['lower']} lower){'; ' + ', '.join(o['differs']) if o['differs'] else ''}"
              f"{', half ' + str(o['half']) if v.half else ''}",
              flush=True)
    print(f"  {time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

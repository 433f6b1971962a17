"""Spacetime planner benchmark: NLP build time, cold solve, median warm solve over 10 schedules.

    python benchmarks/planner_bench.py            # quad12 trot N=30 and hex18 tripod N=30
    python benchmarks/planner_bench.py --section build   # only the build-once measurement
    python benchmarks/planner_bench.py --section compare # derivative paths side by side (#16)

Each warm solve starts from the previous solution with a perturbed schedule (touchdown phases
±0.03, duty ±0.03, period ±5 %) — what basin-CMA's inner loop does. Prints times, the
warm/cold ratio and the ratio against the previous warm-start policy (last multipliers reused),
measured in the same run on the same schedules.

The `build` section measures what a disk cache of the built NLP (issue #16) could save, in one
run: the cold build split into the symbolic part (model, knot quantities, constraint groups) and
`nlpsol` creation (IPOPT with ``expand``: SX expansion, Jacobian and Lagrangian Hessian), then
the same solver written with CasADi's serialiser (`Function.save`) and read back
(`Function.load`): "cached build" = symbolic part + load, ratio = cold / cached.
For scale it also prints the instruction counts of the NLP's Jacobian and Lagrangian Hessian
next to those of one knot (`planner.nlp.constraints.knot_function`) and the time to build the
knot's own derivatives: the whole-NLP derivatives are N expanded copies of the knot's.

The `compare` section runs the solver paths named by ``--paths`` (default ``expanded,knot``:
the whole NLP expanded to SX, and the per-knot derivatives of `planner.nlp.solver_cache`; the
first is the baseline, `PATHS` lists them all) in one run on the same schedules: every template
of the robot and `--random` random schedules, cold, then a chain of `--warm` perturbed warm
solves (`--symmetric`: perturbations that keep the schedule half-cycle symmetric), each compared
against the baseline's cold solve of the same schedule. It prints per path median/min/max solve
time, iterations, ms/iteration and the ratio against the baseline, the build times (with an
empty disk cache and from the cache) and whether each path reaches the baseline's optimum
(same feasibility verdict, cost within 1e-4 relative or lower) over the solves that converged;
a pair in which either solve stopped at the iteration cap is counted apart, with its cost
difference, and not called the same optimum. Each path builds into an empty temporary disk cache,
so "knot" paths run the uncompiled knot derivatives (a robot's first command); `--cache DIR`
builds them from DIR instead (after `gaitsmith cache build ROBOT`: the compiled ones, what later
commands get; the build line says which).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
# a "knot" build on an empty cache would start compiling the robot's J and H in the background
# (planner.nlp.background_compile), on the cores being measured; set it to 1 to measure that
os.environ.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")

import casadi as ca
import numpy as np

import robots
from planner.errors import PlannerConfigError
from planner.nlp import spacetime
from planner.nlp.config import COMPACT_ROWS, PlannerOptions
from planner.nlp.constraints import knot_function
from planner.nlp.solver_cache import cache_folder
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.templates import (
    default_gait_for,
    make_schedule,
    mirror_permutation,
    templates_for,
)

SAME_COST_RTOL = 1e-4


def perturbed(schedule: robots.ContactSchedule, rng: np.random.Generator) -> robots.ContactSchedule:
    n = schedule.n_feet
    phases = tuple(float((p + rng.uniform(-0.03, 0.03)) % 1.0) for p in schedule.touchdown_phase)
    duty = tuple(
        float(np.clip(d + rng.uniform(-0.03, 0.03), 0.3, 0.95)) for d in schedule.duty_factor[:n]
    )
    return robots.ContactSchedule(
        schedule.period_s * float(rng.uniform(0.95, 1.05)), schedule.feet, phases, duty
    )


def warm_pass(
    planner: GaitPlanner, cold: PlanResult, schedules: list[robots.ContactSchedule], speed: float
) -> tuple[float, float, int, float]:
    """Chained warm solves from the cold solution: (median s, median it, feasible, ms/it)."""
    planner._last = cold.warm_start
    times, iters, ok = [], [], 0
    for schedule in schedules:
        res = planner.solve(schedule, speed)
        times.append(res.solve_time_s)
        iters.append(res.iterations)
        ok += res.feasible
    per_it = 1e3 * sum(times) / max(1, sum(iters))
    return statistics.median(times), statistics.median(iters), ok, per_it


def bench(robot_name: str, gait: str, speed: float, n_knots: int, n_warm: int, seed: int) -> None:
    robot = robots.load(robot_name)
    t0 = time.perf_counter()
    planner = GaitPlanner(robot, n_knots=n_knots)
    build = time.perf_counter() - t0
    base = make_schedule(robot, gait)
    cold = planner.solve(base, speed, warm_start=False)
    rng = np.random.default_rng(seed)
    schedules = [perturbed(base, rng) for _ in range(n_warm)]
    med, its, ok, per_it = warm_pass(planner, cold, schedules, speed)
    # baseline in the same run: the previous policy (warm start with the last multipliers)
    spacetime.WARM_START_DUALS = True
    try:
        b_med, b_its, b_ok, _ = warm_pass(planner, cold, schedules, speed)
    finally:
        spacetime.WARM_START_DUALS = False
    print(
        f"{robot_name} {gait} {speed} m/s N={n_knots}: build {build:.2f} s | "
        f"cold {cold.solve_time_s:.3f} s ({cold.iterations} it) | "
        f"warm median {med:.3f} s ({its:.0f} it, {ok}/{n_warm} feasible, {per_it:.1f} ms/it) | "
        f"warm/cold {med / cold.solve_time_s:.2f} | "
        f"baseline warm (with duals) {b_med:.3f} s ({b_its:.0f} it, {b_ok}/{n_warm} feasible) | "
        f"warm/baseline {med / b_med:.2f}"
    )


def with_full_solver(planner: GaitPlanner) -> GaitPlanner:
    """`planner` with its full NLP's IPOPT instance built now (it is built at its first use
    since session 44, and a half-cycle solve never uses it): the build times printed here keep
    including it, as before."""
    planner._solver  # noqa: B018  # the property builds it
    return planner


def build_bench(robot_name: str, n_knots: int) -> None:
    """Cold NLP build vs the same solver loaded from CasADi's serialised form (one run)."""
    robot = robots.load(robot_name)
    nlpsol_times: list[float] = []
    real_nlpsol = ca.nlpsol

    def timed_nlpsol(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        solver = real_nlpsol(*args, **kwargs)
        nlpsol_times.append(time.perf_counter() - t0)
        return solver

    ca.nlpsol = timed_nlpsol  # time nlpsol creation inside the one cold build
    try:
        planner = with_full_solver(GaitPlanner(robot, n_knots=n_knots))
    finally:
        ca.nlpsol = real_nlpsol
    cold, nlpsol_s = planner.build_time_s, sum(nlpsol_times)
    symbolic_s = cold - nlpsol_s
    with tempfile.TemporaryDirectory(prefix="planner_bench_") as tmp:
        path = Path(tmp) / "spacetime.casadi"
        t0 = time.perf_counter()
        planner._solver.save(str(path))
        save_s = time.perf_counter() - t0
        size_mb = path.stat().st_size / 1e6
        t0 = time.perf_counter()
        ca.Function.load(str(path))
        load_s = time.perf_counter() - t0
    cached = symbolic_s + load_s
    nlp_jac = planner._solver.get_function("nlp_jac_g").n_instructions()
    nlp_hess = planner._solver.get_function("nlp_hess_l").n_instructions()
    knot_s, knot_jac, knot_hess = _knot_derivatives(planner)
    print(
        f"{robot_name} N={n_knots} build: cold {cold:.2f} s (symbolic {symbolic_s:.2f} s, "
        f"nlpsol {nlpsol_s:.2f} s) | serialised solver {size_mb:.0f} MB, save {save_s:.2f} s, "
        f"load {load_s:.2f} s | cached build {cached:.2f} s | cold/cached {cold / cached:.2f}\n"
        f"  instructions: NLP Jacobian {nlp_jac}, Hessian {nlp_hess} | one knot: Jacobian "
        f"{knot_jac}, Hessian {knot_hess}, built in {knot_s:.2f} s"
    )


def _knot_derivatives(planner: GaitPlanner) -> tuple[float, int, int]:
    """(build s, Jacobian instructions, Lagrangian-Hessian instructions) of one knot in SX."""
    t0 = time.perf_counter()
    knot = knot_function(planner.model)
    ins = [ca.SX.sym(knot.name_in(i), knot.sparsity_in(i)) for i in range(knot.n_in())]
    x = ca.vertcat(*[ca.vec(v) for v in ins])
    out = ca.vertcat(*[ca.vec(v) for v in knot.call(ins)])
    lam = ca.SX.sym("lam", out.shape[0])
    jac = ca.Function("knot_jac", [x], [ca.jacobian(out, x)])
    hess = ca.Function("knot_hess", [x, lam], [ca.tril(ca.hessian(ca.dot(lam, out), x)[0])])
    return time.perf_counter() - t0, jac.n_instructions(), hess.n_instructions()


def random_schedule(
    base: robots.ContactSchedule, rng: np.random.Generator
) -> robots.ContactSchedule:
    """Random touchdown phases, duty factors in [0.5, 0.85], period ±15 % of the template's."""
    n = base.n_feet
    return robots.ContactSchedule(
        base.period_s * float(rng.uniform(0.85, 1.15)),
        base.feet,
        tuple(float(v) for v in rng.uniform(0.0, 1.0, n)),
        tuple(float(v) for v in rng.uniform(0.5, 0.85, n)),
    )


def _spread(times: list[float], iters: list[int]) -> str:
    per_it = 1e3 * sum(times) / max(1, sum(iters))
    return (
        f"median {statistics.median(times):.3f} s (min {min(times):.3f}, max {max(times):.3f}), "
        f"{statistics.median(iters):.0f} it, {per_it:.1f} ms/it"
    )


def _full_cycle(**options: Any) -> PlannerOptions:
    """A path's options on the full NLP (`half_cycle_solve` off, as every path but
    "compiled-half" was measured; the default is on since session 38)."""
    return PlannerOptions(half_cycle_solve=False, **options)


def _compact_planner(forms: tuple[str, ...], robot: robots.Robot, n_knots: int) -> GaitPlanner:
    return GaitPlanner(robot, n_knots, _full_cycle(compact_rows=forms))


#: Solver paths `compare` can run, by name: each builds a planner for (robot, N). The first
#: path named in ``--paths`` is the baseline every other one is compared against. A new solver
#: path (issue #16) adds one entry here.
PATHS: dict[str, Callable[[robots.Robot, int], GaitPlanner]] = {
    "expanded": lambda robot, n: GaitPlanner(robot, n, _full_cycle(derivatives="expanded")),
    "knot": lambda robot, n: GaitPlanner(robot, n, _full_cycle(derivatives="knot")),
    # "knot" before the assembled constraint Jacobian (docs/results/planner_speed_lifted.md)
    "knot-ad": lambda robot, n: GaitPlanner(robot, n, _full_cycle(nlp_jacobian="ad")),
    "compiled": lambda robot, n: GaitPlanner(robot, n, _full_cycle(derivatives="compiled")),
    # the half-cycle solve (`planner.nlp.half_cycle`): symmetric straight schedules on the first
    # N/2 knots; the warm chain's perturbed schedules are not symmetric and take the full NLP
    "compiled-half": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(derivatives="compiled", half_cycle_solve=True)
    ),
    # EXPERIMENTAL: stage-wise FATROP (docs/results/planner_speed_fatrop.md)
    "fatrop": lambda robot, n: _fatrop_planner(robot, n),
    # IPOPT's options and warm start (`planner.nlp.spacetime.ipopt_options`): before and after
    # the tuning of docs/results/planner_speed_ipopt.md ("knot" is the default, i.e. tuned)
    "knot-s21": lambda robot, n: GaitPlanner(
        robot, n, _full_cycle(derivatives="knot", ipopt_tuning="session21")
    ),
    "knot-tuned": lambda robot, n: GaitPlanner(
        robot, n, _full_cycle(derivatives="knot", ipopt_tuning="tuned")
    ),
    # docs/results/planner_speed_threads.md: the knot functions and their derivatives on 2
    # threads (the "knot-w"/"knot-xy" variants measured there are the default since)
    "knot-t2": lambda robot, n: GaitPlanner(robot, n, _full_cycle(knot_threads=2)),
    "compiled-t2": lambda robot, n: GaitPlanner(
        robot, n, _full_cycle(derivatives="compiled", knot_threads=2)
    ),
    # the constraint Jacobian assembled from one J per knot (`planner.nlp.assembled_jacobian`;
    # "knot-aj" is the default "knot" since then, named for the comparisons in that file)
    "knot-aj": lambda robot, n: GaitPlanner(robot, n, _full_cycle(nlp_jacobian="assembled")),
    # the Lagrangian Hessian assembled from one knot H per knot (`planner.nlp.assembled_hessian`)
    # and CasADi's AD Hessian, each named whatever `PlannerOptions`' default is
    "knot-ah": lambda robot, n: GaitPlanner(robot, n, _full_cycle(nlp_hessian="assembled")),
    "knot-adh": lambda robot, n: GaitPlanner(robot, n, _full_cycle(nlp_hessian="ad")),
    # docs/results/planner_speed_init.md: cold starts (`PlannerOptions.cold_start`) and the
    # swing feet's wrench fixed by bounds (`PlannerOptions.swing_wrench`)
    "knot-bal": lambda robot, n: GaitPlanner(robot, n, _full_cycle(cold_start="balanced")),
    "knot-stride": lambda robot, n: GaitPlanner(robot, n, _full_cycle(cold_start="stride")),
    "knot-swr": lambda robot, n: GaitPlanner(robot, n, _full_cycle(swing_wrench="rows")),
    "knot-swb": lambda robot, n: GaitPlanner(robot, n, _full_cycle(swing_wrench="bounds")),
    # the schedule's switched-off equality rows (`PlannerOptions.inactive_rows`,
    # docs/results/planner_speed_ipopt.md, sessions 33-34), each named whatever the default is
    "knot-ir-rows": lambda robot, n: GaitPlanner(robot, n, _full_cycle(inactive_rows="rows")),
    "knot-ir-free-stance": lambda robot, n: GaitPlanner(
        robot, n, _full_cycle(inactive_rows="free stance")
    ),
    "knot-swb-bal": lambda robot, n: GaitPlanner(
        robot, n, _full_cycle(swing_wrench="bounds", cold_start="balanced")
    ),
    "compiled-ah": lambda robot, n: GaitPlanner(
        robot, n, _full_cycle(derivatives="compiled", nlp_hessian="assembled")
    ),
    # inequality rows in a smaller form, the same feasible set (`PlannerOptions.compact_rows`,
    # docs/results/planner_speed_rows.md): every form, none, and each alone
    # docs/results/planner_speed_coldstart.md: the default options (the half-cycle solve where it
    # fits, as `gaitsmith plan` plans) and with the stance feet's clearance rows freed
    # (`PlannerOptions.stance_clearance`)
    "default": lambda robot, n: GaitPlanner(robot, n, PlannerOptions()),
    # docs/results/planner_speed_rows.md, session 43: the servo goals as variables of their own
    # (`PlannerOptions.servo_goal_form`), a smaller MUMPS factor for the same NLP
    "default-lifted-goals": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(servo_goal_form="lifted")
    ),
    "default-sc-free": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(stance_clearance="free")
    ),
    # docs/results/planner_speed_rows.md, session 44 (branch inertia): IPOPT's Hessian shifted on
    # the lifted accelerations (`PlannerOptions.hessian_shift_acc`, the Newton model only)
    "default-hshift2": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(hessian_shift_acc=2e-7)
    ),
    "default-hshift3": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(hessian_shift_acc=3e-7)
    ),
    # docs/results/planner_speed_coldstart.md, session 41: the template path's defaults with the
    # swing feet's wrench fixed by bounds, alone and with the reciprocal μ-oracle centrality
    # ("default-swb" is "default" since session 42; "default-rows" the defaults before it)
    "default-swb": lambda robot, n: GaitPlanner(robot, n, PlannerOptions(swing_wrench="bounds")),
    "default-rows": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(swing_wrench="rows", separation_unit_leg_lengths=None)
    ),
    "default-swb-recip": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(swing_wrench="bounds", cold_mu_centrality="reciprocal")
    ),
    # docs/results/planner_speed_ipopt.md, session 41: warm starts mapped onto the new schedule
    # (`PlannerOptions.warm_retime`), the swing feet's wrench held by bounds in warm solves
    # (`warm_swing_wrench`), warm solves on the half-cycle NLP (`warm_half_cycle`, the default
    # since: "default-warm-half" is "default", "default-warm-full" the warm solves before)
    "default-warm-whole": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_retime="whole")
    ),
    "default-warm-foot": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_retime="per foot")
    ),
    "default-warm-swb": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_swing_wrench="bounds")
    ),
    # session 42 (lead): under the flipped cold default ("bounds"), warm solves by rows
    "default-warm-rows": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_swing_wrench="rows")
    ),
    "default-warm-foot-swb": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_retime="per foot", warm_swing_wrench="bounds")
    ),
    "default-warm-half": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_half_cycle=True)
    ),
    "default-warm-full": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_half_cycle=False)
    ),
    "default-warm-foot-half": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_retime="per foot", warm_half_cycle=True)
    ),
    "default-warm-foot-swb-half": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(warm_retime="per foot", warm_swing_wrench="bounds",
                                 warm_half_cycle=True)
    ),
    # docs/results/planner_speed_ipopt.md, session 43 (benchmarks/tail_screen.py): the defaults
    # with IPOPT's last iterations changed — the y step (``alpha_for_y``), the adaptive μ's
    # affine corrector, a looser stopping test (`PlannerOptions.ipopt_extra`, `tol`)
    "default-afy-pf": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(ipopt_extra=(("alpha_for_y", "primal-and-full"),))
    ),
    "default-corr-affine": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(ipopt_extra=(("corrector_type", "affine"),))
    ),
    "default-pf-affine": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(ipopt_extra=(("alpha_for_y", "primal-and-full"),
                                              ("corrector_type", "affine")))
    ),
    "default-affine-fhp6": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(ipopt_extra=(("corrector_type", "affine"),
                                              ("first_hessian_perturbation", 1e-6)))
    ),
    "default-warm-corr-affine": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(ipopt_extra=(("warm:corrector_type", "affine"),))
    ),
    # session 44 (lead): `spacetime.MIN_REFINEMENT_STEPS` 0 is the default; "default-refine1" is
    # IPOPT's own default (one refinement step on every linear solve), the solves before
    "default-refine1": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(ipopt_extra=(("min_refinement_steps", 1),))
    ),
    # session 45 (lead): `spacetime.FAST_STEP_COMPUTATION` "yes" is the default (no residual
    # check of the linear solves); "default-checkstep" is IPOPT's own "no", the solves before
    "default-checkstep": lambda robot, n: GaitPlanner(
        robot, n, PlannerOptions(ipopt_extra=(("fast_step_computation", "no"),))
    ),
    "default-tol1e-5": lambda robot, n: GaitPlanner(robot, n, PlannerOptions(tol=1e-5)),
    "default-tol1e-4": lambda robot, n: GaitPlanner(robot, n, PlannerOptions(tol=1e-4)),
    "knot-rows": lambda robot, n: GaitPlanner(robot, n, _full_cycle(compact_rows=())),
    "knot-compact": lambda robot, n: GaitPlanner(
        robot, n, _full_cycle(compact_rows=COMPACT_ROWS)
    ),
    **{f"knot-c-{form.replace(' ', '-')}": partial(_compact_planner, (form,))
       for form in COMPACT_ROWS},
}


def _fatrop_planner(robot: robots.Robot, n_knots: int) -> GaitPlanner:
    from planner.nlp.fatrop_solver import FatropPlanner

    return FatropPlanner(robot, n_knots)


def _build_from_cache(
    robot: robots.Robot, n_knots: int, names: list[str], cache: Path
) -> dict[str, GaitPlanner]:
    """Each path built once from the disk cache `cache` (`--cache`: a user's cache, e.g. after
    `gaitsmith cache build ROBOT`): the planners a later command gets, with the compiled knot
    derivatives where the cache holds them. Prints each build time and what the cache gave
    (hit or built; compiled or not)."""
    planners: dict[str, GaitPlanner] = {}
    with cache_folder(cache):
        for name in names:
            t0 = time.process_time()
            planners[name] = with_full_solver(PATHS[name](robot, n_knots))
            cpu = time.process_time() - t0
            status = planners[name].derivative_cache
            got = ("" if status is None else
                   f" ({status.status}, {'compiled' if status.compiled else 'not compiled'})")
            print(f"  build {name}: from {cache} {planners[name].build_time_s:.2f} s "
                  f"(CPU {cpu:.2f} s){got}")
    return planners


def _build_paths(
    robot: robots.Robot, n_knots: int, names: list[str], cache: Path | None = None
) -> dict[str, GaitPlanner]:
    """Each path built twice into a disk cache of its own, the first time empty (cold), the
    second from what the first wrote (cached); prints both build times, wall and process CPU.
    Returns the cached-build planners. With `cache`: `_build_from_cache` instead."""
    if cache is not None:
        return _build_from_cache(robot, n_knots, names, cache)
    planners: dict[str, GaitPlanner] = {}
    with tempfile.TemporaryDirectory(prefix="planner_bench_cache_") as folder:
        for name in names:
            # its own folder: paths sharing the knot's J and H would otherwise find the first
            # path's in the cache and their "empty cache" build would not be cold
            with cache_folder(Path(folder) / name):
                t0 = time.process_time()
                cold = with_full_solver(PATHS[name](robot, n_knots))
                cold_cpu = time.process_time() - t0
                cold_s = cold.build_time_s
                del cold
                t0 = time.process_time()
                planners[name] = with_full_solver(PATHS[name](robot, n_knots))
                cached_cpu = time.process_time() - t0
            status = planners[name].derivative_cache
            print(
                f"  build {name}: empty cache {cold_s:.2f} s (CPU {cold_cpu:.2f} s) | from "
                f"the cache {planners[name].build_time_s:.2f} s (CPU {cached_cpu:.2f} s)"
                + (f" ({status.status})" if status is not None else "")
            )
    return planners


def _cpu_ms_per_it(cpu_s: list[float], iterations: list[int]) -> float:
    return sum(cpu_s) / max(1, sum(iterations)) * 1e3


def compare(
    robot_name: str,
    gait: str,
    speed: float,
    n_knots: int,
    n_random: int,
    n_warm: int,
    seed: int,
    paths: list[str],
    only_templates: list[str] | None = None,
    symmetric: bool = False,
    cache: Path | None = None,
) -> None:
    """Solver paths side by side on the same schedules, in one run (module docstring);
    `only_templates`: these of the robot's templates instead of all; `symmetric`: the warm
    chain's schedules stay half-cycle symmetric (`warm_chain`); `cache`: build from this disk
    cache (`_build_from_cache`) instead of empty temporary ones."""
    robot = robots.load(robot_name)
    print(f"{robot_name} N={n_knots} ({', '.join(paths)}; baseline {paths[0]})")
    planners = _build_paths(robot, n_knots, paths, cache)
    base_name = paths[0]
    rng = np.random.default_rng(seed)
    schedules: list[tuple[str, robots.ContactSchedule]] = []
    unknown = sorted(set(only_templates or ()) - set(templates_for(robot)))
    if unknown:
        raise SystemExit(f"--templates: {robot_name} has no template {', '.join(unknown)}; "
                         f"known: {', '.join(templates_for(robot))}")
    for name in templates_for(robot):
        if only_templates is None or name in only_templates:
            schedules.append((name, make_schedule(robot, name)))
    base = make_schedule(robot, gait)
    schedules += [(f"random{i}", random_schedule(base, rng)) for i in range(n_random)]
    rows: dict[str, tuple[list[float], list[int]]] = {p: ([], []) for p in paths}
    same = {p: 0 for p in paths[1:]}
    lower = {p: 0 for p in paths[1:]}
    worst_rel = {p: 0.0 for p in paths[1:]}
    # a pair in which either solve stopped short of IPOPT's optimality test (the iteration
    # cap): its costs say where the solver stopped, not which optimum it found
    unconverged = {p: 0 for p in paths[1:]}
    # solves whose every iterate matched the baseline's: the same x bit for bit, iterations, cost
    identical = {p: 0 for p in paths[1:]}
    worst_unconverged = {p: 0.0 for p in paths[1:]}
    verdicts = 0
    # process CPU time per solve: moves far less than wall time with a shared machine's load
    cpu: dict[str, list[float]] = {p: [] for p in paths}
    for label, schedule in schedules:
        results: dict[str, PlanResult] = {}
        cpu_s: dict[str, float] = {}
        for path in paths:
            try:
                t0 = time.process_time()
                res = planners[path].solve(schedule, speed, warm_start=False)
                cpu_s[path] = time.process_time() - t0
            except PlannerConfigError:
                break  # e.g. "stand" at a moving speed: not a plan for any path
            results[path] = res
        if len(results) < len(paths):
            continue
        verdicts += 1
        for path, res in results.items():
            rows[path][0].append(res.solve_time_s)
            rows[path][1].append(res.iterations)
            cpu[path].append(cpu_s[path])
        a = results[base_name]
        line = [f"{base_name} {a.cost:.6g} ({a.iterations} it, {a.solve_time_s:.2f} s, CPU "
                f"{cpu_s[base_name]:.2f} s, {'feasible' if a.feasible else a.status})"]
        for path in paths[1:]:
            b = results[path]
            identical[path] += bool(
                a.iterations == b.iterations and a.cost == b.cost
                and np.array_equal(a.warm_start.x, b.warm_start.x)
            )
            if a.feasible != b.feasible:
                line.append(f"{path}: verdict differs ({b.status})")
                continue
            rel = (b.cost - a.cost) / max(abs(a.cost), 1e-12)
            if a.feasible and not (a.optimal and b.optimal):
                unconverged[path] += 1
                worst_unconverged[path] = max(worst_unconverged[path], abs(rel))
            elif a.feasible:
                worst_rel[path] = max(worst_rel[path], abs(rel))
                lower[path] += rel < -SAME_COST_RTOL
                same[path] += rel <= SAME_COST_RTOL
            else:
                same[path] += 1  # both infeasible: the same verdict
            line.append(
                f"{path} {b.cost:.6g} ({b.iterations} it, {b.solve_time_s:.2f} s, CPU "
                f"{cpu_s[path]:.2f} s) rel {rel:+.1e}"
            )
        print(f"  {label}: " + " | ".join(line))
    print(f"  cold solves over {verdicts} schedules:")
    for path in paths:
        cpu_ms = _cpu_ms_per_it(cpu[path], rows[path][1])
        cpu_med = statistics.median(cpu[path] or [float("nan")])
        print(f"    {path}: {_spread(*rows[path])}; process CPU {cpu_ms:.1f} ms/it, "
              f"median {cpu_med:.2f} s")
    for path in paths[1:]:
        if not rows[path][0]:
            continue
        ratio_med = statistics.median(rows[path][0]) / statistics.median(rows[base_name][0])
        ratio_it = (sum(rows[path][0]) / max(1, sum(rows[path][1]))) / (
            sum(rows[base_name][0]) / max(1, sum(rows[base_name][1]))
        )
        cpu_ratio = _cpu_ms_per_it(cpu[path], rows[path][1]) / _cpu_ms_per_it(
            cpu[base_name], rows[base_name][1]
        )
        print(
            f"    {path}/{base_name}: median {ratio_med:.2f}, ms/it {ratio_it:.2f}, CPU ms/it "
            f"{cpu_ratio:.2f}; same optimum "
            f"{same[path]}/{verdicts - unconverged[path]} converged (same verdict and cost "
            f"within {SAME_COST_RTOL:g} relative or lower; {lower[path]} lower), worst |rel| "
            f"{worst_rel[path]:.1e}; {unconverged[path]} stopped short of optimality on either "
            f"path (not compared), their |rel| up to {worst_unconverged[path]:.1e}; "
            f"bit-identical x {identical[path]}/{verdicts}"
        )
    if n_warm:
        warm_chain(robot, planners, paths, base, gait, speed, n_warm, seed, symmetric)


def add_chain_arguments(ap: argparse.ArgumentParser) -> None:
    """The screens' common options (warm_start_screen, sqp_warm_screen): the robot, its gait and
    speed (`chain_defaults` fills them), N and the chain's seed."""
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--gait", default=None, help="default: trot (quad12), tripod (hex18)")
    ap.add_argument("--speed", type=float, default=None)
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)


def chain_defaults(args: argparse.Namespace) -> None:
    """`args.gait` and `args.speed` when not given: trot (tripod on hex18), 0.25 m/s (0.15)."""
    args.gait = args.gait or {"quad12": "trot", "hex18": "tripod"}.get(args.robot, "trot")
    args.speed = args.speed if args.speed is not None else {"hex18": 0.15}.get(args.robot, 0.25)


def symmetric_perturbed(schedule: robots.ContactSchedule, image: tuple[int, ...],
                        rng: np.random.Generator) -> robots.ContactSchedule:
    """`perturbed` drawn per mirror pair (`image`: each foot's mirror image): a foot and its
    image keep one duty factor and touchdowns half a cycle apart, so the schedule stays
    half-cycle symmetric (the half-cycle NLP fits it)."""
    phases, duty = list(schedule.touchdown_phase), list(schedule.duty_factor)
    done: set[int] = set()
    for f, g in enumerate(image):
        if f in done:
            continue
        d = float(np.clip(duty[f] + rng.uniform(-0.03, 0.03), 0.3, 0.95))
        td = float((phases[f] + rng.uniform(-0.03, 0.03)) % 1.0)
        duty[f], phases[f] = d, td
        if g != f:
            duty[g], phases[g] = d, float((td + 0.5) % 1.0)
        done |= {f, g}
    return robots.ContactSchedule(schedule.period_s * float(rng.uniform(0.95, 1.05)),
                                  schedule.feet, tuple(phases), tuple(duty))


def warm_chain(robot: robots.Robot, planners: dict[str, GaitPlanner], paths: list[str],
               base: robots.ContactSchedule, gait: str, speed: float, n_warm: int, seed: int,
               symmetric: bool) -> None:
    """The warm chain: `n_warm` perturbed schedules (`symmetric`: `symmetric_perturbed`), each
    solved from the previous optimum, per path; every solve compared against the cold solve of
    the same schedule by the baseline path (same verdict, cost within `SAME_COST_RTOL` relative
    or lower)."""
    warm_rng = np.random.default_rng(seed + 1)
    image = mirror_permutation(robot) if symmetric else None
    if symmetric and image is None:
        raise SystemExit(f"--symmetric: {robot.name} has no left-right mirror map")
    chain = [perturbed(base, warm_rng) if image is None
             else symmetric_perturbed(base, image, warm_rng) for _ in range(n_warm)]
    base_name = paths[0]
    cold: list[PlanResult] = []
    cold_cpu = []
    for s in chain:
        t0 = time.process_time()
        cold.append(planners[base_name].solve(s, speed, warm_start=False))
        cold_cpu.append(time.process_time() - t0)
    warm: dict[str, tuple[list[float], list[int]]] = {}
    warm_cpu: dict[str, list[float]] = {}
    checks: dict[str, str] = {}
    halves: dict[str, int] = {}
    results: dict[str, list[PlanResult]] = {}
    for path in paths:
        planner = planners[path]
        planner.solve(base, speed, warm_start=False)  # the chain starts from this optimum
        chained, cpu = [], []
        for s in chain:
            t0 = time.process_time()
            chained.append(planner.solve(s, speed))
            cpu.append(time.process_time() - t0)
        warm_cpu[path] = cpu
        results[path] = chained
        warm[path] = ([r.solve_time_s for r in chained], [r.iterations for r in chained])
        halves[path] = sum(bool(r.stats.get("half_cycle")) for r in chained)
        same = lower = 0
        off = []
        for i, (w, c) in enumerate(zip(chained, cold, strict=True)):
            rel = (w.cost - c.cost) / max(abs(c.cost), 1e-12)
            ok = w.feasible == c.feasible and (not c.feasible or rel <= SAME_COST_RTOL)
            same += ok
            lower += bool(ok and c.feasible and rel < -SAME_COST_RTOL)
            if not ok:
                off.append(f"s{i} {rel:+.1e}" if w.feasible == c.feasible else (
                    f"s{i} {'feasible' if w.feasible else 'infeasible'} ({w.status}, worst "
                    f"violation {w.max_violation:.1e}) vs cold "
                    f"{'feasible' if c.feasible else 'infeasible'} ({c.status}, "
                    f"{c.max_violation:.1e}), rel {rel:+.1e}"))
        checks[path] = (f"same optimum as cold {same}/{n_warm} ({lower} lower)"
                        + (f"; off: {', '.join(off)}" if off else ""))
        if path != base_name:  # against the baseline's own warm chain
            rels = [(w.cost - b.cost) / max(abs(b.cost), 1e-12)
                    for w, b in zip(chained, results[base_name], strict=True)
                    if w.feasible and b.feasible]
            verdicts = sum(w.feasible == b.feasible
                           for w, b in zip(chained, results[base_name], strict=True))
            checks[path] += (f"; against {base_name}'s warm solves: same verdict {verdicts}/"
                             f"{n_warm}, cost within {SAME_COST_RTOL:g} "
                             f"{sum(abs(r) <= SAME_COST_RTOL for r in rels)}/{len(rels)}, "
                             f"{sum(r < -SAME_COST_RTOL for r in rels)} lower, "
                             f"{sum(r > SAME_COST_RTOL for r in rels)} higher, worst |rel| "
                             f"{max((abs(r) for r in rels), default=0.0):.1e}")
    cold_its = [c.iterations for c in cold]
    print(f"  warm chain of {n_warm} ({gait}, {'symmetric' if symmetric else 'perturbed'}); "
          f"cold solves of the same schedules ({base_name}): median "
          f"{statistics.median(cold_its):.0f} it, CPU median {statistics.median(cold_cpu):.2f} s "
          f"(total {sum(cold_cpu):.2f} s, {sum(cold_its)} it), "
          f"{sum(bool(c.stats.get('half_cycle')) for c in cold)} half-cycle:")
    for path in paths:
        ratio = statistics.median(warm[path][0]) / statistics.median(warm[base_name][0])
        its = warm[path][1]
        print(f"    {path}: {_spread(*warm[path])}, /{base_name} median {ratio:.2f}; process "
              f"CPU {_cpu_ms_per_it(warm_cpu[path], its):.1f} ms/it, median "
              f"{statistics.median(warm_cpu[path]):.2f} s, total {sum(warm_cpu[path]):.2f} s "
              f"(/cold {sum(warm_cpu[path]) / sum(cold_cpu):.2f}, iterations /cold "
              f"{sum(its) / max(1, sum(cold_its)):.2f}); {halves[path]} half-cycle; "
              f"{checks[path]}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--warm", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--random", type=int, default=5, help="random schedules in `compare`")
    ap.add_argument(
        "--robot", default="both",
        help="both (quad12 trot 0.25 m/s and hex18 tripod 0.15 m/s), quad12, hex18, or another "
        "robot (name or folder) for `compare`, at its default gait and --speed",
    )
    ap.add_argument("--speed", type=float, default=0.15,
                    help="`compare` with another --robot: the speed [m/s]")
    ap.add_argument(
        "--section", choices=("all", "build", "solve", "compare"), default="all"
    )
    ap.add_argument(
        "--paths",
        default="expanded,knot",
        help=f"solver paths for `compare`, baseline first; known: {', '.join(PATHS)}",
    )
    ap.add_argument(
        "--templates", default=None, help="`compare`: only these templates (comma-separated)"
    )
    ap.add_argument("--symmetric", action="store_true",
                    help="`compare`: a warm chain of half-cycle symmetric perturbations")
    ap.add_argument(
        "--cache", type=Path, default=None,
        help="`compare`: build every path from this disk cache (e.g. ~/.cache/gaitsmith after "
        "`gaitsmith cache build ROBOT`: the compiled knot derivatives a user's later commands "
        "get) instead of empty temporary ones (the uncompiled path, and the build times cold "
        "and cached)")
    args = ap.parse_args()
    if args.cache is not None and not args.cache.is_dir():
        ap.error(f"--cache {args.cache}: not a folder (a GAITSMITH_CACHE, e.g. ~/.cache/gaitsmith)")
    only = None if args.templates is None else [t.strip() for t in args.templates.split(",")]
    paths = [p.strip() for p in args.paths.split(",") if p.strip()]
    unknown = [p for p in paths if p not in PATHS]
    if unknown or len(paths) < 2:
        ap.error(f"--paths {args.paths!r}: name two or more of {', '.join(PATHS)}")
    if args.section in ("all", "build"):
        build_bench("quad12", args.knots)
        build_bench("hex18", args.knots)
    if args.section in ("all", "solve"):
        bench("quad12", "trot", 0.25, args.knots, args.warm, args.seed)
        bench("hex18", "tripod", 0.15, args.knots, args.warm, args.seed)
    if args.section in ("all", "compare"):
        if args.robot in ("both", "quad12"):
            compare("quad12", "trot", 0.25, args.knots, args.random, args.warm, args.seed, paths,
                    only, args.symmetric, args.cache)
        if args.robot in ("both", "hex18"):
            compare("hex18", "tripod", 0.15, args.knots, args.random, args.warm, args.seed, paths,
                    only, args.symmetric, args.cache)
        if args.robot not in ("both", "quad12", "hex18"):
            try:
                gait = default_gait_for(robots.load(args.robot))
            except robots.RobotsError as exc:
                ap.error(f"--robot {args.robot!r}: {exc}")
            compare(args.robot, gait, args.speed, args.knots, args.random, args.warm, args.seed,
                    paths, only, args.symmetric, args.cache)


if __name__ == "__main__":
    main()

"""Gait-search benchmark: one full basin-CMA search at one speed, per derivative path and executor.

    python benchmarks/gait_search_bench.py [--robot quad12] [--speed 0.25] [--generations 6]
                                           [--workers 2] [--sim-accept]
                                           [--derivatives knot] [--executors serial,process]

Targets: issue 5, a full search in ≤ 60 s on 2 cores; issue 16, the README's
`gaitsmith plan quad12 --speed 0.25 --search` (MuJoCo acceptance on) in ≤ 15 s. "Full" is what
`gaitsmith plan ROBOT --speed V --search` runs by default: template seeds, 6 basin-CMA
generations of the coarse (12-knot) NLP, then the final 30-knot solve of the best timings;
`--sim-accept` adds the MuJoCo acceptance check of every feasible sample and of the final gait
(the command line's default, with the command line's own acceptance settings).

`--warm-starts cold,nearest-retimed` runs each path with those search warm starts
(`planner.search.gait_search.SEARCH_WARM_STARTS`; labelled ``knot+nearest-retimed`` etc.;
measured in docs/results/planner_speed_search.md, session 30).
`--swing-wrenches rows,bounds` and `--cold-starts stance,balanced` run each path with those
`PlannerOptions.swing_wrench` / `cold_start` values in every NLP of the search
(docs/results/planner_speed_init.md); "coarse-bounds" is "bounds" in the coarse solves only,
"rows" elsewhere (`search_gait(search_swing_wrench=...)`, planner_speed_search.md session 32);
"default" (the default) the search's own (`SEARCH_SWING_WRENCH`, `FINAL_SWING_WRENCH`, session 40).
`--compact-rows "none,torque envelope"` runs each path with `PlannerOptions.compact_rows` = ()
(the torque envelope's four faces, the form before session 31) and then ("torque envelope",)
(its two ranged rows, today's default); "+" joins several row names into one value
(docs/results/planner_speed_rows.md, session 32).
`--coarse-aborts off,30/0.03` runs each path without and with the stall abort of the coarse
solves (`planner.nlp.iteration_abort.StallAbort(after_iter=30, min_violation=0.03)`; labelled
``knot+abort30/0.03``), alternating, so their CPU ratio is measured under the same load.

Every combination of `--derivatives` (`PlannerOptions.derivatives`: "expanded" = the whole NLP
expanded to SX, "knot" = per-knot derivatives, today's default) and `--executors` runs in this
one process, one after the other, so their ratios are measured under the same load. Per run it
prints wall time (process pool start-up and every NLP build included), local solves, IPOPT
iterations, samples accepted / rejected by MuJoCo / infeasible, the winner and its final
verdict, and where the time went: the phases of the search in wall time, and the workers' NLP
builds, solves and acceptance checks summed over workers (seconds of worker time); and the CPU
time of the whole search, this process plus its worker processes (`getrusage`), which a shared
machine's load moves far less than wall time.
"""

from __future__ import annotations

import argparse
import os
import resource
import time
from dataclasses import dataclass, replace
from itertools import product
from typing import Any, get_args

os.environ.setdefault("OMP_NUM_THREADS", "1")
# a "knot" build on an empty cache would start compiling the robot's J and H in the background
# (planner.nlp.background_compile), on the cores being measured; set it to 1 to measure that
os.environ.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")

import robots
from gaitsmith.plan_cmd import DEFAULT_CYCLES, servo_limited_search_seed
from gaitsmith.plan_options import DEFAULT_MU, planner_options, search_planner_options
from gaitsmith.plan_search import USER_SEED
from gaitsmith.search_options import sim_acceptance
from gaitsmith.stance_options import stance_shaped
from planner.nlp.config import (
    COLD_STARTS,
    COMPACT_ROWS,
    DEFAULT_COMPACT_ROWS,
    DEFAULT_SERVO_GOAL_FORM,
    DEFAULT_SWING_WRENCH,
    DERIVATIVE_PATHS,
    SERVO_GOAL_FORMS,
    SWING_WRENCHES,
    PlannerOptions,
)
from planner.nlp.iteration_abort import StallAbort
from planner.search.defaults import (
    DEFAULT_FINAL_TEMPLATES,
    FINAL_HALF_CYCLE,
    FINAL_RETRY_ALL,
    FINAL_RETRY_FULL,
    FINAL_RETRY_NARROW,
    FINAL_RETRY_OFF,
    FINAL_SWING_WRENCH,
    SEARCH_HALF_CYCLE,
    SEARCH_SWING_WRENCH,
)
from planner.search.executors import ExecutorKind
from planner.search.gait_search import (
    ABORTED_STATUS,
    DEFAULT_SEARCH_KNOTS,
    DEFAULT_SEARCH_MAX_ITER,
    SEARCH_WARM_STARTS,
    GaitSearchResult,
    search_gait,
)

#: `--swing-wrenches` value: "bounds" in the coarse solves, "rows" in the final re-solves
COARSE_BOUNDS = "coarse-bounds"
#: `--swing-wrenches` value: the search's defaults (`SEARCH_SWING_WRENCH` in the coarse solves,
#: `FINAL_SWING_WRENCH` in the candidates' final re-solves, the options' default
#: `DEFAULT_SWING_WRENCH` in the templates')
DEFAULT_WRENCHES = "default"


@dataclass(frozen=True)
class SearchRun:
    """One search, measured."""

    derivatives: str
    executor: str
    wall_s: float
    result: GaitSearchResult
    #: CPU seconds of this process and of the worker processes that ended during the search
    cpu_s: float = 0.0
    worker_cpu_s: float = 0.0

    @property
    def solves(self) -> int:
        return len(self.result.samples)

    @property
    def iterations(self) -> int:
        """IPOPT iterations of the search's local solves (n_fevals = iterations + 1)."""
        return sum(max(r.n_fevals - 1, 0) for _, r in self.result.samples)

    def count(self, what: str) -> int:
        """Samples "accepted" (feasible and passed acceptance), "rejected" (feasible plan,
        failed acceptance) or "infeasible"."""
        n = 0
        for _, r in self.result.samples:
            plan_ok = bool(getattr(r, "plan_feasible", r.feasible))
            n += {"accepted": r.feasible, "rejected": plan_ok and not r.feasible,
                  "infeasible": not plan_ok}[what]
        return n

    def stopped(self) -> int:
        """Samples stopped by the coarse solves' stall abort."""
        return sum(getattr(r, "status", "") == ABORTED_STATUS for _, r in self.result.samples)

    def worker_s(self, field: str) -> float:
        """`build_s`, `solve_s` or `accept_s` summed over every local solve (worker seconds)."""
        return sum(float(getattr(r, field, 0.0)) for _, r in self.result.samples)

    def verdict(self) -> str:
        accepted = self.result.accepted
        if not self.result.best.feasible:
            return "infeasible"
        return {True: "MuJoCo pass", False: "MuJoCo FAIL", None: "not simulated"}[accepted]


def _children_cpu_s() -> float:
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def cli_search_options(robot: robots.Robot, derivatives: str = "knot",
                       swing_wrench: str = DEFAULT_SWING_WRENCH,
                       cold_start: str = "stance",
                       compact_rows: tuple[str, ...] = DEFAULT_COMPACT_ROWS,
                       sim_accept: bool = True, speed_m_s: float | None = None
                       ) -> tuple[PlannerOptions, dict[str, Any]]:
    """The planner options and the other `search_gait` keywords (MuJoCo checks, the
    servo-limited seed) `gaitsmith plan ROBOT --speed SPEED --search` uses with no flags
    (`cli_search_kwargs`), with these benchmark options."""
    cli = cli_search_kwargs(robot, derivatives, sim_accept, speed_m_s)
    options = replace(cli.pop("options"), swing_wrench=swing_wrench, cold_start=cold_start,
                      compact_rows=compact_rows)
    return options, cli


def run(robot_name: str, speed: float, generations: int, workers: int, seed: int,
        sim_accept: bool, derivatives: str, executor: str, knots: int,
        warm_start: str = "cold", abort: str = "off", swing_wrench: str = DEFAULT_SWING_WRENCH,
        cold_start: str = "stance",
        compact_rows: tuple[str, ...] = DEFAULT_COMPACT_ROWS,
        search_swing_wrench: str | None = SEARCH_SWING_WRENCH,
        search_max_iter: int = DEFAULT_SEARCH_MAX_ITER,
        search_tol: float | None = None,
        search_knots: int = DEFAULT_SEARCH_KNOTS,
        coarse_speed_tol: float | None = None,
        search_half_cycle: bool = SEARCH_HALF_CYCLE,
        final_half_cycle: bool = FINAL_HALF_CYCLE,
        final_templates: str = DEFAULT_FINAL_TEMPLATES,
        final_retry_full: str = FINAL_RETRY_FULL,
        final_swing_wrench: str | None = FINAL_SWING_WRENCH,
        option_fields: tuple[tuple[str, Any], ...] = ()) -> SearchRun:
    """One `search_gait` as `gaitsmith plan ROBOT --speed V --search` runs it (cold: every
    NLP, the final one included, is built inside the timed call). `swing_wrench` is every
    NLP's (the options'); `search_swing_wrench` (None: `swing_wrench`), `search_max_iter`,
    `search_tol` (not None) and `search_knots` the coarse solves' only; `final_swing_wrench`
    (None: `swing_wrench`) the candidates' final re-solves' only (`search_gait(
    final_swing_wrench=)`, the templates keep `swing_wrench`); `coarse_speed_tol` (not None)
    the coarse MuJoCo check's `PassCriteria.speed_rel_tol` (the final check keeps the default);
    `search_half_cycle` the coarse solves' `PlannerOptions.half_cycle_solve`,
    `final_half_cycle` the final re-solves' (`search_gait(final_half_cycle=)`), with
    `final_retry_full` which failed half-cycle candidates are re-solved full (`search_gait(
    final_retry_full=)`: "all", "narrow", "off");
    `final_templates` whether the templates compete with the searched winner
    (`search_gait(final_templates=...)`); `option_fields` further `PlannerOptions` fields
    (name, value) of every NLP, set on the command line's options."""
    robot = robots.load(robot_name)
    options, acceptance = cli_search_options(robot, derivatives, swing_wrench, cold_start,
                                             compact_rows, sim_accept, speed)
    options = replace(options, **dict(option_fields))
    if coarse_speed_tol is not None and "acceptance" in acceptance:
        coarse = acceptance["acceptance"]
        acceptance["acceptance"] = replace(
            coarse, criteria=replace(coarse.criteria, speed_rel_tol=coarse_speed_tol))
    t0, c0, w0 = time.perf_counter(), time.process_time(), _children_cpu_s()
    result = search_gait(
        robot, speed, n_knots=knots, options=options,
        max_generations=generations, seed=seed, executor=executor, workers=workers,
        warm_start=warm_start, coarse_abort=_abort_rule(abort),
        search_swing_wrench=search_swing_wrench, search_max_iter=search_max_iter,
        search_tol=search_tol, search_knots=search_knots,
        search_half_cycle=search_half_cycle, final_half_cycle=final_half_cycle,
        final_templates=final_templates, final_retry_full=final_retry_full,
        final_swing_wrench=final_swing_wrench, **acceptance,
    )
    wall, cpu, wcpu = time.perf_counter() - t0, time.process_time() - c0, _children_cpu_s() - w0
    label = derivatives if warm_start == "cold" else f"{derivatives}+{warm_start}"
    label += "" if abort == "off" else f"+abort{abort}"
    label += "" if swing_wrench == DEFAULT_SWING_WRENCH else f"+swing-{swing_wrench}"
    label += "" if search_swing_wrench == SEARCH_SWING_WRENCH else \
        f"+coarse-{search_swing_wrench or swing_wrench}"
    label += "" if final_swing_wrench == FINAL_SWING_WRENCH else \
        f"+final-{final_swing_wrench or swing_wrench}"
    label += "" if cold_start == "stance" else f"+{cold_start}"
    label += "" if compact_rows == DEFAULT_COMPACT_ROWS else f"+rows-{_rows_label(compact_rows)}"
    label += "" if search_max_iter == DEFAULT_SEARCH_MAX_ITER else f"+cap{search_max_iter}"
    label += "" if search_tol is None else f"+tol{search_tol:g}"
    label += "" if search_knots == DEFAULT_SEARCH_KNOTS else f"+knots{search_knots}"
    label += "" if coarse_speed_tol is None else f"+speed{coarse_speed_tol:g}"
    label += "" if search_half_cycle == SEARCH_HALF_CYCLE else (
        "+half" if search_half_cycle else "+full")
    label += "" if (final_half_cycle, final_retry_full) == (FINAL_HALF_CYCLE, FINAL_RETRY_FULL) \
        else final_solve_token(final_half_cycle, final_retry_full)
    label += "" if final_templates == DEFAULT_FINAL_TEMPLATES else f"+{final_templates}"
    label += "".join(f"+{name}={value}" for name, value in option_fields)
    return SearchRun(label, executor, wall, result, cpu, wcpu)


#: the final re-solve policies' tokens: (final_half_cycle, final_retry_full) of each
#: (`search_gait(final_half_cycle=, final_retry_full=)`): the full NLP; half the knots where a
#: timing is symmetric; half, every failed candidate re-solved full; half, a candidate that
#: fails the final check narrowly re-solved full (`defaults.FINAL_RETRY_MARGIN`)
FINAL_SOLVE_TOKENS: dict[str, tuple[bool, str]] = {
    "fullfinal": (False, FINAL_RETRY_FULL), "halffinal": (True, FINAL_RETRY_OFF),
    "halfretry": (True, FINAL_RETRY_ALL), "halfnarrow": (True, FINAL_RETRY_NARROW)}


def final_solve_token(half_cycle: bool, retry_full: str) -> str:
    """The label of a final re-solve policy ("+" and its `FINAL_SOLVE_TOKENS` key)."""
    if not half_cycle:
        return "+fullfinal"
    return "+" + next(k for k, (h, r) in FINAL_SOLVE_TOKENS.items() if h and r == retry_full)


def swing_wrenches(value: str) -> tuple[str | None, str | None]:
    """`run`'s (search_swing_wrench, final_swing_wrench) for a `--swing-wrenches` value: the
    search's defaults, the options' own in every NLP ("rows", "bounds": None), or "bounds" in
    the coarse solves with "rows" elsewhere."""
    if value == DEFAULT_WRENCHES:
        return SEARCH_SWING_WRENCH, FINAL_SWING_WRENCH
    return ("bounds", None) if value == COARSE_BOUNDS else (None, None)


def cli_search_kwargs(robot: robots.Robot, derivatives: str, sim_accept: bool,
                      speed_m_s: float | None = None) -> dict[str, Any]:
    """`options` and the MuJoCo checks (`acceptance`, `final_acceptance`; none without
    `sim_accept`) that `gaitsmith plan ROBOT --speed SPEED --search --solver DERIVATIVES` gives
    `search_gait` with no other flag, built by the command line's own functions (the
    stance-compliance rule, `planner_options`, `servo_limited_search_seed`,
    `search_planner_options`, `sim_acceptance`), so the two cannot drift apart
    (tests/benchmarks/test_gait_search_bench.py compares them). With `speed_m_s`, a body whose
    template swings faster than its servos (knee8) gets the servo-limited timing's options and
    its timing as `seed_schedules`, as the command gives it."""
    shaped = stance_shaped(robot, None, None, None, None)
    options = planner_options(DEFAULT_MU, derivatives, shaped, None, None)
    seed = None
    if speed_m_s is not None:
        options, seed = servo_limited_search_seed(robot, speed_m_s, options)
    return {"options": search_planner_options(options),
            **({} if seed is None else {"seed_schedules": {USER_SEED: seed}}),
            **sim_acceptance(robot, sim_accept, DEFAULT_CYCLES, shaped.entry or 1)}


def _abort_rule(text: str) -> StallAbort | None:
    """"off" or "K/V": `StallAbort(after_iter=K, min_violation=V)`."""
    if text == "off":
        return None
    try:
        after, violation = text.split("/")
        return StallAbort(after_iter=int(after), min_violation=float(violation))
    except ValueError as e:
        raise SystemExit(f"--coarse-aborts: expected off or K/V (e.g. 30/0.03), got {text!r}"
                         ) from e


def _rows_label(rows: tuple[str, ...]) -> str:
    """`compact_rows` as `--compact-rows` spells it: "none" or names joined by "+"."""
    return "+".join(rows) if rows else "none"


def compact_rows_values(text: str) -> list[tuple[str, ...]]:
    """`--compact-rows`: comma-separated `PlannerOptions.compact_rows` values, each "none" (the
    empty tuple) or row names of `COMPACT_ROWS` joined by "+"; duplicates are refused."""
    values: list[tuple[str, ...]] = []
    for item in (v.strip() for v in text.split(",")):
        rows = () if item == "none" else tuple(n.strip() for n in item.split("+"))
        if not item or any(n not in COMPACT_ROWS for n in rows) or len(set(rows)) < len(rows):
            raise SystemExit(
                f"--compact-rows: expected comma-separated values, each none or names joined by "
                f"+ from {', '.join(COMPACT_ROWS)} (e.g. \"none,torque envelope\"), got {text!r}")
        values.append(rows)
    return values


def report(r: SearchRun, target_s: float) -> str:
    res = r.result
    ph = res.phase_s
    final = "; ".join(
        f"{plan.iterations} it {plan.solve_time_s:.1f} s"
        + ("" if ok is None else f" + check {check_s:.1f} s {'pass' if ok else 'FAIL'}")
        for plan, check_s, ok in res.final_solves)
    return "\n".join([
        f"  {r.derivatives:8s} {r.executor:8s} {r.wall_s:7.1f} s  {r.solves:4d} solves  "
        f"{r.iterations:5d} iterations  {r.solves / r.wall_s:5.2f} solves/s  "
        f"{'OK' if r.wall_s <= target_s else 'over'} the {target_s:g} s target",
        f"           CPU {r.cpu_s + r.worker_cpu_s:.1f} s (this process {r.cpu_s:.1f} s, workers "
        f"{r.worker_cpu_s:.1f} s); {res.cma.n_generations} generations "
        f"({res.cma.stop_reason})",
        f"           samples: {r.count('accepted')} accepted, {r.count('rejected')} rejected in "
        f"MuJoCo, {r.count('infeasible')} infeasible ({r.stopped()} stopped by the abort); "
        f"winner {res.label} (search cost "
        f"{res.search_cost:.5g}, best template {res.best_template} {res.best_template_cost:.5g}), "
        f"final cost {res.best.cost:.6g}, period {res.best.schedule.period_s:.3f} s, "
        f"{r.verdict()}",
        f"           wall: final NLP build {ph['final_build']:.1f} s, seeding (pool, worker "
        f"builds, templates) {ph['seed']:.1f} s, basin-CMA {ph['cma']:.1f} s, final re-solves "
        f"{ph['final']:.1f} s [{final}]",
        f"           worker time: builds {r.worker_s('build_s'):.1f} s, solves "
        f"{r.worker_s('solve_s'):.1f} s, MuJoCo acceptance {r.worker_s('accept_s'):.1f} s",
    ])


def _choices(text: str, allowed: tuple[str, ...], option: str) -> list[str]:
    values = [v.strip() for v in text.split(",") if v.strip()]
    bad = [v for v in values if v not in allowed]
    if bad or not values:
        raise SystemExit(f"{option}: expected a comma-separated subset of {', '.join(allowed)}, "
                         f"got {text!r}")
    return values


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--knots", type=int, default=30, help="knots of the final gait")
    ap.add_argument("--generations", type=int, default=6)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sim-accept", action="store_true", help="MuJoCo acceptance of samples")
    ap.add_argument("--derivatives", default="knot",
                    help=f"comma-separated derivative paths, first = baseline "
                         f"({', '.join(DERIVATIVE_PATHS)})")
    ap.add_argument("--executors", default="serial,process",
                    help=f"comma-separated executors ({', '.join(get_args(ExecutorKind))})")
    ap.add_argument("--warm-starts", default="cold",
                    help=f"comma-separated search warm starts, run after each derivative path "
                         f"({', '.join(SEARCH_WARM_STARTS)})")
    ap.add_argument("--coarse-aborts", default="off",
                    help="comma-separated: off | K/V (stall abort of the coarse solves from "
                         "iteration K above violation V), run alternately per path")
    ap.add_argument("--swing-wrenches", default=DEFAULT_WRENCHES,
                    help=f"comma-separated, run alternately per path: {DEFAULT_WRENCHES} (the "
                         f"search's: {SEARCH_SWING_WRENCH} in the coarse solves, "
                         f"{FINAL_SWING_WRENCH} in the final re-solves, rows in the templates'), "
                         f"{', '.join(SWING_WRENCHES)} (`PlannerOptions.swing_wrench` of every "
                         f"NLP) or {COARSE_BOUNDS} (bounds in the coarse solves only)")
    ap.add_argument("--cold-starts", default="stance",
                    help=f"comma-separated `PlannerOptions.cold_start` values, run alternately "
                         f"per path ({', '.join(COLD_STARTS)})")
    ap.add_argument("--compact-rows", default=_rows_label(DEFAULT_COMPACT_ROWS),
                    help=f"comma-separated `PlannerOptions.compact_rows` values, run alternately "
                         f"per path: none or names joined by + ({', '.join(COMPACT_ROWS)})")
    ap.add_argument("--target", type=float, default=60.0, help="target wall time [s]")
    ap.add_argument("--servo-goal-forms", default=DEFAULT_SERVO_GOAL_FORM,
                    help=f"comma-separated `PlannerOptions.servo_goal_form` values, each a "
                         f"search of its own ({', '.join(SERVO_GOAL_FORMS)})")
    args = ap.parse_args()
    goal_forms = _choices(args.servo_goal_forms, SERVO_GOAL_FORMS, "--servo-goal-forms")
    paths = _choices(args.derivatives, tuple(DERIVATIVE_PATHS), "--derivatives")
    executors = _choices(args.executors, get_args(ExecutorKind), "--executors")
    warm_starts = _choices(args.warm_starts, SEARCH_WARM_STARTS, "--warm-starts")
    wrenches = _choices(args.swing_wrenches, (DEFAULT_WRENCHES, *SWING_WRENCHES, COARSE_BOUNDS),
                        "--swing-wrenches")
    colds = _choices(args.cold_starts, COLD_STARTS, "--cold-starts")
    row_forms = compact_rows_values(args.compact_rows)
    aborts = [a.strip() for a in args.coarse_aborts.split(",") if a.strip()] or ["off"]
    for a in aborts:
        _abort_rule(a)  # validate before any search runs
    print(
        f"{args.robot} gait search at {args.speed} m/s, {args.generations} generations, "
        f"final N={args.knots}, sim acceptance {'on' if args.sim_accept else 'off'}, "
        f"{args.workers} workers, load average {os.getloadavg()[0]:.2f}, "
        f"{time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC", flush=True
    )
    runs: list[SearchRun] = []
    for derivatives, warm_start, abort, wrench, cold, rows, form, executor in product(
            paths, warm_starts, aborts, wrenches, colds, row_forms, goal_forms, executors):
        coarse, final = swing_wrenches(wrench)
        r = run(args.robot, args.speed, args.generations, args.workers,
                args.seed, args.sim_accept, derivatives, executor,
                args.knots, warm_start, abort,
                wrench if wrench in SWING_WRENCHES else
                "rows" if wrench == COARSE_BOUNDS else
                DEFAULT_SWING_WRENCH, cold,
                rows, coarse, final_swing_wrench=final,
                option_fields=(("servo_goal_form", form),))
        runs.append(r)
        print(report(r, args.target), flush=True)
    for executor in executors:
        same = [r for r in runs if r.executor == executor]
        for r in same[1:]:
            base = same[0]
            rel = (r.result.best.cost - base.result.best.cost) / abs(base.result.best.cost)
            cpu = (r.cpu_s + r.worker_cpu_s) / (base.cpu_s + base.worker_cpu_s)
            print(f"  {executor}: {r.derivatives}/{base.derivatives} wall "
                  f"{r.wall_s / base.wall_s:.2f}, CPU {cpu:.2f}, solves {r.solves}/{base.solves}, "
                  f"iterations {r.iterations}/{base.iterations}, winner "
                  f"{r.result.label}/{base.result.label}, final cost rel {rel:+.1e}")
    for derivatives in dict.fromkeys(r.derivatives for r in runs):
        by = {r.executor: r for r in runs if r.derivatives == derivatives}
        if "serial" in by and "process" in by:
            print(f"  {derivatives}: process-pool speed-up over serial "
                  f"{by['serial'].wall_s / by['process'].wall_s:.2f}x ({args.workers} workers)")
    print(f"  load average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

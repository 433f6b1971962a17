"""Is the half-cycle solve's MuJoCo verdict a knife edge of its own, or of the check?

    python benchmarks/half_cycle_verdicts.py run --cases quad12@0.25,tests/zoo/bittle8@0.13:walk \\
        [--knots 30] [--sigma 1e-6] [--seeds 1,2] [--out ROWS.jsonl]
    python benchmarks/half_cycle_verdicts.py run \\
        --cases biped@0.5:biped_run/duty0.42/knots12/cycles30
    python benchmarks/half_cycle_verdicts.py table ROWS.jsonl

`run`: for each case (robot, template or custom schedule, speed) plans the gait as
`gaitsmith plan ROBOT --gait G --speed V --knots N --simulate` does with no other flags
(`gaitsmith.stance_options.stance_shaped`, `gaitsmith.plan_options.planner_options` and
`gait_metadata`, `planner.user_schedule.command_schedule`, `GaitPlanner.to_gait`, the attitude
gain `gaitsmith.attitude_options.resolved_gain` resolves, `sim.validate.validate` over
`gaitsmith.plan_output.simulated_cycles`) and judges it in MuJoCo, four ways:

- ``full``: today's path (a cold start, all N knots);
- ``half``: `PlannerOptions.half_cycle_solve` (`planner.nlp.half_cycle`; a schedule that is not
  half-cycle mirror symmetric is solved in full there, so the row says ``half = full`` and the
  half run is skipped);
- ``full~k`` (one per `--seeds` entry): the full NLP from the same cold start x0 moved by
  δᵢ = σ·max(1, |x0ᵢ|)·ξᵢ, ξ ~ N(0, 1) from `numpy.random.default_rng(k)` (σ = `--sigma`,
  default 1e-6: IPOPT's own convention for its bound push, relative to max(1, |x|)). The NLP is
  unchanged: the start is handed to `GaitPlanner.solve` as a `WarmStart` with zero multipliers
  (what a cold solve passes) on a planner whose `ipopt_tuning` is "session21", under which a warm
  solve's IPOPT options are the cold ones (`planner.nlp.spacetime.ipopt_options`; "tuned", the
  default, would push a warm start 1e-3 inside its bounds with μ₀ 1e-3 — another algorithm, not
  a tiny perturbation). With σ = 0 this reproduces ``full`` bit for bit (the harness's test).

A perturbed run counts only if it reached the same optimum: feasible and its cost within
`SAME_COST_REL` (1e-4) relative of ``full``'s. Each row records per run: cost, iterations, the
distance from ``full``'s point max |xᵢ − x_fullᵢ| / max(1, |x_fullᵢ|) and the largest planned joint
angle difference, the verdict with its failed checks, and every check's value, limit and
normalised margin (limit − value)/limit (> 0: within the limit; `check_margins`). One JSON line
per case is appended to `--out` (a case already there is skipped, so an interrupted run resumes).

`table`: every row, then the counts: verdict flips full vs half (rows where the reduced NLP was
used) and full vs full~k (the perturbed runs that count), and the spread of the tightest
margins. Measured in docs/results/half_cycle_verdicts.md, session 37.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import re
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from gaitsmith.attitude_options import attitude_settings, resolved_gain
from gaitsmith.plan_options import DEFAULT_MU, gait_metadata, planner_options
from gaitsmith.plan_output import simulated_cycles
from gaitsmith.stance_options import stance_shaped
from planner.errors import PlannerConfigError
from planner.nlp.cold_start import StartCommand
from planner.nlp.command import VelocityCommand
from planner.nlp.config import PlannerOptions
from planner.nlp.mirror import schedule_symmetric
from planner.nlp.spacetime import GaitPlanner, PlanResult, WarmStart, parameter_vector
from planner.templates import mirror_permutation, templates_for
from planner.user_schedule import command_schedule
from robots.errors import RobotsError
from sim.validate import ValidationResult, slip_limit_m, validate

#: a perturbed run reached ``full``'s optimum when its cost is within this (relative)
SAME_COST_REL = 1e-4
DEFAULT_SIGMA = 1e-6
DEFAULT_SEEDS = (1, 2)
#: `PlannerOptions.ipopt_tuning` under which a warm solve uses the cold solve's IPOPT options
SAME_OPTIONS_TUNING = "session21"
_CASE = re.compile(r"^(?P<robot>[^@]+)@(?P<speed>[^:]+)(?::(?P<rest>.+))?$")


@dataclasses.dataclass(frozen=True)
class Case:
    """One planned command: `gait` a template (or "custom" with `phases`), `duty`/`period_s` as
    `gaitsmith plan --duty/--period`, `cycles` as `--cycles` (None: the command's default)."""

    robot: str
    gait: str
    speed_m_s: float
    knots: int
    duty: str | None = None
    phases: str | None = None
    period_s: float | None = None
    cycles: int | None = None

    @property
    def key(self) -> str:
        extra = "".join(f"/{k}{v}" for k, v in (("duty", self.duty), ("phases", self.phases),
                                                 ("period", self.period_s),
                                                 ("cycles", self.cycles)) if v is not None)
        return f"{self.robot}@{self.speed_m_s:g}:{self.gait}/knots{self.knots}{extra}"


def parse_cases(text: str, knots: int) -> list[Case]:
    """"ROBOT@SPEED[:GAIT[/dutyD][/phasesP][/periodT][/knotsN][/cyclesC]]", comma-separated;
    no GAIT: every template of the robot but the stand (a moving command cannot stand).
    Phases are written with ';' between feet (``phases0;0.5``) since ',' separates cases."""
    out: list[Case] = []
    for token in (t.strip() for t in text.split(",") if t.strip()):
        m = _CASE.match(token)
        if m is None:
            raise SystemExit(f"--cases: {token!r} is not ROBOT@SPEED[:GAIT[/dutyD]...], e.g. "
                             "quad12@0.25:trot")
        try:
            speed = float(m["speed"])
        except ValueError:
            raise SystemExit(f"--cases: {token!r}: speed {m['speed']!r} is not a number") from None
        if not math.isfinite(speed) or speed <= 0.0:
            raise SystemExit(f"--cases: {token!r}: the speed must be > 0 m/s")
        try:
            bot = robots.load(m["robot"])
        except RobotsError as exc:
            raise SystemExit(f"--cases: {token!r}: cannot load robot {m['robot']!r}: {exc}"
                             ) from None
        if m["rest"] is None:
            out += [Case(m["robot"], g, speed, knots) for g in templates_for(bot) if g != "stand"]
            continue
        gait, *mods = m["rest"].split("/")
        fields: dict[str, Any] = {"knots": knots}
        for mod in mods:
            name = next((n for n in ("duty", "phases", "period", "knots", "cycles")
                         if mod.startswith(n)), None)
            if name is None:
                raise SystemExit(f"--cases: {token!r}: unknown modifier {mod!r} (duty, phases, "
                                 "period, knots, cycles)")
            value = mod[len(name):]
            try:
                if name in ("knots", "cycles"):
                    fields[name] = int(value)
                elif name == "period":
                    fields["period_s"] = float(value)
                else:
                    fields[name] = value.replace(";", ",")
            except ValueError:
                raise SystemExit(f"--cases: {token!r}: {name} {value!r} is not a number"
                                 ) from None
        if gait != "custom" and gait not in templates_for(bot):
            raise SystemExit(f"--cases: {token!r}: {m['robot']} has no template {gait}; known: "
                             f"{', '.join(templates_for(bot))} (or custom with phases)")
        if fields["knots"] % 2 or fields["knots"] < 8:
            raise SystemExit(f"--cases: {token!r}: knots must be even and ≥ 8")
        out.append(Case(m["robot"], gait, speed, **fields))
    return out


def check_margins(v: ValidationResult, leg_length_m: float) -> dict[str, dict[str, float]]:
    """Every magnitude check `sim.validate.judge` makes on a straight command: its value, its
    limit and the normalised margin (limit − value)/limit (> 0: within it). The fall check has
    no magnitude: its margin is +1 (stayed up) or −1 (fell). "ok" is the judge's own verdict on
    the check (margin ≥ 0 exactly when it holds)."""
    m, c = v.metrics, v.criteria
    tol = max(c.speed_rel_tol * m.commanded_speed_m_s, c.speed_abs_tol_m_s)
    pairs: dict[str, tuple[float | None, float]] = {
        "speed": (abs(m.achieved_speed_m_s - m.commanded_speed_m_s), tol),
        "peak torque": (m.peak_torque_fraction, c.max_peak_torque_fraction),
        "heading": (abs(m.heading_error_rad), c.max_heading_error_rad),
        "lateral drift": (m.lateral_drift_per_m, c.max_lateral_drift_per_m),
        "yaw drift": (m.yaw_drift_rad_per_m, c.max_yaw_drift_rad_per_m),
        "tilt": (m.tilt_max_rad, c.max_tilt_rad),
        "foot slip": (m.slip_mean_m, slip_limit_m(c, leg_length_m)),
    }
    ok = {name: passed for name, passed, _ in v.checks}
    out = {name: {"value": float(x), "limit": float(lim), "margin": (lim - float(x)) / lim,
                  "ok": ok[name]}
           for name, (x, lim) in pairs.items() if x is not None}
    out["no fall"] = {"value": float(m.fell), "limit": 0.0, "margin": -1.0 if m.fell else 1.0,
                      "ok": ok["no fall"]}
    return out


def perturbed_start(planner: GaitPlanner, case: Case, schedule: robots.ContactSchedule,
                    sigma: float, seed: int) -> WarmStart:
    """The cold start `GaitPlanner.solve` would use, moved by σ·max(1, |x0|)·N(0, 1), with the
    zero multipliers of a cold solve."""
    p = parameter_vector(schedule, planner.n_knots, case.speed_m_s, planner.swing_clearance_m,
                         0.0, 0.0)
    x0 = planner._cold_start(schedule, p, StartCommand(
        VelocityCommand(case.speed_m_s, 0.0, 0.0), planner.swing_clearance_m))
    noise = np.random.default_rng(seed).standard_normal(x0.size)
    x = x0 + sigma * np.maximum(1.0, np.abs(x0)) * noise
    return WarmStart(x, np.zeros_like(x), np.zeros(len(planner._lbg)))


def distance(a: np.ndarray, b: np.ndarray) -> float:
    """max |aᵢ − bᵢ| / max(1, |bᵢ|)."""
    return float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))))


@dataclasses.dataclass(frozen=True)
class Planners:
    """One robot's three planners at one knot count (built once, every case solves cold)."""

    full: GaitPlanner
    half: GaitPlanner
    perturbed: GaitPlanner
    meta: dict[str, Any] | None


def build_planners(bot: robots.Robot, knots: int) -> Planners:
    """The command line's options (`gaitsmith plan ROBOT --gait G`, no other flags)."""
    shaped = stance_shaped(bot, None, None, None, None)
    options = planner_options(DEFAULT_MU, PlannerOptions.derivatives, shaped, None, None,
                              half_cycle=False)
    return Planners(
        GaitPlanner(bot, knots, options),
        GaitPlanner(bot, knots, dataclasses.replace(options, half_cycle_solve=True)),
        GaitPlanner(bot, knots, dataclasses.replace(options, ipopt_tuning=SAME_OPTIONS_TUNING)),
        gait_metadata(None, None, shaped),
    )


def judged(planner: GaitPlanner, bot: robots.Robot, case: Case, label: str,
           meta: dict[str, Any] | None, result: PlanResult, x_full: np.ndarray | None,
           q_full: np.ndarray | None, cost_full: float | None) -> dict[str, Any]:
    """One run's record: the plan's figures and, if feasible, MuJoCo's verdict with margins."""
    row: dict[str, Any] = {
        "cost": result.cost, "feasible": result.feasible, "iterations": result.iterations,
        "status": result.status, "half_cycle_used": bool(result.stats.get("half_cycle")),
        "solve_s": result.solve_time_s,
    }
    if x_full is not None and q_full is not None and cost_full is not None:
        row["dx"] = distance(result.warm_start.x, x_full)
        row["dq_rad"] = float(np.max(np.abs(result.joint_angles_rad - q_full)))
        row["cost_rel"] = (result.cost - cost_full) / abs(cost_full)
    if not result.feasible:
        row["passed"] = None
        return row
    gait = planner.to_gait(result, label, extra_metadata=meta)
    attitude = attitude_settings(resolved_gain(None, bot, gait))
    cycles, _ = simulated_cycles(gait, case.cycles)
    t0 = time.process_time()
    v = validate(gait, bot, cycles, attitude=attitude, keep_trajectory=False)
    row.update(passed=v.passed, reasons=list(v.reasons), sim_cpu_s=time.process_time() - t0,
               heading_deg=math.degrees(v.metrics.heading_error_rad),
               speed_ratio=v.metrics.achieved_speed_m_s / case.speed_m_s,
               checks=check_margins(v, bot.leg_length_m))
    return row


def run_case(case: Case, bot: robots.Robot, planners: Planners, sigma: float,
             seeds: Sequence[int]) -> dict[str, Any]:
    """Every run of one case (see the module docstring)."""
    schedule, label = command_schedule(bot, case.gait, phases=case.phases, duty=case.duty,
                                       period_s=case.period_s)
    feet = mirror_permutation(bot)
    symmetric = feet is not None and schedule_symmetric(schedule, feet, case.knots)
    row: dict[str, Any] = {"case": case.key, "robot": case.robot, "gait": case.gait,
                           "speed_m_s": case.speed_m_s, "knots": case.knots,
                           "symmetric": symmetric, "sigma": sigma,
                           "utc": time.strftime("%H:%M:%S", time.gmtime()),
                           "load": os.getloadavg()[0]}
    c0 = time.process_time()
    full = planners.full.solve(schedule, case.speed_m_s, warm_start=False)
    x_full, q_full = full.warm_start.x, full.joint_angles_rad
    runs = {"full": judged(planners.full, bot, case, label, planners.meta, full, None, None,
                           None)}
    if symmetric:
        half = planners.half.solve(schedule, case.speed_m_s, warm_start=False)
        runs["half"] = judged(planners.half, bot, case, label, planners.meta, half, x_full,
                              q_full, full.cost)
    for seed in seeds:
        start = perturbed_start(planners.perturbed, case, schedule, sigma, seed)
        res = planners.perturbed.solve(schedule, case.speed_m_s, warm_start=start)
        run = judged(planners.perturbed, bot, case, label, planners.meta, res, x_full, q_full,
                     full.cost)
        run["same_optimum"] = bool(res.feasible and full.feasible
                                   and abs(run["cost_rel"]) <= SAME_COST_REL)
        runs[f"full~{seed}"] = run
    row["runs"] = runs
    row["cpu_s"] = time.process_time() - c0
    return row


def cmd_run(args: argparse.Namespace) -> None:
    if args.sigma < 0.0 or not math.isfinite(args.sigma):
        raise SystemExit(f"--sigma must be finite and ≥ 0, got {args.sigma}")
    try:
        seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    except ValueError:
        raise SystemExit(f"--seeds: {args.seeds!r} is not a comma-separated list of integers"
                         ) from None
    cases = parse_cases(args.cases, args.knots)
    done: set[str] = set()
    if args.out is not None and args.out.exists():
        done = {json.loads(line)["case"] for line in args.out.read_text().splitlines() if line}
    planners: dict[tuple[str, int], Planners] = {}
    for case in cases:
        if case.key in done:
            print(f"{case.key}: already in {args.out}", flush=True)
            continue
        bot = robots.load(case.robot)
        if (case.robot, case.knots) not in planners:
            planners.clear()  # one robot's planners at a time
            planners[case.robot, case.knots] = build_planners(bot, case.knots)
        try:
            row = run_case(case, bot, planners[case.robot, case.knots], args.sigma, seeds)
        except PlannerConfigError as exc:  # e.g. a template the NLP refuses at this speed
            print(f"{case.key}: refused: {exc}", flush=True)
            continue
        print(line(row), flush=True)
        if args.out is not None:
            with args.out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")


def tightest(run: dict[str, Any]) -> tuple[str, float] | None:
    """The check with the smallest normalised margin."""
    checks = run.get("checks")
    if not checks:
        return None
    name = min(checks, key=lambda n: checks[n]["margin"])
    return name, float(checks[name]["margin"])


def verdict(run: dict[str, Any]) -> str:
    if run.get("passed") is None:
        return "infeasible"
    return "pass" if run["passed"] else "FAIL"


def cell(name: str, run: dict[str, Any]) -> str:
    """One run as a table cell: verdict, tightest check and margin, heading, cost difference,
    distance from full's point."""
    t = tightest(run)
    parts = [verdict(run) + ("" if run.get("same_optimum", True) else " (other optimum)")]
    if t is not None:
        parts.append(f"{t[0]} {t[1]:+.2f}")
    if "heading_deg" in run:
        parts.append(f"{run['heading_deg']:+.1f}°")
    if "cost_rel" in run:
        parts.append(f"Δc {run['cost_rel']:+.1e}, Δx {run['dx']:.1e}")
    return ", ".join(parts)


def line(row: dict[str, Any], seeds: Sequence[str] | None = None) -> str:
    """One row of the table; `seeds`: the perturbed runs' columns ("—" where a row has none),
    None: the row's own."""
    runs = row["runs"]
    full = runs["full"]
    cells = [f"{row['case']}", f"{full['cost']:.6g} ({full['iterations']} it)",
             cell("full", full),
             cell("half", runs["half"]) if "half" in runs else "= full (not symmetric)"]
    names = [k for k in runs if k.startswith("full~")] if seeds is None else seeds
    cells += [cell(k, runs[k]) if k in runs else "—" for k in names]
    return "| " + " | ".join(cells) + " |"


def rows_of(path: Path) -> list[dict[str, Any]]:
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()]


def flips(rows: Sequence[dict[str, Any]], other: str) -> tuple[int, int]:
    """(verdict flips against full, comparable pairs) for runs named `other` ("half" or
    "full~"-prefixed): both feasible, perturbed runs only where they reached full's optimum."""
    n = k = 0
    for row in rows:
        full = row["runs"]["full"]
        for name, run in row["runs"].items():
            if name == "full" or not name.startswith(other):
                continue
            if full.get("passed") is None or run.get("passed") is None:
                continue
            if name.startswith("full~") and not run["same_optimum"]:
                continue
            if name == "half" and not run["half_cycle_used"]:
                continue
            n += 1
            k += run["passed"] != full["passed"]
    return k, n


def spreads(rows: Sequence[dict[str, Any]], other: str, check: str) -> Iterator[float]:
    """|margin(other) − margin(full)| of one check over the comparable pairs (see `flips`)."""
    for row in rows:
        full = row["runs"]["full"]
        for name, run in row["runs"].items():
            if name == "full" or not name.startswith(other):
                continue
            if name.startswith("full~") and not run.get("same_optimum"):
                continue
            if name == "half" and not run.get("half_cycle_used"):
                continue
            a, b = full.get("checks", {}).get(check), run.get("checks", {}).get(check)
            if a is not None and b is not None:
                yield abs(b["margin"] - a["margin"])


def cmd_table(args: argparse.Namespace) -> None:
    rows = [r for p in args.rows for r in rows_of(p)]
    seeds = sorted({k for r in rows for k in r["runs"] if k.startswith("full~")},
                   key=lambda k: int(k[len("full~"):]))
    print("| case | full cost (it) | full | half | " + " | ".join(seeds) + " |")
    print("|---|---|---|---|" + "---|" * len(seeds))
    for row in rows:
        print(line(row, seeds))
    print()
    for other, what in (("half", "full vs half"), ("full~", "full vs full~k")):
        k, n = flips(rows, other)
        print(f"- verdict flips {what}: {k} of {n}")
    print()
    print("| check: median / 90th percentile / max of |Δ margin| | full vs half | "
          "full vs full~k |")
    print("|---|---|---|")
    for check in ("heading", "speed", "lateral drift", "yaw drift", "tilt", "foot slip",
                  "peak torque"):
        cells = []
        for other in ("half", "full~"):
            d = sorted(spreads(rows, other, check))
            cells.append(f"{np.median(d):.3f} / {np.percentile(d, 90):.3f} / {max(d):.3f} "
                         f"(n {len(d)})" if d else "—")
        print(f"| {check} | " + " | ".join(cells) + " |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="plan and judge the cases")
    r.add_argument("--cases", required=True)
    r.add_argument("--knots", type=int, default=30)
    r.add_argument("--sigma", type=float, default=DEFAULT_SIGMA)
    r.add_argument("--seeds", default=",".join(str(s) for s in DEFAULT_SEEDS))
    r.add_argument("--out", type=Path, default=None)
    t = sub.add_parser("table", help="tables and counts of recorded rows")
    t.add_argument("rows", type=Path, nargs="+")
    args = ap.parse_args(argv)
    if args.cmd == "run":
        print(f"start {time.strftime('%H:%M:%S', time.gmtime())} UTC, load "
              f"{os.getloadavg()[0]:.2f}", flush=True)
        cmd_run(args)
        print(f"end {time.strftime('%H:%M:%S', time.gmtime())} UTC, load "
              f"{os.getloadavg()[0]:.2f}", flush=True)
    else:
        missing = [str(p) for p in args.rows if not p.is_file()]
        if missing:
            raise SystemExit(f"table: no such file {', '.join(missing)}")
        cmd_table(args)


if __name__ == "__main__":
    main()

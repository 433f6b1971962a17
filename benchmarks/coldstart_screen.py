"""Screen cold-start remedies (issue #16, docs/results/planner_speed_coldstart.md, session 39).

    python benchmarks/coldstart_screen.py hex18 0.15 base='{}' \\
        u_p3='{"warm_start_bound_push":1e-3,"warm_start_slack_bound_push":1e-3,\\
               "warm_start_mult_bound_push":1e-3}' freeclr='{"_freeclr":1}' --random 20

One planner per variant, built with `PlannerOptions()` (the half-cycle solve where it fits, as
`gaitsmith plan` does) or with the `PlannerOptions` fields a variant names; cold solves of every
template of the robot (a template a moving command refuses, "stand", is skipped) and of
``--random`` schedules drawn as `planner_bench compare` draws them (seed 0, around the robot's
default gait). Prints iterations per schedule with the cost relative to the first variant
("c": stopped short of IPOPT's optimality test; "V!": another feasibility verdict), then the
sums, process CPU and the median iterations. IPOPT is deterministic: iteration counts compare
across runs; CPU only within one.

A variant is ``name=SPEC``; SPEC is a JSON object of IPOPT options added to the *cold* solves'
options (`planner.nlp.spacetime.ipopt_options`; warm solves keep theirs), or
``opt:field=value,...[;JSON]`` to build the planner with those `PlannerOptions` fields (strings)
and, after ``;``, the JSON. Keys starting with ``_`` are this screen's own remedies:

- ``"_freeclr": 1`` — the "swing clearance" rows at the (foot, knot) pairs in contact get lower
  bound −∞: there the swing profile is 0 and the row (foot height ≥ 0) repeats the "stance
  height" equality, so it sits on its bound at every point of the feasible set (same feasible
  set; the row's slack is one of the first iterations' blockers, `ipopt_blockers.py`).
- ``"_lift": 1`` — the cold start of ``cold_start="balanced"`` on poses whose swing feet are
  lifted 1.25× the swing profile by IK and whose stance feet stay put (`ColdStarter`'s
  "stride" with a zero velocity command); use with ``opt:cold_start=balanced``.
- ``"_z0": z`` — cold starts pass multiplier z for every inequality row and variable bound the
  start sits on or past (instead of zeros; IPOPT lifts zeros to its multiplier push).

The remedies are applied by replacing `ipopt_options`, `WarmStart`, `ColdStarter.start` and
`GaitPlanner._solve_bounds` in their modules for this process only.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from planner.errors import PlannerConfigError
from planner.nlp import cold_start as cs
from planner.nlp import spacetime as st
from planner.nlp.config import PlannerOptions
from planner.nlp.stance_clearance import free_stance_clearance
from planner.nlp.variables import parameter_vector
from planner.templates import default_gait_for, make_schedule, templates_for

sys.path.insert(0, str(Path(__file__).resolve().parent))
from planner_bench import random_schedule

#: the current variant's extra options (IPOPT's and the ``_`` remedies)
EXTRA: dict[str, Any] = {}
#: the planner, schedule and speed of the solve under way (for ``_z0``)
CURRENT: dict[str, Any] = {}

_ipopt_options = st.ipopt_options
_warm_start = st.WarmStart
_start = cs.ColdStarter.start
_solve_bounds = st.GaitPlanner._solve_bounds


def _options(options: PlannerOptions, warm: bool) -> dict[str, Any]:
    out = _ipopt_options(options, warm)
    if not warm or options.ipopt_tuning != "tuned":
        out.update({k: v for k, v in EXTRA.items() if not k.startswith("_")})
    return out


def _targeted(x: np.ndarray, lam_x: np.ndarray, lam_g: np.ndarray,
              schedule: Any = None) -> Any:
    """``_z0``: a cold start's zero multipliers become z0 where the start sits on or past a
    bound of an inequality row or a variable (lower side negative, CasADi's sign); `schedule`:
    `WarmStart.schedule`, passed through."""
    z0 = EXTRA.get("_z0")
    if z0 is None or np.any(lam_x) or np.any(lam_g) or "planner" not in CURRENT:
        return _warm_start(x, lam_x, lam_g, schedule)
    planner, schedule, speed = CURRENT["planner"], CURRENT["schedule"], CURRENT["speed"]
    p = parameter_vector(schedule, planner.n_knots, speed, planner.swing_clearance_m, 0.0, 0.0)
    b = planner._solve_bounds(schedule)
    g = np.asarray(planner._evaluate(x, p)[0]).ravel()
    ineq = b.lbg < b.ubg
    lo = ineq & np.isfinite(b.lbg) & (g - b.lbg <= 1e-6 * np.maximum(1.0, np.abs(b.lbg)))
    hi = ineq & np.isfinite(b.ubg) & (b.ubg - g <= 1e-6 * np.maximum(1.0, np.abs(b.ubg)))
    lam_g, lam_x = np.zeros_like(g), np.zeros_like(x)
    lam_g[lo], lam_g[hi] = -z0, z0
    box = b.lbx < b.ubx
    xl = box & np.isfinite(b.lbx) & (x - b.lbx <= 1e-6 * np.maximum(1.0, np.abs(b.lbx)))
    xu = box & np.isfinite(b.ubx) & (b.ubx - x <= 1e-6 * np.maximum(1.0, np.abs(b.ubx)))
    lam_x[xl], lam_x[xu] = -z0, z0
    return _warm_start(x, lam_x, lam_g, schedule)


def _lifted(self: cs.ColdStarter, kind: str, schedule: robots.ContactSchedule,
            command: cs.StartCommand, p: np.ndarray) -> np.ndarray:
    if EXTRA.get("_lift"):
        command = dataclasses.replace(command, velocity=cs.VelocityCommand(0.0, 0.0, 0.0))
        kind = "stride"
    return _start(self, kind, schedule, command, p)


def _bounds(self: st.GaitPlanner, schedule: robots.ContactSchedule,
            swing_wrench: str | None = None) -> st.SolveBounds:
    b = _solve_bounds(self, schedule, swing_wrench)
    if not EXTRA.get("_freeclr"):
        return b
    # the same rows `PlannerOptions(stance_clearance="free")` frees
    lbg = free_stance_clearance(dict(self._slices), schedule.contact_matrix(self.n_knots), b.lbg)
    return st.SolveBounds(b.lbx, b.ubx, lbg, b.ubg)


def _variant(text: str) -> tuple[str, dict[str, str], dict[str, Any]]:
    name, spec = text.split("=", 1)
    fields: dict[str, str] = {}
    extra: dict[str, Any] = {}
    if spec.startswith("opt:"):
        spec = spec[4:]
        if ";" in spec:
            spec, extra_json = spec.split(";", 1)
            extra = json.loads(extra_json)
        for item in filter(None, spec.split(",")):
            key, value = item.split("=", 1)
            fields[key] = value
    else:
        extra = json.loads(spec)
    return name, fields, extra


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("robot", help="robot name or folder")
    ap.add_argument("speed", type=float, help="[m/s]")
    ap.add_argument("variants", nargs="+", help="name=SPEC (module docstring); first: baseline")
    ap.add_argument("--gait", default=None, help="the random schedules' base (default gait)")
    ap.add_argument("--random", type=int, default=0)
    ap.add_argument("--templates", default=None, help="only these (comma-separated)")
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--out", default=None, help="append one JSON line per solve")
    a = ap.parse_args()
    st.ipopt_options = _options  # type: ignore[assignment]
    st.WarmStart = _targeted  # type: ignore[misc, assignment]
    cs.ColdStarter.start = _lifted  # type: ignore[method-assign]
    st.GaitPlanner._solve_bounds = _bounds  # type: ignore[method-assign]
    robot = robots.load(a.robot)
    only = None if a.templates is None else a.templates.split(",")
    schedules = [(t, make_schedule(robot, t)) for t in templates_for(robot)
                 if only is None or t in only]
    rng = np.random.default_rng(0)
    base = make_schedule(robot, a.gait or default_gait_for(robot))
    schedules += [(f"random{i}", random_schedule(base, rng)) for i in range(a.random)]
    variants = [_variant(v) for v in a.variants]
    out = open(a.out, "a") if a.out else None
    results: dict[tuple[str, str], dict[str, Any]] = {}
    for name, fields, extra in variants:
        EXTRA.clear()
        EXTRA.update(extra)
        planner = st.GaitPlanner(robot, a.knots, PlannerOptions(**fields))  # type: ignore[arg-type]
        for label, schedule in schedules:
            CURRENT.update(planner=planner, schedule=schedule, speed=a.speed)
            t0 = time.process_time()
            try:
                res = planner.solve(schedule, a.speed, warm_start=False)
            except PlannerConfigError as exc:
                print(f"{name} {label}: skipped ({exc})")
                continue
            rec = {"robot": a.robot, "variant": name, "schedule": label, "it": res.iterations,
                   "cost": res.cost, "feasible": bool(res.feasible), "optimal": bool(res.optimal),
                   "cpu": time.process_time() - t0, "half": bool(res.stats.get("half_cycle")),
                   "status": res.status}
            results[(name, label)] = rec
            if out is not None:
                out.write(json.dumps(rec) + "\n")
                out.flush()
    _table(a.robot, a.knots, a.speed, variants, schedules, results)


def _table(robot: str, knots: int, speed: float, variants: list[Any], schedules: list[Any],
           results: dict[tuple[str, str], dict[str, Any]]) -> None:
    base = variants[0][0]
    print(f"{robot} N={knots} speed {speed}; iterations (cost rel. to {base})")
    print("schedule".ljust(18) + "".join(v[0][:22].rjust(24) for v in variants))
    totals: dict[str, list[Any]] = {v[0]: [0, 0.0, []] for v in variants}
    for label, _ in schedules:
        b = results.get((base, label))
        cells = []
        for name, _, _ in variants:
            r = results.get((name, label))
            if r is None or b is None:
                cells.append("-".rjust(24))
                continue
            rel = (r["cost"] - b["cost"]) / max(abs(b["cost"]), 1e-12)
            flag = "" if r["feasible"] == b["feasible"] else "V!"
            mark = "" if r["optimal"] else "c"
            cells.append(f"{r['it']}{mark} {rel:+.1e}{flag}".rjust(24))
            totals[name][0] += r["it"]
            totals[name][1] += r["cpu"]
            totals[name][2].append(r["it"])
        print(label.ljust(18) + "".join(cells))
    print("sum it / CPU s / median".ljust(18) + "".join(
        f"{t[0]} {t[1]:.1f}s m{np.median(t[2]) if t[2] else 0:.0f}".rjust(24)
        for t in totals.values()))


if __name__ == "__main__":
    main()

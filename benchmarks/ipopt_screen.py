"""Screen IPOPT option sets and warm-start policies on one planner (issue #16, iterations).

    python benchmarks/ipopt_screen.py --variants base,cold_std --templates walk,trot --warm 4

One GaitPlanner (quad12 trot by default, N=30) is built once; every variant gets its own IPOPT
instance on the same NLP (`GaitPlanner._nlp`) with the session-21 options
(`planner.nlp.spacetime.ipopt_options` with ``ipopt_tuning="session21"``) changed by the
variant's ``cold``/``warm`` dicts, and solves the same schedules: the named templates cold, then
the template of ``--gait`` cold and a chain of ``--warm`` perturbed schedules
(`planner_bench.perturbed`, seed+1 as `planner_bench compare` uses), each warm-started from the
previous solution by the variant's policy. Prints iterations, cost and process CPU seconds per
solve: IPOPT is deterministic, so iteration counts compare across runs; times only within one.
docs/results/planner_speed_ipopt.md lists what was measured with it.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import casadi as ca
import numpy as np

import robots
from planner.nlp import spacetime
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, WarmStart, ipopt_options
from planner.templates import make_schedule

sys.path.insert(0, str(Path(__file__).resolve().parent))
from planner_bench import perturbed

#: (planner, schedule, last start or None) → the start to pass (None: cold)
Policy = Callable[[GaitPlanner, robots.ContactSchedule, WarmStart | None], WarmStart | None]


def _push(value: float, mu_init: float | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {k: value for k in ("warm_start_bound_push",
                                              "warm_start_slack_bound_push",
                                              "warm_start_mult_bound_push")}
    if mu_init is not None:
        out["mu_init"] = mu_init
    return out


def _contact_changes() -> Callable[[GaitPlanner, robots.ContactSchedule], set[tuple[int, int]]
                                    | None]:
    """A tracker of the schedule between solves: called with each solve's planner and schedule,
    it returns the (foot, knot) cells whose contact mode changed since the previous call (None
    on the first)."""
    last: dict[str, np.ndarray] = {}

    def changed(pl: GaitPlanner, s: robots.ContactSchedule) -> set[tuple[int, int]] | None:
        new = s.contact_matrix(pl.n_knots)
        old = last.get("contact")
        last["contact"] = new
        if old is None:
            return None
        return {(f, k) for k in range(pl.n_knots) for f in range(new.shape[1])
                if new[k, f] != old[k, f]}

    return changed


def _force_mask(pl: GaitPlanner, cells: set[tuple[int, int]]) -> np.ndarray:
    """The decision variables that are the contact forces of `cells`."""
    forces = {f"foot {f} f{a}@knot {k}" for f, k in cells for a in "xyz"}
    return np.array([lab in forces for lab in pl._x_labels])


def reset_changed_duals() -> Policy:
    """Last multipliers, but those of every row and force of a (foot, knot) whose contact mode
    changed since the last solve set to zero."""
    changes = _contact_changes()

    def policy(pl: GaitPlanner, s: robots.ContactSchedule, ws: WarmStart | None) -> Any:
        changed = changes(pl, s)
        if ws is None or changed is None:
            return ws
        names = pl.robot.foot_names
        rows = {f"foot {names[f]}@knot {k}" for f, k in changed}
        lam_g, lam_x = ws.lam_g.copy(), ws.lam_x.copy()
        for group, sl in pl._slices:
            labels = pl._labels.get(group)
            if labels is not None:
                lam_g[np.arange(sl.start, sl.stop)[[lab in rows for lab in labels]]] = 0.0
        lam_x[_force_mask(pl, changed)] = 0.0
        return WarmStart(ws.x, lam_x, lam_g)

    return policy


def reset_changed_forces() -> Policy:
    """Last primal point, but the forces of every (foot, knot) whose contact mode changed taken
    from the cold initial guess (`planner.nlp.variables.initial_guess`); zero multipliers."""
    from planner.nlp.variables import initial_guess

    changes = _contact_changes()

    def policy(pl: GaitPlanner, s: robots.ContactSchedule, ws: WarmStart | None) -> Any:
        changed = changes(pl, s)
        if ws is None or changed is None:
            return ws
        mask = _force_mask(pl, changed)
        x = ws.x.copy()
        x[mask] = initial_guess(pl.layout, pl.model, s)[mask]
        return WarmStart(x, np.zeros_like(ws.lam_x), np.zeros_like(ws.lam_g))

    return policy


#: name → cold options, warm options (default: the cold ones), policy ("primal": last point,
#: zero multipliers; "duals": last point and multipliers; or a `Policy` factory)
VARIANTS: dict[str, dict[str, Any]] = {
    "base": {},
    "cold_std": {"cold": {"warm_start_init_point": "no", "mu_init": 0.1}, "warm": {}},
    "probing": {"cold": {"mu_oracle": "probing"}},
    "loqo": {"cold": {"mu_oracle": "loqo"}},
    "noscale": {"cold": {"nlp_scaling_method": "none"}},
    "mumps_noscale": {"cold": {"mumps_permuting_scaling": 0, "mumps_scaling": 0}},
    "w_duals": {"policy": "duals"},
    "w_duals_mu4": {"policy": "duals", "warm": {"mu_init": 1e-4}},
    "w_duals_mu3_push3": {"policy": "duals", "warm": _push(1e-3, 1e-3)},
    "w_reset_mu3": {"policy": reset_changed_duals,
                    "warm": {"mu_init": 1e-3, "warm_start_mult_bound_push": 1e-3}},
    "w_primal_xreset": {"policy": reset_changed_forces},
    "w_primal_push3": {"warm": _push(1e-3, 1e-3)},
    "w_p3_mu4": {"warm": _push(1e-3, 1e-4)},
    "w_p2": {"warm": _push(1e-2)},
    "u_p3": {"cold": _push(1e-3)},
}


def _solver(planner: GaitPlanner, extra: dict[str, Any]) -> Any:
    ipopt = ipopt_options(replace(planner.options, ipopt_tuning="session21"), warm=False)
    ipopt.update(extra)
    return ca.nlpsol("spacetime", "ipopt", planner._nlp,
                     {"ipopt": ipopt, "print_time": False,
                      "expand": planner.options.derivatives == "expanded",
                      "error_on_fail": False})


def screen(robot_name: str, gait: str, speed: float, n_knots: int, names: list[str],
           templates: list[str], n_warm: int, seed: int, chain_cold: bool = False) -> None:
    robot = robots.load(robot_name)
    planner = GaitPlanner(robot, n_knots, PlannerOptions(ipopt_tuning="session21"))
    base = make_schedule(robot, gait)
    warm_rng = np.random.default_rng(seed + 1)
    chain = [perturbed(base, warm_rng) for _ in range(n_warm)]
    for name in names:
        v = VARIANTS[name]
        cold_solver = _solver(planner, v.get("cold", {}))
        warm_solver = _solver(planner, v.get("warm", v.get("cold", {})))
        kind = v.get("policy", "primal")
        policy: Policy | None = kind() if callable(kind) else None

        def solve(schedule: robots.ContactSchedule, start: WarmStart | None, label: str,
                  cold_solver: Any = cold_solver, warm_solver: Any = warm_solver,
                  kind: Any = kind, policy: Policy | None = policy, name: str = name) -> Any:
            planner._solver = cold_solver if start is None else warm_solver
            spacetime.WARM_START_DUALS = kind != "primal"
            if policy is not None:
                start = policy(planner, schedule, start)
            t0 = time.process_time()
            res = planner.solve(schedule, speed, warm_start=start if start is not None else False)
            print(f"  {name} {label}: {res.iterations} it, cost {res.cost:.8g}, "
                  f"{'feasible' if res.feasible else res.status}, "
                  f"{time.process_time() - t0:.1f} s CPU", flush=True)
            return res

        try:
            cold = [solve(make_schedule(robot, t), None, f"cold {t}").iterations
                    for t in templates]
            last = solve(base, None, f"cold {gait} (chain start)")
            warm = []
            for i, schedule in enumerate(chain):
                res = solve(schedule, last.warm_start if last.feasible else None, f"warm {i}")
                warm.append(res.iterations)
                last = res
            if chain_cold:  # the reference: the same chain, every schedule cold
                cold += [solve(schedule, None, f"cold chain {i}").iterations
                         for i, schedule in enumerate(chain)]
        finally:
            spacetime.WARM_START_DUALS = False
        print(f"{name}: cold {cold} (sum {sum(cold)}) | warm chain {warm} (sum {sum(warm)})",
              flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--gait", default="trot")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--variants", default="base", help=f"known: {', '.join(VARIANTS)}")
    ap.add_argument("--templates", default="walk,trot,pace,bound,gallop_rotary")
    ap.add_argument("--warm", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--chain-cold", action="store_true",
                    help="also solve every schedule of the warm chain cold")
    args = ap.parse_args()
    names = [n.strip() for n in args.variants.split(",") if n.strip()]
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        ap.error(f"--variants: unknown {', '.join(unknown)}; known: {', '.join(VARIANTS)}")
    templates = [t.strip() for t in args.templates.split(",") if t.strip()]
    screen(args.robot, args.gait, args.speed, args.knots, names, templates, args.warm, args.seed,
           args.chain_cold)


if __name__ == "__main__":
    main()

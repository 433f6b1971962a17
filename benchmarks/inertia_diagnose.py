"""Why IPOPT corrects the inertia: the reduced Hessian at each iterate of one cold solve.

    python benchmarks/inertia_diagnose.py [--robot hex18] [--speed 0.15] [--gait tripod]
                                          [--knots 30] [--iters all|8,9,10] [--option F=V …]
                                          [--random I] [--plain] [--corrected] [--detail]

Solves the template (or planner_bench's `--random` schedule) cold, on the half-cycle NLP where
it fits (else the full NLP), with the options `gaitsmith plan ROBOT --search` gives
(`gait_search_bench.cli_search_options`, as half_cycle_bench.py; `--plain`: `PlannerOptions()`,
planner_bench's "default"), IPOPT writing its iterates to a file at ``file_print_level`` 8
(every ``curr_*`` vector in IPOPT's own scaled space, the constraint scaling, δ_c and every δ_w
it tried). At each iterate k it rebuilds what IPOPT factorised: W = ∇²L (the reduced NLP's own
``nlp_hess_l`` at x_k with IPOPT's multipliers, σ = 1 here), the equality Jacobian J_c (scaled
rows), and the barrier terms Σ_x = z_L/(x − x_L) + z_U/(x_U − x) and Σ_s = v_L/(s − d_L) +
v_U/(d_U − s) of the bounds and inequality slacks. Eliminating the slacks and the inequality
multipliers exactly (δ_d included), IPOPT's KKT matrix has the inertia it wants iff A = W + Σ_x
+ J_dᵀ(Σ_s⁻¹ + δ_d)⁻¹J_d is positive definite on the null space of J_c (δ_c → 0; J_c's zero
rows, the schedule's inactive ones, dropped). The null space Z comes from a dense SVD; the
smallest eigenvalues of ZᵀAZ are printed beside IPOPT's trial δ_w (a correction: a list longer
than [0.0]). For every negative eigenvalue (or the smallest, if none) its unit eigenvector v is
attributed: vᵀAv split into the objective's vᵀ∇²f v, each row group's vᵀ(Σ λ_i∇²g_i)v (one
``nlp_hess_l`` call per group, λ masked; "stance height" and the "swing clearance" rows, which
repeat each other at stance knots and carry large opposite multipliers there, are also summed as
"foot height"), Σ_x, each inequality group's barrier; the objective further into its terms
(central differences of the planner's weighted terms along E·v); v's squared norm per variable
block and its largest entries; and the largest negative groups per knot and per row label.
docs/results/planner_speed_rows.md, session 44 (branch inertia).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import casadi as ca
import numpy as np
from gait_search_bench import cli_search_options
from half_cycle_bench import _fields

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.half_cycle import HalfCycleNLP, RowSelection, VariableMirror
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import BLOCKS, parameter_vector
from planner.templates import make_schedule

_VECTOR = re.compile(r'^DenseVector "([^"]+)" with (\d+) elements:')
_BEGIN = re.compile(r"^\*\*\* Beginning Iteration (\d+) from the following point:")
_PHASE = re.compile(r"^\*\*\* (?:Update Barrier Parameter|Solving the Primal Dual System) "
                    r"for Iteration (\d+)")
_HOMOGENEOUS = re.compile(r"[Hh]omogeneous vector, all elements have value ([-+0-9.eE]+)")
_DELTA_X = re.compile(r"Solving system with delta_x=([-+0-9.eE]+)")
_DELTA_C = re.compile(r"delta_c=([-+0-9.eE]+)")
#: rows that repeat each other at stance knots, also summed
FOOT_HEIGHT = ("stance height", "swing clearance")


@dataclasses.dataclass(frozen=True)
class IpoptLog:
    """What `parse_log` reads: global vectors (e.g. "c scaling vector"), each iteration's
    ``curr_*`` vectors, δ_c and the δ_w IPOPT tried at each iteration (first: 0)."""

    vectors: dict[str, np.ndarray]
    iterates: dict[int, dict[str, np.ndarray]]
    delta_c: dict[int, float]
    delta_w: dict[int, list[float]]


def parse_log(lines: Iterator[str]) -> IpoptLog:
    """IPOPT's file log at ``file_print_level`` ≥ 8."""
    vectors: dict[str, np.ndarray] = {}
    iterates: dict[int, dict[str, np.ndarray]] = {}
    delta_c: dict[int, float] = {}
    delta_w: dict[int, list[float]] = {}
    current = vectors
    phase: int | None = None
    for line in lines:
        if m := _BEGIN.match(line):
            current = iterates.setdefault(int(m.group(1)), {})
            continue
        if m := _PHASE.match(line):
            phase = int(m.group(1))
            continue
        if phase is not None and (m := _DELTA_X.search(line)):
            delta_w.setdefault(phase, []).append(float(m.group(1)))
        if phase is not None and (m := _DELTA_C.search(line)):
            delta_c.setdefault(phase, float(m.group(1)))
        m = _VECTOR.match(line)
        if not m:
            continue
        name, n = m.group(1), int(m.group(2))
        first = next(lines)
        if h := _HOMOGENEOUS.search(first):
            values = np.full(n, float(h.group(1)))
        else:
            values = np.array([float(first.split("=")[1])]
                              + [float(next(lines).split("=")[1]) for _ in range(n - 1)])
        current.setdefault(name, values)
    return IpoptLog(vectors, iterates, delta_c, delta_w)


def _dense(value: Any) -> np.ndarray:
    return np.asarray(ca.DM(value).full())


def _symmetric(triu: Any) -> np.ndarray:
    h = _dense(triu)
    return h + h.T - np.diag(np.diag(h))


class Diagnosis:
    """The reduced NLP of one solved half-cycle planner and IPOPT's view of it."""

    def __init__(self, planner: GaitPlanner, schedule: robots.ContactSchedule, speed: float,
                 log: IpoptLog, half_cycle: bool = True) -> None:
        half = planner._half_cycle if half_cycle else None
        if half_cycle and not isinstance(half, HalfCycleNLP):
            raise SystemExit("the solve did not take the half-cycle path")
        self.planner, self.log = planner, log
        n_x, n_g = planner.layout.size, planner._lbg.size
        if isinstance(half, HalfCycleNLP):
            m, r, solver, self.f_factor = half.mirror, half.rows, half.solver, 0.5
        else:  # the full NLP: E = I, every row, f itself
            m = VariableMirror(np.arange(n_x), np.ones(n_x), np.arange(n_x))
            r, solver, self.f_factor = RowSelection(np.arange(n_g), np.ones(n_g)), \
                planner._solver, 1.0
        self.mirror = m
        self.p = parameter_vector(schedule, planner.n_knots, speed, planner.swing_clearance_m,
                                  0.0, 0.0)
        bounds = planner._solve_bounds(schedule, planner.options.swing_wrench)
        self.lbx, ubx = bounds.lbx[m.half], bounds.ubx[m.half]
        self.lbg = r.weight * bounds.lbg[r.keep]
        ubg = r.weight * bounds.ubg[r.keep]
        self.free = self.lbx != ubx  # IPOPT removes fixed variables
        self.eq = self.lbg == ubg
        self.ineq = ~self.eq
        self.x_lower = (self.lbx > -1e19)[self.free]
        self.x_upper = (ubx < 1e19)[self.free]
        self.d_lower = self.lbg[self.ineq] > -1e19
        self.d_upper = ubg[self.ineq] < 1e19
        self.jac = solver.get_function("nlp_jac_g")
        self.hess = solver.get_function("nlp_hess_l")
        group = np.empty(planner._lbg.size, dtype=object)
        label = np.empty(planner._lbg.size, dtype=object)
        for name, sl in planner._slices:
            group[sl] = name
            names = planner._labels.get(name)
            label[sl] = names if names is not None and len(names) == sl.stop - sl.start else name
        self.group, self.label = group[r.keep], label[r.keep]
        self.groups = list(dict.fromkeys(self.group))
        self.x_labels = np.array(planner._x_labels)[m.half]
        self.block = np.empty(m.n_reduced, dtype=object)
        for name in BLOCKS:
            sl = planner.layout.block(name)
            self.block[np.isin(m.half, np.arange(sl.start, sl.stop))] = name

    def point(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """x (reduced, fixed entries at their bound) and the multipliers λ IPOPT's Hessian call
        gets at iterate k (y_c times the row scaling, y_d)."""
        vec = self.log.iterates[k]
        x = self.lbx.copy()
        x[self.free] = vec["curr_x"]
        lam = np.zeros(self.lbg.size)
        lam[self.eq] = vec["curr_y_c"] * self.log.vectors.get(
            "c scaling vector", np.ones(int(self.eq.sum())))
        lam[self.ineq] = vec["curr_y_d"]
        return x, lam

    def matrices(self, k: int) -> dict[str, np.ndarray]:
        """At iterate k: A (free variables), J_c (scaled), J_d, Σ_x and the slacks' D."""
        vec = self.log.iterates[k]
        x, lam = self.point(k)
        fx = np.ix_(self.free, self.free)
        w = _symmetric(self.hess(x, self.p, 1.0, lam))[fx]
        jac = _dense(self.jac(x, self.p)[1])[:, self.free]
        scale = self.log.vectors.get("c scaling vector", np.ones(int(self.eq.sum())))
        jc, jd = scale[:, None] * jac[self.eq], jac[self.ineq]
        sx = np.zeros(int(self.free.sum()))
        sx[self.x_lower] += vec["curr_z_L"] / vec["curr_slack_x_L"]
        sx[self.x_upper] += vec["curr_z_U"] / vec["curr_slack_x_U"]
        ss = np.zeros(int(self.ineq.sum()))
        ss[self.d_lower] += vec["curr_v_L"] / vec["curr_slack_s_L"]
        ss[self.d_upper] += vec["curr_v_U"] / vec["curr_slack_s_U"]
        d = 1.0 / (1.0 / np.maximum(ss, 1e-300) + self.log.delta_c.get(k, 0.0))
        a = w + np.diag(sx) + jd.T @ (d[:, None] * jd)
        return {"x": x, "lam": lam, "A": a, "Jc": jc, "Jd": jd, "Sx": sx, "D": d}

    def lowest(self, mats: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eigenvalues and unit eigenvectors (free variables) of ZᵀAZ, ascending, and J_c's
        smallest nonzero singular values."""
        jc = mats["Jc"][np.abs(mats["Jc"]).max(axis=1) > 0]
        _, s, vt = np.linalg.svd(jc, full_matrices=True)
        rank = int((s > s.max() * max(jc.shape) * np.finfo(float).eps).sum())
        z = vt[rank:].T
        ev, ew = np.linalg.eigh(z.T @ mats["A"] @ z)
        return ev, z @ ew, s[max(rank - 3, 0):rank]

    def curvature(self, mats: dict[str, np.ndarray], vf: np.ndarray,
                  rows: Callable[[int], str] | None = None,
                  only: str | None = None) -> dict[str, float]:
        """vᵀAv split by term (module docstring); with `rows`, the λ·∇²g part of group `only`
        (or of the foot-height pair, `only` = "foot height") split by `rows(row index)`."""
        x, lam = mats["x"], mats["lam"]
        v = np.zeros(self.lbx.size)
        v[self.free] = vf

        def part(mask: np.ndarray) -> float:
            lg = np.where(mask, lam, 0.0)
            return float(v @ _symmetric(self.hess(x, self.p, 0.0, lg)) @ v) if lg.any() else 0.0

        if rows is not None:
            members = (np.isin(self.group, FOOT_HEIGHT) if only == "foot height"
                       else self.group == only)
            keys: dict[str, list[int]] = {}
            for i in np.flatnonzero(members):
                keys.setdefault(rows(int(i)), []).append(int(i))
            return {key: part(np.isin(np.arange(self.lbg.size), idx))
                    for key, idx in keys.items()}
        out = {"total": float(vf @ mats["A"] @ vf),
               "objective": float(v @ _symmetric(
                   self.hess(x, self.p, 1.0, np.zeros(self.lbg.size))) @ v)}
        for g in self.groups:
            out[f"λ {g}"] = part(self.group == g)
        out["λ foot height (sum)"] = part(np.isin(self.group, FOOT_HEIGHT))
        out["Σ_x"] = float((mats["Sx"] * vf * vf).sum())
        barrier = mats["D"] * (mats["Jd"] @ vf) ** 2
        for g in self.groups:
            mask = self.group[self.ineq] == g
            if mask.any():
                out[f"Σ_s {g}"] = float(barrier[mask].sum())
        return {k: val for k, val in out.items() if k in ("total", "objective") or abs(val) > 0}

    def cost_terms(self, k: int, vf: np.ndarray, step: float = 1e-3) -> dict[str, float]:
        """The objective's curvature along v by weighted term (the half-cycle NLP's f̃ = f/2),
        central differences of the planner's terms at E·x along E·v."""
        planner, m = self.planner, self.mirror
        x, _ = self.point(k)
        v = np.zeros(self.lbx.size)
        v[self.free] = vf
        xf, u = m.expand(x), m.expand(v)
        n_terms = len(planner._term_names)

        def terms(at: np.ndarray) -> np.ndarray:
            out = planner._evaluate(at, self.p)
            return np.array([float(out[3 + j]) for j in range(n_terms)])

        second = (terms(xf + step * u) - 2 * terms(xf) + terms(xf - step * u)) / step**2
        weights = planner.options.weights.as_dict()
        return {name: float(self.f_factor * weights[name] * second[j])
                for j, name in enumerate(planner._term_names) if weights[name]}

    def blocks(self, vf: np.ndarray) -> dict[str, float]:
        share: dict[str, float] = {}
        for name, value in zip(self.block[self.free], vf, strict=True):
            share[name] = share.get(name, 0.0) + float(value * value)
        return share


def solve_logged(robot_name: str, speed: float, gait: str, knots: int,
                 fields: dict[str, Any], log_path: Path, random: int | None = None,
                 plain: bool = False) -> tuple[GaitPlanner, Any, Any]:
    """One cold solve, logged. `random`: planner_bench's random schedule of that index (seed 0,
    on `gait`'s template) instead of the template; `plain`: `PlannerOptions()` (planner_bench's
    "default") instead of the command line's search options."""
    robot = robots.load(robot_name)
    options = PlannerOptions() if plain else cli_search_options(robot, speed_m_s=speed)[0]
    options = dataclasses.replace(
        options, half_cycle_solve=True, **fields,
        ipopt_extra=(*options.ipopt_extra, ("output_file", str(log_path)),
                     ("file_print_level", 8)))
    planner = GaitPlanner(robot, knots, options)
    schedule = make_schedule(robot, gait)
    if random is not None:
        from planner_bench import random_schedule

        rng = np.random.default_rng(0)
        for _ in range(random + 1):
            drawn = random_schedule(schedule, rng)
        schedule = drawn
    c0 = time.process_time()
    result = planner.solve(schedule, speed, warm_start=False)
    name = gait if random is None else f"random{random} (on {gait})"
    print(f"{robot_name} {name} {speed} m/s N={knots} {fields or ''}: {result.iterations} it, "
          f"cost {result.cost:.10g}, feasible {result.feasible}, half-cycle "
          f"{result.stats['half_cycle']}, CPU {time.process_time() - c0:.2f} s (logging at "
          "level 8 included)", flush=True)
    return planner, schedule, result


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="hex18")
    ap.add_argument("--speed", type=float, default=0.15)
    ap.add_argument("--gait", default="tripod")
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--iters", default="all", help="iterates to analyse: all or k,k,…")
    ap.add_argument("--option", default="", help="FIELD=VALUE[,…] PlannerOptions fields")
    ap.add_argument("--random", type=int, default=None,
                    help="planner_bench's random schedule of this index (seed 0) on --gait")
    ap.add_argument("--plain", action="store_true",
                    help="PlannerOptions() (planner_bench's default) instead of the CLI's")
    ap.add_argument("--corrected", action="store_true",
                    help="only the iterates IPOPT corrected (and the last)")
    ap.add_argument("--detail", action="store_true",
                    help="split the largest λ·∇²g groups by knot and by row label")
    args = ap.parse_args(argv)
    fields = _fields(args.option) if args.option else {}
    with tempfile.TemporaryDirectory() as tmp:
        log_path = Path(tmp) / "ipopt.log"
        planner, schedule, result = solve_logged(args.robot, args.speed, args.gait,
                                                 args.knots, fields, log_path, args.random,
                                                 args.plain)
        with log_path.open() as fh:
            log = parse_log(iter(fh))
    diag = Diagnosis(planner, schedule, args.speed, log, bool(result.stats["half_cycle"]))
    wanted = (sorted(log.iterates) if args.iters == "all"
              else [int(k) for k in args.iters.split(",")])
    if args.corrected:
        last = max(log.iterates)
        wanted = [k for k in wanted if len(log.delta_w.get(k, [])) > 1 or k == last]
    print("| k | δ_w tried | J_c zero rows | smallest σ(J_c) | lowest eigenvalues of ZᵀAZ |")
    print("|---|---|---|---|---|")
    for k in wanted:
        mats = diag.matrices(k)
        ev, vecs, smin = diag.lowest(mats)
        zero = int((np.abs(mats["Jc"]).max(axis=1) == 0).sum())
        print(f"| {k} | {log.delta_w.get(k)} | {zero} | "
              + ", ".join(f"{s:.1e}" for s in smin) + " | "
              + ", ".join(f"{e:+.2e}" for e in ev[:4]) + " |", flush=True)
        for i in [i for i in range(len(ev)) if ev[i] < 0] or [0]:
            vf = vecs[:, i]
            report: dict[str, Any] = {
                "k": k, "eigenvalue": float(ev[i]),
                "curvature": diag.curvature(mats, vf),
                "cost terms": diag.cost_terms(k, vf),
                "blocks": diag.blocks(vf),
                "largest entries": [(str(diag.x_labels[diag.free][j]), float(vf[j]))
                                    for j in np.argsort(-np.abs(vf))[:12]],
            }
            if args.detail:
                parts: dict[str, float] = report["curvature"]
                worst = sorted((val, key) for key, val in parts.items()
                               if key.startswith("λ ") and key != "λ foot height (sum)")[:3]
                for _, key in [*worst, (0.0, "λ foot height")]:
                    group = key.removeprefix("λ ")
                    for name, by in (("knot", lambda i: str(diag.label[i]).split("@knot ")[-1]),
                                     ("row", lambda i: str(diag.label[i]).split("@")[0])):
                        split = diag.curvature(mats, vf, by, group)
                        report[f"{group} by {name}"] = dict(
                            sorted(split.items(), key=lambda t: t[1])[:8])
            print(json.dumps(report, indent=1), flush=True)


if __name__ == "__main__":
    main()

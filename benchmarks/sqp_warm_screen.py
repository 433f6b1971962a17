"""Screen CasADi's `sqpmethod` (and an IPOPT-then-SQP two-phase solve) for warm solves (#16).

    python benchmarks/sqp_warm_screen.py --robot quad12 --variants ipopt,qrqp:reg,qpoases:reg
    python benchmarks/sqp_warm_screen.py --robot quad12 --schedule 0 --timeout 60 ...

One warm solve of the symmetric warm chain (`planner_bench.symmetric_perturbed`, schedule
`--schedule` of seed `--seed`), from the template's optimum, on the half-cycle NLP
(`planner.nlp.half_cycle`, the default warm path since session 41), compared with today's warm
IPOPT solve and the cold IPOPT solve of the same schedule (same verdict and a cost within
`SAME_COST_RTOL` relative). Every SQP variant runs in its own process under a wall-clock cap
(`--timeout`; the first QP can take minutes): the process builds the default planner, solves the
template cold, then solves the chain schedule warm with the reduced NLP's warm IPOPT instance
replaced by the variant's solver (`GaitPlanner._half_solver`), judged on the full NLP as every
solve is. The SQP gets the reduced NLP's own assembled Jacobian and Hessian.

A variant is ``[ipoptK+]QP[@key=value...][:HESS]``:
- QP: a CasADi conic plugin with options (`QPS`: ``qrqp``, ``qpoases`` dense,
  ``qpoases-sparse``, ``qpoases-schur`` with MA27 / ``-mumps`` / ``-ldl``, ``daqp``,
  ``proxqp``, ``osqp``, ``highs``, ``hpipm``, ``fatrop``, ``ipqp``, ``nlpsol-ipopt``), or
  ``blocksqp`` (CasADi's blockSQP instead of sqpmethod: its quasi-Newton Hessian, HESS unused,
  ``@`` options its own), or ``ipopt`` alone (today's warm solve);
- ``@key=value`` after QP (repeatable): more options of the QP plugin (qpOASES' say);
- HESS: ``exact`` (no convexification), ``reg`` (``convexify_strategy regularize``),
  ``clip`` (``eigen-clip``), ``reflect`` (``eigen-reflect``), ``lbfgs``
  (``hessian_approximation limited-memory``); default ``reg``;
- ``ipoptK+``: IPOPT's warm solve capped at K iterations first, then the SQP from its primal
  and dual point (a two-phase warm solve).
Prints per variant the iterations, process CPU of the solve, seconds to the SQP's first
iterate (an iteration callback), the status and cost against IPOPT's warm and cold solves.
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
# the dense QPs call BLAS: one thread, as every timing here (OpenBLAS and MKL read their own)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")

import casadi as ca
import numpy as np

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.half_cycle import HalfCycleNLP
from planner.nlp.iteration_abort import IterationCallback
from planner.nlp.spacetime import GaitPlanner, PlanResult, ipopt_options
from planner.templates import make_schedule, mirror_permutation

sys.path.insert(0, str(Path(__file__).resolve().parent))
from planner_bench import (
    SAME_COST_RTOL,
    add_chain_arguments,
    chain_defaults,
    symmetric_perturbed,
)

HESSIANS: dict[str, dict[str, Any]] = {
    "exact": {"hessian_approximation": "exact"},
    "reg": {"hessian_approximation": "exact", "convexify_strategy": "regularize"},
    "clip": {"hessian_approximation": "exact", "convexify_strategy": "eigen-clip"},
    "reflect": {"hessian_approximation": "exact", "convexify_strategy": "eigen-reflect"},
    "lbfgs": {"hessian_approximation": "limited-memory"},
}
#: per QP plugin: (conic plugin, its options)
QPS: dict[str, tuple[str, dict[str, Any]]] = {
    "qrqp": ("qrqp", {"print_iter": False, "print_header": False, "print_info": False}),
    "qpoases": ("qpoases", {"printLevel": "none"}),
    "qpoases-sparse": ("qpoases", {"printLevel": "none", "sparse": True}),
    # the Schur-complement method: its default sparse solver is HSL's MA27 (not in the wheel)
    "qpoases-schur": ("qpoases", {"printLevel": "none", "sparse": True, "schur": True}),
    "qpoases-schur-mumps": ("qpoases", {"printLevel": "none", "sparse": True, "schur": True,
                                        "linsol_plugin": "mumps"}),
    "qpoases-schur-ldl": ("qpoases", {"printLevel": "none", "sparse": True, "schur": True,
                                      "linsol_plugin": "ldl"}),
    # the same with qpOASES' equality handling, or its Hessian regularisation, or both
    "qpoases-schur-ldl-eq": ("qpoases", {"printLevel": "low", "sparse": True, "schur": True,
                                         "linsol_plugin": "ldl", "enableEqualities": True}),
    "qpoases-schur-ldl-regu": ("qpoases", {"printLevel": "low", "sparse": True, "schur": True,
                                           "linsol_plugin": "ldl",
                                           "enableRegularisation": True}),
    "qpoases-schur-ldl-both": ("qpoases", {"printLevel": "low", "sparse": True, "schur": True,
                                           "linsol_plugin": "ldl", "enableEqualities": True,
                                           "enableRegularisation": True}),
    "daqp": ("daqp", {}),
    "proxqp": ("proxqp", {"proxqp": {"backend": "sparse"}, "warm_start_primal": True,
                          "warm_start_dual": True}),
    "osqp": ("osqp", {"osqp": {"verbose": False}, "warm_start_primal": True,
                      "warm_start_dual": True}),
    "highs": ("highs", {}),
    "hpipm": ("hpipm", {}),
    # CasADi's own interior-point QP (sparse LDL), and a QP handed to IPOPT (MUMPS)
    "ipqp": ("ipqp", {"print_iter": False, "print_header": False, "print_info": False}),
    "nlpsol-ipopt": ("nlpsol", {"nlpsol": "ipopt", "nlpsol_options": {
        "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False}}),
    # the same with the planner's warm IPOPT options (METIS ordering, μ₀ 1e-3, the pushes; the
    # QP's constant derivatives declared): `sqp_solver` fills them in
    "nlpsol-ipopt-tuned": ("nlpsol", {"nlpsol": "ipopt"}),
    # "tuned" started hot: the QP's IPOPT from sqpmethod's multipliers with μ₀ 1e-6, monotone μ
    # and pushes 1e-8 (near the optimum the working set hardly changes)
    "nlpsol-ipopt-hot": ("nlpsol", {"nlpsol": "ipopt"}),
    "fatrop": ("fatrop", {"structure_detection": "auto"}),
}


@dataclass(frozen=True)
class Variant:
    name: str
    qp: str  # a QPS key or "ipopt"
    hessian: str
    ipopt_first: int  # 0: no IPOPT phase
    qp_extra: tuple[tuple[str, Any], ...] = ()  # more of the QP plugin's options

    @classmethod
    def parse(cls, name: str) -> Variant:
        first = 0
        rest = name
        if rest.startswith("ipopt") and "+" in rest:
            head, rest = rest.split("+", 1)
            first = int(head[len("ipopt"):])
        qp, _, hess = rest.partition(":")
        qp, *extra_items = qp.split("@")
        extra = []
        for item in extra_items:
            key, _, value = item.partition("=")
            try:
                extra.append((key, ast.literal_eval(value)))
            except (ValueError, SyntaxError):
                extra.append((key, value))
        hess = hess or "reg"
        if qp not in ("ipopt", "blocksqp") and qp not in QPS:
            raise SystemExit(f"variant {name!r}: QP {qp!r} is not one of {', '.join(QPS)}")
        if hess not in HESSIANS:
            raise SystemExit(f"variant {name!r}: Hessian {hess!r} is not one of "
                             f"{', '.join(HESSIANS)}")
        return cls(name, qp, hess, first, tuple(extra))


#: the process CPU at the start of the measured solve (`FirstIterate`'s log is relative to it)
callback_t0 = [0.0]


class FirstIterate(IterationCallback):
    """An iteration callback recording the process CPU and wall time of every iterate."""

    def __init__(self, nx: int, ng: int, np_: int) -> None:
        self.cpu: list[float] = []
        self.wall: list[float] = []
        super().__init__("sqp_iterates", nx, ng, np_)

    def at_iterate(self, values: dict[str, np.ndarray]) -> bool:
        self.cpu.append(time.process_time())
        self.wall.append(time.perf_counter())
        print(f"      iterate {len(self.cpu) - 1} at solve CPU "
              f"{self.cpu[-1] - callback_t0[0]:.1f} s", file=sys.stderr, flush=True)
        return False


def sqp_solver(half: HalfCycleNLP, v: Variant, tol: float, callback: FirstIterate | None
               ) -> Any:
    """`sqpmethod` on the reduced NLP with its assembled derivatives (`jac_fg` from its f and
    its ``jac_g``, ``hess_lag`` its triangle made symmetric)."""
    assert half.nlp is not None and half.solver_options is not None
    nlp = half.nlp
    if v.qp == "blocksqp":  # its own SQP: blockwise quasi-Newton, qpOASES' Schur method
        return ca.nlpsol("spacetime_half_blocksqp", "blocksqp", nlp, {
            "linsol": "ldl", "max_iter": 100, "opttol": tol, "nlinfeastol": tol,
            "print_header": False, "print_time": False, "error_on_fail": False,
            **({"iteration_callback": callback} if callback is not None else {}),
            **dict(v.qp_extra)})
    x, p = nlp["x"], nlp["p"]
    jac_g = half.solver_options.get("jac_g")
    hess_tri = half.solver_options.get("hess_lag")
    f = nlp["f"]
    grad_f = ca.gradient(f, x)
    if jac_g is not None:
        g, jg = jac_g(x, p)
    else:
        g, jg = nlp["g"], ca.jacobian(nlp["g"], x)
    jac_fg = ca.Function("nlp_jac_fg", [x, p], [f, grad_f, g, jg], ["x", "p"],
                         ["f", "grad_f_x", "g", "jac_g_x"])
    qp_options = {**QPS[v.qp][1], **dict(v.qp_extra), "error_on_fail": False}
    if v.qp in ("nlpsol-ipopt-tuned", "nlpsol-ipopt-hot"):
        ipopt = {**ipopt_options(PlannerOptions(), True), "print_level": 0, "sb": "yes",
                 "hessian_constant": "yes", "jac_c_constant": "yes", "jac_d_constant": "yes"}
        if v.qp == "nlpsol-ipopt-hot":
            ipopt.update({"mu_init": 1e-6, "mu_strategy": "monotone",
                          **{k: 1e-8 for k in ("warm_start_bound_push",
                                               "warm_start_slack_bound_push",
                                               "warm_start_mult_bound_push")}})
        qp_options["nlpsol_options"] = {"print_time": False,
                                        **{f"ipopt.{k}": val for k, val in ipopt.items()}}
    opts: dict[str, Any] = {
        **HESSIANS[v.hessian],
        "jac_fg": jac_fg,
        "qpsol": QPS[v.qp][0],
        "qpsol_options": qp_options,
        "max_iter": 100,
        "tol_pr": tol,
        "tol_du": tol,
        "print_header": False,
        "print_iteration": True,
        "print_time": False,
        "error_on_fail": False,
    }
    if hess_tri is not None and v.hessian != "lbfgs":
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", nlp["g"].shape[0])
        h = ca.triu2symm(hess_tri(x, p, lam_f, lam_g))
        opts["hess_lag"] = ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [h],
                                       ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])
    if callback is not None:
        opts["iteration_callback"] = callback
    return ca.nlpsol("spacetime_half_sqp", "sqpmethod", nlp, opts)


class SafeStats:
    """A CasADi solver whose `stats` survive sqpmethod's failure to name its return status
    (eigen-clip runs: "basic_string: construction from null")"""

    def __init__(self, solver: Any) -> None:
        self.solver = solver

    def __call__(self, **kw: Any) -> Any:
        return self.solver(**kw)

    def stats(self) -> dict[str, Any]:
        try:
            return dict(self.solver.stats())
        except RuntimeError as exc:
            return {"return_status": f"stats failed: {str(exc).splitlines()[-1][:80]}",
                    "iter_count": -1}


class TwoPhase:
    """IPOPT capped at `first` iterations, then `sqp` from its primal and dual point; called
    and queried (`stats`) as a CasADi solver."""

    def __init__(self, ipopt: Any, sqp: Any) -> None:
        self.ipopt, self.sqp = ipopt, sqp
        self._stats: dict[str, Any] = {}

    def __call__(self, **kw: Any) -> dict[str, Any]:
        first = self.ipopt(**kw)
        s1 = dict(self.ipopt.stats())
        out = self.sqp(**{**kw, "x0": first["x"], "lam_x0": first["lam_x"],
                          "lam_g0": first["lam_g"]})
        s2 = SafeStats(self.sqp).stats()
        self._stats = {**s2, "iter_count": int(s1.get("iter_count", 0))
                       + int(s2.get("iter_count", 0)),
                       "ipopt_iterations": int(s1.get("iter_count", 0)),
                       "iterations": s1.get("iterations")}
        return dict(out)

    def stats(self) -> dict[str, Any]:
        return self._stats


def chain_schedule(robot: robots.Robot, gait: str, seed: int, index: int
                   ) -> robots.ContactSchedule:
    """Schedule `index` of `planner_bench.warm_chain`'s symmetric chain of seed `seed`."""
    rng = np.random.default_rng(seed + 1)
    image = mirror_permutation(robot)
    assert image is not None
    base = make_schedule(robot, gait)
    return [symmetric_perturbed(base, image, rng) for _ in range(index + 1)][index]


def planner_options(spec: str) -> PlannerOptions:
    """`PlannerOptions` from ``name=value;…`` (values as Python literals, else strings)."""
    kw: dict[str, Any] = {}
    for item in filter(None, spec.split(";")):
        key, _, value = item.partition("=")
        try:
            kw[key.strip()] = ast.literal_eval(value.strip())
        except (ValueError, SyntaxError):
            kw[key.strip()] = value.strip()
    return PlannerOptions(**kw)


def run_one(args: argparse.Namespace, v: Variant) -> dict[str, Any]:
    """The variant's warm solve in this process (module docstring)."""
    robot = robots.load(args.robot)
    planner = GaitPlanner(robot, args.knots, planner_options(args.options))
    base = make_schedule(robot, args.gait)
    base_res = planner.solve(base, args.speed, warm_start=False)
    schedule = chain_schedule(robot, args.gait, args.seed, args.schedule)
    out: dict[str, Any] = {"variant": v.name}
    if v.qp != "ipopt":
        half = planner._half_cycle
        assert isinstance(half, HalfCycleNLP), "the template was not solved on the half cycle"
        t0 = time.process_time()
        callback = FirstIterate(half.mirror.n_reduced, int(half.rows.keep.size),
                                int(half.nlp["p"].numel()) if half.nlp else 0)
        sqp = sqp_solver(half, v, planner.options.tol, callback)
        solver: Any = SafeStats(sqp)
        if v.ipopt_first:
            assert half.nlp is not None and half.solver_options is not None
            capped = {**ipopt_options(planner.options, True), "max_iter": v.ipopt_first}
            ipopt = ca.nlpsol("spacetime_half_phase1", "ipopt", half.nlp,
                              {**half.solver_options, "ipopt": capped})
            solver = TwoPhase(ipopt, sqp)
        out["create_cpu_s"] = time.process_time() - t0
        planner._half_solver = lambda h, warm: solver if warm else h.solver  # type: ignore
    if v.qp != "ipopt":  # SIGALRM's default action ends this process, even inside a QP
        signal.alarm(max(1, int(args.timeout)))
    t0 = time.process_time()
    callback_t0[0] = t0
    t_wall = time.perf_counter()
    res: PlanResult = planner.solve(schedule, args.speed, warm_start=base_res.warm_start)
    cpu = time.process_time() - t0
    signal.alarm(0)
    out.update(iterations=res.iterations, cpu_s=cpu, wall_s=time.perf_counter() - t_wall,
               status=res.status, feasible=res.feasible, cost=res.cost,
               max_violation=res.max_violation, half=bool(res.stats.get("half_cycle")))
    if v.qp != "ipopt":
        # the callback's first call is the start (iterate 0), its second the first SQP step
        out["first_iterate_cpu_s"] = (callback.cpu[1] - t0) if len(callback.cpu) > 1 else None
        out["ipopt_iterations"] = solver.stats().get("ipopt_iterations", 0)
    if v.qp == "ipopt":  # the cold reference of the same schedule
        t0 = time.process_time()
        cold = planner.solve(schedule, args.speed, warm_start=False)
        out["cold"] = {"iterations": cold.iterations, "cpu_s": time.process_time() - t0,
                       "feasible": cold.feasible, "cost": cold.cost, "status": cold.status}
    return out


def equality_rank(args: argparse.Namespace) -> None:
    """The rank of the reduced NLP's equality rows' Jacobian (rows with lbg = ubg, and the
    fixed variables) at the warm start and at IPOPT's warm optimum, and the groups whose rows
    are dependent (greedy: a row that adds no rank to the rows before it)."""
    robot = robots.load(args.robot)
    planner = GaitPlanner(robot, args.knots, planner_options(args.options))
    base = make_schedule(robot, args.gait)
    base_res = planner.solve(base, args.speed, warm_start=False)
    schedule = chain_schedule(robot, args.gait, args.seed, args.schedule)
    res = planner.solve(schedule, args.speed, warm_start=base_res.warm_start)
    half = planner._half_cycle
    assert isinstance(half, HalfCycleNLP) and half.solver_options is not None
    p = planner._solver_parameters(schedule, args.speed)
    bounds = planner._solve_bounds(schedule)
    keep = half.rows.keep
    eq = np.flatnonzero(bounds.lbg[keep] == bounds.ubg[keep])
    free_x = np.flatnonzero(bounds.lbx[half.mirror.half] != bounds.ubx[half.mirror.half])
    group_of = np.empty(bounds.lbg.size, dtype=object)
    for name, sl in planner._slices:
        group_of[sl] = name
    for label, x in (("warm start", base_res.warm_start.x), ("IPOPT warm optimum",
                                                             res.warm_start.x)):
        _, jac = half.solver_options["jac_g"](x[half.mirror.half], p)
        a = np.asarray(ca.densify(ca.DM(jac)))[eq][:, free_x]
        rank = np.linalg.matrix_rank(a, tol=1e-9 * max(1.0, float(np.abs(a).max())))
        print(f"  {label}: {eq.size} equality rows over {free_x.size} free variables, rank "
              f"{rank} ({eq.size - rank} dependent)")
        if rank < eq.size:
            r = np.linalg.qr(a.T, mode="r")
            d = np.abs(np.diag(r))
            dep = eq[d <= 1e-9 * max(1.0, float(d.max()))]
            names: dict[str, int] = {}
            for row in keep[dep]:
                names[str(group_of[row])] = names.get(str(group_of[row]), 0) + 1
            print("    rows adding no rank (QR, in row order): "
                  + ", ".join(f"{k} {n}" for k, n in names.items()))


def stagewise_run(args: argparse.Namespace, solver_name: str, hessian: str) -> None:
    """The stage-wise NLP (`planner.nlp.stagewise`, FATROP's form: the wrap-around carried as
    a state, no normal-force rate rows) solved warm — from IPOPT's optimum of the template on
    it, onto the chain schedule — by IPOPT and by `sqpmethod` with a QP given the stage
    structure (``hpipm``, ``fatrop``); the full NLP (the stage-wise form has no half cycle).
    Prints iterations, CPU, the first SQP iterate's CPU and the cost against IPOPT's."""
    from planner.nlp.model import RobotModel
    from planner.nlp.stagewise import build_stagewise, stage_bounds
    from planner.nlp.variables import Layout, initial_guess, parameter_vector, variable_bounds

    robot = robots.load(args.robot)
    options = PlannerOptions(normal_force_rate_weights_per_t0=None, compact_rows=(),
                             derivatives="expanded", nlp_jacobian="ad", servo_goal_form="direct")
    model = RobotModel(robot)
    layout = Layout.of(model, args.knots)
    t0 = time.process_time()
    sw = build_stagewise(model, args.knots, options, layout)
    lbx, ubx = stage_bounds(sw, *variable_bounds(layout, model, options))
    nlp = {"x": sw.w, "p": sw.p, "f": sw.f, "g": sw.g}
    ipopt_common = {"expand": True, "print_time": False, "error_on_fail": False}
    cold_ipopt = ca.nlpsol("sw_cold", "ipopt", nlp,
                           {**ipopt_common, "ipopt": ipopt_options(options, False)})
    warm_ipopt = ca.nlpsol("sw_warm", "ipopt", nlp,
                           {**ipopt_common, "ipopt": ipopt_options(options, True)})
    print(f"  stage-wise NLP: {sw.size} variables, {sw.lbg.size} rows, nx {sw.nx[0]}, nu "
          f"{sw.nu[0]}; built with 2 IPOPT instances in CPU {time.process_time() - t0:.1f} s",
          flush=True)
    clear = options.swing_clearance_for(robot.leg_length_m)
    base = make_schedule(robot, args.gait)
    p0 = parameter_vector(base, args.knots, args.speed, clear)
    w0 = np.asarray(sw.to_stage(initial_guess(layout, model, base), p0)).ravel()
    bounds = {"lbx": lbx, "ubx": ubx, "lbg": sw.lbg, "ubg": sw.ubg}
    t0 = time.process_time()
    tmpl = cold_ipopt(x0=w0, p=p0, **bounds)
    print(f"  template cold IPOPT: {cold_ipopt.stats()['iter_count']} it, CPU "
          f"{time.process_time() - t0:.2f} s, {cold_ipopt.stats()['return_status']}, cost "
          f"{float(tmpl['f']):.6g}", flush=True)
    schedule = chain_schedule(robot, args.gait, args.seed, args.schedule)
    p1 = parameter_vector(schedule, args.knots, args.speed, clear)
    # the planner's warm start: the previous optimum's primal point (its copies consistent)
    x_prev = np.asarray(tmpl["x"]).ravel()[sw.from_planner_index]
    w1 = np.asarray(sw.to_stage(x_prev, p1)).ravel()

    def worst(sol: Any) -> float:
        g = np.asarray(sol["g"]).ravel()
        x = np.asarray(sol["x"]).ravel()
        return float(max(np.max(np.maximum(sw.lbg - g, g - sw.ubg)),
                         np.max(np.maximum(lbx - x, x - ubx))))

    t0 = time.process_time()
    ref = warm_ipopt(x0=w1, p=p1, **bounds)
    ref_cpu = time.process_time() - t0
    print(f"  warm IPOPT: {warm_ipopt.stats()['iter_count']} it, CPU {ref_cpu:.2f} s, "
          f"{warm_ipopt.stats()['return_status']}, cost {float(ref['f']):.6g}, worst row "
          f"{worst(ref):.1e}", flush=True)
    if solver_name == "ipopt":
        return
    structure = {"N": sw.n_knots, "nx": list(sw.nx), "nu": list(sw.nu), "ng": list(sw.ng)}
    qp_options: dict[str, Any] = dict(structure)
    if solver_name == "fatrop":
        qp_options["structure_detection"] = "manual"
    callback = FirstIterate(sw.size, int(sw.lbg.size), int(sw.p.numel()))
    t0 = time.process_time()
    sqp = ca.nlpsol("sw_sqp", "sqpmethod", nlp, {
        **HESSIANS[hessian], "expand": True, "qpsol": solver_name,
        "qpsol_options": {**qp_options, "error_on_fail": False}, "max_iter": 100,
        "tol_pr": options.tol, "tol_du": options.tol, "print_header": False,
        "print_iteration": True, "print_time": False, "error_on_fail": False,
        "iteration_callback": callback})
    print(f"  sqpmethod + {solver_name} ({hessian}) created in CPU "
          f"{time.process_time() - t0:.1f} s", flush=True)
    signal.alarm(max(1, int(args.timeout)))
    t0 = time.process_time()
    callback_t0[0] = t0
    sol = sqp(x0=w1, p=p1, **bounds)
    cpu = time.process_time() - t0
    signal.alarm(0)
    st = sqp.stats()
    rel = (float(sol["f"]) - float(ref["f"])) / max(abs(float(ref["f"])), 1e-12)
    first = callback.cpu[1] - t0 if len(callback.cpu) > 1 else float("nan")
    print(f"  sqpmethod + {solver_name} ({hessian}): {st['iter_count']} it, CPU {cpu:.2f} s "
          f"(/warm IPOPT {cpu / ref_cpu:.2f}), first SQP step at CPU {first:.2f} s, "
          f"{st['return_status']}, cost {float(sol['f']):.6g} rel {rel:+.1e}, worst row "
          f"{worst(sol):.1e}", flush=True)


def qp_probe(n: int = 300, n_eq: int = 100, n_ineq: int = 200, seed: int = 0) -> None:
    """qpOASES' Schur-complement method with each linear solver CasADi offers it, against dense
    and sparse (no Schur) qpOASES, on one random strictly convex sparse QP (`n` variables,
    `n_eq` equality and `n_ineq` one-sided rows of 6 entries each, boxes ±10): is it the
    planner's QP or the plugin that fails?"""
    rng = np.random.default_rng(seed)
    a = np.zeros((n_eq + n_ineq, n))
    for row in range(a.shape[0]):
        a[row, rng.choice(n, 6, replace=False)] = rng.standard_normal(6)
    m = rng.standard_normal((n, n)) * (rng.random((n, n)) < 0.02)
    h = ca.DM(m @ m.T + 1e-2 * np.eye(n))
    a_dm = ca.sparsify(ca.DM(a))
    g = rng.standard_normal(n)
    lba = np.r_[np.zeros(n_eq), -np.ones(n_ineq)]
    uba = np.r_[np.zeros(n_eq), np.full(n_ineq, np.inf)]
    cases: list[tuple[str, dict[str, Any]]] = [("dense", {}), ("sparse", {"sparse": True})]
    cases += [(f"schur + {ls}", {"sparse": True, "schur": True, "linsol_plugin": ls})
              for ls in ("ldl", "qr", "csparse", "mumps", "ma27")]
    print(f"random convex QP: {n} variables, {n_eq} equalities, {n_ineq} inequalities")
    for label, extra in cases:
        try:
            qp = ca.conic("probe", "qpoases", {"h": h.sparsity(), "a": a_dm.sparsity()},
                          {"printLevel": "none", "error_on_fail": False, **extra})
            t0 = time.process_time()
            qp(h=h, g=g, a=a_dm, lba=lba, uba=uba, lbx=-10, ubx=10)
            st = qp.stats()
            outcome = "solved" if st.get("success") else str(st.get("return_status"))
            print(f"  qpOASES {label}: {outcome}, CPU {time.process_time() - t0:.3f} s")
        except RuntimeError as exc:
            print(f"  qpOASES {label}: error: {str(exc).strip().splitlines()[-1][-90:]}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_chain_arguments(ap)
    ap.add_argument("--schedule", type=int, default=0, help="which schedule of the chain")
    ap.add_argument("--variants", default="qrqp:reg")
    ap.add_argument("--timeout", type=float, default=60.0, help="wall seconds per SQP variant")
    ap.add_argument("--options", default="",
                    help="PlannerOptions for every process, e.g. 'inactive_rows=free'")
    ap.add_argument("--stagewise", default=None, metavar="QP[:HESS]",
                    help="the stage-wise NLP instead: IPOPT's warm solve and sqpmethod with "
                    "QP (hpipm, fatrop; ipopt: IPOPT alone), in this process (`stagewise_run`)")
    ap.add_argument("--qp-probe", action="store_true",
                    help="qpOASES' Schur method on a random convex QP (`qp_probe`) and stop")
    ap.add_argument("--rank", action="store_true",
                    help="print the rank of the reduced NLP's equality Jacobian and stop")
    ap.add_argument("--one", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    chain_defaults(args)
    if args.qp_probe:
        qp_probe()
        return
    if args.stagewise:
        name, _, hess = args.stagewise.partition(":")
        stagewise_run(args, name, hess or "reg")
        return
    if args.rank:
        equality_rank(args)
        return
    if args.one is not None:
        print("RESULT " + json.dumps(run_one(args, Variant.parse(args.one))), flush=True)
        return
    variants = [Variant.parse(v) for v in args.variants.split(",") if v]
    print(f"{args.robot} {args.gait} {args.speed} m/s N={args.knots}, symmetric chain seed "
          f"{args.seed} schedule {args.schedule}, options {args.options or 'default'}; "
          f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, "
          f"load {os.getloadavg()[0]:.2f}", flush=True)
    env = dict(os.environ)
    tmp = None
    if "GAITSMITH_CACHE" not in env:  # an empty cache: SX knot derivatives (as session 41)
        tmp = tempfile.TemporaryDirectory(prefix="sqp_warm_screen_")
        env["GAITSMITH_CACHE"] = tmp.name
    common = [sys.executable, __file__, "--robot", args.robot, "--gait", args.gait, "--speed",
              str(args.speed), "--knots", str(args.knots), "--seed", str(args.seed),
              "--schedule", str(args.schedule), "--options", args.options,
              "--timeout", str(args.timeout)]
    ref: dict[str, Any] | None = None
    for v in ["ipopt", *[x.name for x in variants if x.name != "ipopt"]]:
        t0 = time.perf_counter()
        # the reference runs uncapped (it also fills the derivative cache)
        proc = subprocess.run([*common, "--one", v], capture_output=True, text=True, env=env,
                              check=False)
        if proc.returncode == -signal.SIGALRM:
            seen = [s.strip() for s in proc.stderr.splitlines() if "iterate" in s]
            print(f"  {v}: no result within the {args.timeout:.0f} s wall cap of the solve "
                  f"({time.perf_counter() - t0:.0f} s with the build and template); SQP "
                  f"iterates (0 = the start): {len(seen)}{' (' + seen[-1] + ')' if seen else ''}"
                  f"; load {os.getloadavg()[0]:.2f}", flush=True)
            continue
        line = next((s for s in proc.stdout.splitlines() if s.startswith("RESULT ")), None)
        if line is None:
            print(f"  {v}: failed (exit {proc.returncode}): {proc.stderr.strip()[-600:]}",
                  flush=True)
            continue
        r = json.loads(line[len("RESULT "):])
        if v == "ipopt":
            ref = r
            c = r["cold"]
            print(f"  cold IPOPT: {c['iterations']} it, CPU {c['cpu_s']:.2f} s, cost "
                  f"{c['cost']:.6g}{'' if c['feasible'] else ' INFEASIBLE ' + c['status']}")
        assert ref is not None
        rel_w = (r["cost"] - ref["cost"]) / max(abs(ref["cost"]), 1e-12)
        rel_c = (r["cost"] - ref["cold"]["cost"]) / max(abs(ref["cold"]["cost"]), 1e-12)
        same = r["feasible"] == ref["cold"]["feasible"] and rel_c <= SAME_COST_RTOL
        first = r.get("first_iterate_cpu_s")
        phase1 = r.get("ipopt_iterations")
        step = f"first SQP step done at CPU {first:.2f} s, " if first is not None else ""
        print(f"  {v}: {r['iterations']} it{f' ({phase1} IPOPT)' if phase1 else ''}"
              f", CPU {r['cpu_s']:.2f} s (/IPOPT warm {r['cpu_s'] / ref['cpu_s']:.2f}), "
              f"{step}"
              f"{r['status']}, {'feasible' if r['feasible'] else 'INFEASIBLE'} (worst "
              f"{r['max_violation']:.1e}), cost {r['cost']:.6g} rel warm {rel_w:+.1e} cold "
              f"{rel_c:+.1e}, {'same optimum' if same else 'NOT the same optimum'}"
              f"{'' if r['half'] else ', full NLP'}; load {os.getloadavg()[0]:.2f}", flush=True)
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()

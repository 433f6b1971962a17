"""Basin-CMA benchmark: CEC-2006 efficiency vs plain penalty CMA-ES, and executor speed-up.

Run:  python benchmarks/basin_cma_bench.py [--seeds 5] [--plain-budget 200000] [--workers 2]

Part 1 (W&P 2009 App. A style): per problem and seed, basin-CMA stops when within 1e-4
(relative) of the published optimum.  Printed: success rate, median local solves, median
evaluations with derivatives counted as one ("ratio1" convention) and as n ("fd", ratio2),
median wall time; plain penalty CMA-ES (``cma`` library, IPOP restarts) with a large budget:
success rate, median evaluations to reach 1e-4 (over successful seeds), and the ratios
plain/basin in both conventions (W&P's "fevals ratio1" and "ratio2").

Part 2: the same basin-CMA run (same seed → identical result) on a problem whose local solve
is costly (a hanging chain of many links draped over an obstacle, one IPOPT NLP with
hundreds of variables, built once per worker), serial vs ``ProcessExecutor``; wall time with
and without the pool start-up, and the ratio.
"""

from __future__ import annotations

import os

# One native thread per process, for the serial loop too, so serial vs pool compares like with
# like (and results are bitwise identical); must be set before CasADi loads its IPOPT plugin.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from typing import Any  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

from planner.search.basin_cma import LocalResult, basin_cma  # noqa: E402
from planner.search.cec2006 import PROBLEMS, CecLocalSolver, solve_basin_cma, solve_penalty_cma  # noqa: E402
from planner.search.executors import ProcessExecutor, SerialExecutor  # noqa: E402


def _median(xs: list[float]) -> float:
    return statistics.median(xs) if xs else math.nan


def bench_cec(seeds: int, plain_budget: int) -> None:
    print(f"CEC-2006, {seeds} seeds, target 1e-4 relative; plain CMA budget {plain_budget}")
    print(f"{'prob':5s} {'n':>3s} | {'basin ok':>8s} {'solves':>6s} {'fevals':>7s} "
          f"{'fev_fd':>7s} {'time_s':>7s} | {'plain ok':>8s} {'fevals':>8s} {'plain/fe':>8s} "
          f"{'plain/fd':>8s}")
    for name, p in PROBLEMS.items():
        ok = 0
        solves: list[float] = []
        fe: list[float] = []
        fd: list[float] = []
        ts: list[float] = []
        pok = 0
        pfe: list[float] = []
        for seed in range(1, seeds + 1):
            solver = CecLocalSolver(p)
            t0 = time.perf_counter()
            r = solve_basin_cma(p, seed=seed, solver=solver, max_local_solves=5000)
            ts.append(time.perf_counter() - t0)
            if r.feasible and r.cost <= p.target():
                ok += 1
                solves.append(r.n_local_solves)
                fe.append(r.n_fevals)
                fd.append(solver.n_f + p.dim * solver.n_grad)
            pr = solve_penalty_cma(p, max_fevals=plain_budget, seed=seed)
            if pr.fevals_to_target is not None:
                pok += 1
                pfe.append(pr.fevals_to_target)
        ratio1 = _median(pfe) / _median(fe) if pfe and fe else math.nan
        ratio2 = _median(pfe) / _median(fd) if pfe and fd else math.nan
        print(f"{name:5s} {p.dim:3d} | {ok:>4d}/{seeds:<3d} {_median(solves):6.0f} "
              f"{_median(fe):7.0f} {_median(fd):7.0f} {_median(ts):7.3f} | "
              f"{pok:>4d}/{seeds:<3d} {_median(pfe):8.0f} {ratio1:8.1f} {ratio2:8.1f}")


@dataclass(frozen=True)
class ChainFactory:
    """A hanging chain of ``links`` rigid links (total length 1.6) between (0, 0) and (1, 0),
    parametrised by its link angles (a kinematic chain, like a leg), draped around a disc
    obstacle: minimise potential energy Σ y_i s.t. the chain ends at (1, 0) and every joint
    stays outside the disc.  The dense forward kinematics make each IPOPT solve costly.  The
    basin-CMA variable is the initial guess of the middle joint (2-D); the projection is the
    solution's middle joint.  Two basins (chain left or right of the obstacle)."""

    links: int = 100

    def __call__(self) -> ChainSolver:
        return ChainSolver(self.links)


class ChainSolver:
    LENGTH = 1.6
    CENTER = (0.45, -0.45)
    RADIUS = 0.2

    def __init__(self, links: int) -> None:
        self.links = links
        th = ca.SX.sym("theta", links)
        seg = self.LENGTH / links
        px = ca.cumsum(seg * ca.cos(th))
        py = ca.cumsum(seg * ca.sin(th))
        cx, cy = self.CENTER
        g_obs = (px[:-1] - cx) ** 2 + (py[:-1] - cy) ** 2 - self.RADIUS**2
        opts: dict[str, Any] = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                                "ipopt.max_iter": 500, "show_eval_warnings": False}
        self._solver = ca.nlpsol("chain", "ipopt",
                                 {"x": th, "f": ca.sum1(py) / links,
                                  "g": ca.vertcat(px[-1] - 1.0, py[-1], g_obs)}, opts)
        self._pos = ca.Function("pos", [th], [px, py])
        self._lbg = [0.0, 0.0] + [0.0] * (links - 1)
        self._ubg = [0.0, 0.0] + [math.inf] * (links - 1)

    def __call__(self, mid: np.ndarray) -> LocalResult:
        k = self.links // 2
        a1 = math.atan2(mid[1], mid[0])
        a2 = math.atan2(-mid[1], 1.0 - mid[0])
        th0 = np.concatenate([np.full(k, a1), np.full(self.links - k, a2)])
        sol = self._solver(x0=th0, lbg=self._lbg, ubg=self._ubg)
        st = self._solver.stats()
        px, py = (np.asarray(v, dtype=float).reshape(-1) for v in self._pos(sol["x"]))
        y_mid = np.array([px[k - 1], py[k - 1]])
        fe = int(st.get("n_call_nlp_f", 0)) + int(st.get("n_call_nlp_grad_f", 0))
        return LocalResult(y_mid, float(sol["f"]), bool(st["success"]), fe)


def bench_executors(workers: int, links: int, generations: int, popsize: int) -> None:
    factory = ChainFactory(links)
    kw: dict[str, Any] = {"seed": 3, "max_generations": generations, "restarts": 0,
                          "popsize": popsize, "stall_generations": 10**6}
    x0, s0, bounds = [0.5, -0.8], [0.5, 0.5], ([0.0, -1.5], [1.0, 0.0])
    t0 = time.perf_counter()
    with SerialExecutor(factory) as ex:
        t_build = time.perf_counter() - t0
        ts = time.perf_counter()
        serial = basin_cma(ex.local_solve, x0, s0, bounds, executor=ex, **kw)
        t_serial = time.perf_counter() - ts
    t0 = time.perf_counter()
    with ProcessExecutor(factory, workers) as pex:
        pex.map(pex.local_solve, [np.array(x0)] * workers)     # start + build in every worker
        t_start = time.perf_counter() - t0
        tp = time.perf_counter()
        par = basin_cma(pex.local_solve, x0, s0, bounds, executor=pex, **kw)
        t_par = time.perf_counter() - tp
    assert np.array_equal(serial.x, par.x), "executors must not change the result"
    per = t_serial / serial.n_local_solves
    print(f"\nexecutors: hanging chain, {links} links ({links} NLP variables), "
          f"{serial.n_local_solves} local solves ({per * 1e3:.1f} ms each), {workers} workers")
    print(f"  NLP build (once per worker): {t_build:.3f} s; process pool start+build: "
          f"{t_start:.3f} s")
    print(f"  serial {t_serial:.2f} s | process {t_par:.2f} s (+{t_start:.2f} s start-up) | "
          f"speed-up {t_serial / t_par:.2f}x steady, {t_serial / (t_par + t_start):.2f}x "
          f"incl. start-up")
    print(f"  best energy {serial.cost:.6f} at mid {np.round(serial.x, 4)} (same in both)")
    load = os.getloadavg()[0]
    print(f"  machine: {os.cpu_count()} cores, 1-min load average {load:.2f} "
          f"(a speed-up below {workers}x under load > cores means the workers were starved)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--plain-budget", type=int, default=200_000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--links", type=int, default=100)
    ap.add_argument("--generations", type=int, default=4)
    ap.add_argument("--popsize", type=int, default=16)
    ap.add_argument("--skip-cec", action="store_true")
    a = ap.parse_args()
    if not a.skip_cec:
        bench_cec(a.seeds, a.plain_budget)
    bench_executors(a.workers, a.links, a.generations, a.popsize)


if __name__ == "__main__":
    main()

"""A subset of the CEC-2006 constrained benchmark, a local solver for basin-CMA, and baselines.

Problem definitions, bounds and best known optima are from J. J. Liang, T. P. Runarsson,
E. Mezura-Montes, M. Clerc, P. N. Suganthan, C. A. Coello Coello and K. Deb, "Problem
definitions and evaluation criteria for the CEC 2006 special session on constrained
real-parameter optimization", Technical Report, Nanyang Technological University, 2006
(§1, problems g01…g24).  W&P Appendix A reports basin-CMA on the same suite.

Conventions follow the report: inequalities ``g_i(x) <= 0``; equalities ``h_j(x) = 0`` are
relaxed to ``|h_j(x)| - 1e-4 <= 0`` (that is why g11's optimum is 0.7499, not 0.75).
Objective/constraint expressions are written once, generic over ``numpy`` and ``casadi``
(the ``m`` argument is the math namespace), so the IPOPT model and the numpy evaluator used by
the plain CMA-ES baseline cannot drift apart.

Feval accounting of :class:`CecLocalSolver` (W&P App. A, "fevals ratio1/ratio2"):
``"derivative_as_one"`` counts every objective/constraint evaluation and every derivative
evaluation (gradient + Jacobian) as one evaluation each; ``"finite_difference"`` counts a
derivative evaluation as ``n`` evaluations (forward differences).  IPOPT runs with a
limited-memory (L-BFGS) Hessian, so there are no Hessian evaluations to count — the
quasi-Newton set-up closest to the paper's SNOPT.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import casadi as ca
import numpy as np

from planner.search.basin_cma import (
    BasinCmaResult,
    FloatArray,
    LocalResult,
    PenaltyCmaResult,
    basin_cma,
    penalty_cma,
    sigma_from_bounds,
)

Expr = Any  # numpy float / ndarray element or casadi SX
Fn = Callable[[Any, Any], Expr]
Constraints = Callable[[Any, Any], Sequence[Expr]]

EQ_TOL = 1e-4      # CEC-2006 equality tolerance
FEAS_TOL = 1e-6    # our tolerance on the summed inequality violation when checking a point


@dataclass(frozen=True)
class CecProblem:
    """One CEC-2006 problem: minimise f(x) s.t. g(x) <= 0, |h(x)| <= 1e-4, lb <= x <= ub."""

    name: str
    lb: tuple[float, ...]
    ub: tuple[float, ...]
    f: Fn
    g: Constraints
    f_star: float                   # best known optimum (Liang et al. 2006, §1)
    x_star: tuple[float, ...]       # a best known solution (same source)
    h: Constraints = field(default=lambda x, m: [])

    @property
    def dim(self) -> int:
        return len(self.lb)

    def evaluate(self, x: FloatArray) -> tuple[float, float]:
        """``(f(x), violation(x))`` with ``violation = Σ max(0, g_i) + Σ max(0, |h_j| - 1e-4)``."""
        xa = np.asarray(x, dtype=float)
        fx = float(self.f(xa, np))
        viol = sum(max(0.0, float(gi)) for gi in self.g(xa, np))
        viol += sum(max(0.0, abs(float(hj)) - EQ_TOL) for hj in self.h(xa, np))
        return fx, viol

    def target(self, rel_tol: float = 1e-4) -> float:
        """Cost threshold for "reached the optimum": ``f* + rel_tol·max(1, |f*|)``."""
        return self.f_star + rel_tol * max(1.0, abs(self.f_star))


def _g01(x: Any, m: Any) -> list[Expr]:
    return [2 * x[0] + 2 * x[1] + x[9] + x[10] - 10, 2 * x[0] + 2 * x[2] + x[9] + x[11] - 10,
            2 * x[1] + 2 * x[2] + x[10] + x[11] - 10, -8 * x[0] + x[9], -8 * x[1] + x[10],
            -8 * x[2] + x[11], -2 * x[3] - x[4] + x[9], -2 * x[5] - x[6] + x[10],
            -2 * x[7] - x[8] + x[11]]


def _g04_terms(x: Any) -> tuple[Expr, Expr, Expr]:
    u = 85.334407 + 0.0056858 * x[1] * x[4] + 0.0006262 * x[0] * x[3] - 0.0022053 * x[2] * x[4]
    v = 80.51249 + 0.0071317 * x[1] * x[4] + 0.0029955 * x[0] * x[1] + 0.0021813 * x[2] ** 2
    w = 9.300961 + 0.0047026 * x[2] * x[4] + 0.0012547 * x[0] * x[2] + 0.0019085 * x[2] * x[3]
    return u, v, w


def _g04(x: Any, m: Any) -> list[Expr]:
    u, v, w = _g04_terms(x)
    return [u - 92, -u, v - 110, -v + 90, w - 25, -w + 20]


def _g07(x: Any, m: Any) -> list[Expr]:
    return [-105 + 4 * x[0] + 5 * x[1] - 3 * x[6] + 9 * x[7],
            10 * x[0] - 8 * x[1] - 17 * x[6] + 2 * x[7],
            -8 * x[0] + 2 * x[1] + 5 * x[8] - 2 * x[9] - 12,
            3 * (x[0] - 2) ** 2 + 4 * (x[1] - 3) ** 2 + 2 * x[2] ** 2 - 7 * x[3] - 120,
            5 * x[0] ** 2 + 8 * x[1] + (x[2] - 6) ** 2 - 2 * x[3] - 40,
            x[0] ** 2 + 2 * (x[1] - 2) ** 2 - 2 * x[0] * x[1] + 14 * x[4] - 6 * x[5],
            0.5 * (x[0] - 8) ** 2 + 2 * (x[1] - 4) ** 2 + 3 * x[4] ** 2 - x[5] - 30,
            -3 * x[0] + 6 * x[1] + 12 * (x[8] - 8) ** 2 - 7 * x[9]]


def _f07(x: Any, m: Any) -> Expr:
    return (x[0] ** 2 + x[1] ** 2 + x[0] * x[1] - 14 * x[0] - 16 * x[1] + (x[2] - 10) ** 2
            + 4 * (x[3] - 5) ** 2 + (x[4] - 3) ** 2 + 2 * (x[5] - 1) ** 2 + 5 * x[6] ** 2
            + 7 * (x[7] - 11) ** 2 + 2 * (x[8] - 10) ** 2 + (x[9] - 7) ** 2 + 45)


def _f09(x: Any, m: Any) -> Expr:
    return ((x[0] - 10) ** 2 + 5 * (x[1] - 12) ** 2 + x[2] ** 4 + 3 * (x[3] - 11) ** 2
            + 10 * x[4] ** 6 + 7 * x[5] ** 2 + x[6] ** 4 - 4 * x[5] * x[6] - 10 * x[5] - 8 * x[6])


def _g09(x: Any, m: Any) -> list[Expr]:
    return [-127 + 2 * x[0] ** 2 + 3 * x[1] ** 4 + x[2] + 4 * x[3] ** 2 + 5 * x[4],
            -282 + 7 * x[0] + 3 * x[1] + 10 * x[2] ** 2 + x[3] - x[4],
            -196 + 23 * x[0] + x[1] ** 2 + 6 * x[5] ** 2 - 8 * x[6],
            4 * x[0] ** 2 + x[1] ** 2 - 3 * x[0] * x[1] + 2 * x[2] ** 2 + 5 * x[5] - 11 * x[6]]


def _g10(x: Any, m: Any) -> list[Expr]:
    return [-1 + 0.0025 * (x[3] + x[5]), -1 + 0.0025 * (x[4] + x[6] - x[3]),
            -1 + 0.01 * (x[7] - x[4]),
            -x[0] * x[5] + 833.33252 * x[3] + 100 * x[0] - 83333.333,
            -x[1] * x[6] + 1250 * x[4] + x[1] * x[3] - 1250 * x[3],
            -x[2] * x[7] + 1250000 + x[2] * x[4] - 2500 * x[4]]


def _f24(x: Any, m: Any) -> Expr:
    return -x[0] - x[1]


def _g24(x: Any, m: Any) -> list[Expr]:
    return [-2 * x[0] ** 4 + 8 * x[0] ** 3 - 8 * x[0] ** 2 + x[1] - 2,
            -4 * x[0] ** 4 + 32 * x[0] ** 3 - 88 * x[0] ** 2 + 96 * x[0] + x[1] - 36]


PROBLEMS: dict[str, CecProblem] = {
    p.name: p for p in [
        CecProblem(
            "g01", (0.0,) * 9 + (0.0,) * 3 + (0.0,), (1.0,) * 9 + (100.0,) * 3 + (1.0,),
            lambda x, m: 5 * sum(x[i] for i in range(4)) - 5 * sum(x[i] ** 2 for i in range(4))
            - sum(x[i] for i in range(4, 13)),
            _g01, -15.0, (1.0,) * 9 + (3.0,) * 3 + (1.0,)),
        CecProblem(
            "g04", (78.0, 33.0, 27.0, 27.0, 27.0), (102.0, 45.0, 45.0, 45.0, 45.0),
            lambda x, m: 5.3578547 * x[2] ** 2 + 0.8356891 * x[0] * x[4] + 37.293239 * x[0]
            - 40792.141,
            _g04, -30665.538671783317,
            (78.0, 33.0, 29.9952560256815985, 45.0, 36.7758129057882073)),
        CecProblem(
            "g06", (13.0, 0.0), (100.0, 100.0),
            lambda x, m: (x[0] - 10) ** 3 + (x[1] - 20) ** 3,
            lambda x, m: [-(x[0] - 5) ** 2 - (x[1] - 5) ** 2 + 100,
                          (x[0] - 6) ** 2 + (x[1] - 5) ** 2 - 82.81],
            -6961.81387558015, (14.09500000000000064, 0.8429607892154795668)),
        CecProblem(
            "g07", (-10.0,) * 10, (10.0,) * 10, _f07, _g07, 24.30620906818,
            (2.17199634142692, 2.3636830416034, 8.77392573913157, 5.09598443745173,
             0.990654756560493, 1.43057392853463, 1.32164415364306, 9.82872576524495,
             8.2800915887356, 8.3759266477347)),
        CecProblem(
            "g08", (0.0, 0.0), (10.0, 10.0),
            lambda x, m: -(m.sin(2 * math.pi * x[0]) ** 3) * m.sin(2 * math.pi * x[1])
            / (x[0] ** 3 * (x[0] + x[1])),
            lambda x, m: [x[0] ** 2 - x[1] + 1, 1 - x[0] + (x[1] - 4) ** 2],
            -0.0958250414180359, (1.22797135260752599, 4.24537336612274885)),
        CecProblem(
            "g09", (-10.0,) * 7, (10.0,) * 7, _f09, _g09, 680.630057374402,
            (2.33049935147405174, 1.95137236847114592, -0.477541399510615805,
             4.36572624923625874, -0.624486959100388983, 1.03813099410962173,
             1.5942266780671519)),
        CecProblem(
            "g10", (100.0, 1000.0, 1000.0) + (10.0,) * 5, (10000.0,) * 3 + (1000.0,) * 5,
            lambda x, m: x[0] + x[1] + x[2], _g10, 7049.24802052867,
            (579.306685017979589, 1359.97067807935605, 5109.97065743133317,
             182.01769963061534, 295.601173702746792, 217.982300369384632,
             286.41652592786852, 395.601173702746735)),
        CecProblem(
            "g11", (-1.0, -1.0), (1.0, 1.0),
            lambda x, m: x[0] ** 2 + (x[1] - 1) ** 2,
            lambda x, m: [], 0.7499, (-0.707036070037170616, 0.500000004333606807),
            h=lambda x, m: [x[1] - x[0] ** 2]),
        CecProblem(
            "g24", (0.0, 0.0), (3.0, 4.0), _f24, _g24, -5.50801327159536,
            (2.32952019747762, 3.17849307411774)),
    ]
}


def get_problem(name: str) -> CecProblem:
    try:
        return PROBLEMS[name]
    except KeyError:
        raise KeyError(f"unknown CEC-2006 problem {name!r}; have {sorted(PROBLEMS)}") from None


FevalConvention = Literal["derivative_as_one", "finite_difference"]


class CecLocalSolver:
    """The projection ``g`` of W&P §4.1.1 for a CEC problem: IPOPT from a start point to a
    local constrained minimum.  The NLP is built once (in ``__init__``); each call only
    changes the initial guess.  Also counts evaluations cumulatively (``n_f``, ``n_grad``)."""

    def __init__(self, problem: CecProblem, *, convention: FevalConvention = "derivative_as_one",
                 max_iter: int = 300, tol: float = 1e-10) -> None:
        self.problem = problem
        self.convention = convention
        n = problem.dim
        x = ca.SX.sym("x", n)
        xs = [x[i] for i in range(n)]
        g = list(problem.g(xs, ca))
        h = list(problem.h(xs, ca))
        self._lbg = [-math.inf] * len(g) + [-EQ_TOL] * len(h)
        self._ubg = [0.0] * len(g) + [EQ_TOL] * len(h)
        opts: dict[str, Any] = {"print_time": False, "show_eval_warnings": False,
                "ipopt.print_level": 0, "ipopt.sb": "yes",
                "ipopt.hessian_approximation": "limited-memory", "ipopt.max_iter": max_iter,
                "ipopt.tol": tol, "ipopt.constr_viol_tol": 1e-9}
        nlp = {"x": x, "f": problem.f(xs, ca), "g": ca.vertcat(*(g + h))}
        self._solver = ca.nlpsol(f"cec_{problem.name}", "ipopt", nlp, opts)
        self.n_calls = self.n_f = self.n_grad = 0

    def fevals(self, n_f: int, n_grad: int) -> int:
        per_grad = 1 if self.convention == "derivative_as_one" else self.problem.dim
        return n_f + per_grad * n_grad

    def __call__(self, x0: FloatArray) -> LocalResult:
        p = self.problem
        sol = self._solver(x0=np.asarray(x0, dtype=float), lbx=p.lb, ubx=p.ub,
                           lbg=self._lbg, ubg=self._ubg)
        st = self._solver.stats()
        n_f = max(int(st.get("n_call_nlp_f", 0)), int(st.get("n_call_nlp_g", 0)))
        n_grad = max(int(st.get("n_call_nlp_grad_f", 0)), int(st.get("n_call_nlp_jac_g", 0)))
        self.n_calls += 1
        self.n_f += n_f
        self.n_grad += n_grad
        y = np.clip(np.asarray(sol["x"], dtype=float).reshape(-1), p.lb, p.ub)
        fy, viol = p.evaluate(y)
        feasible = viol <= FEAS_TOL and math.isfinite(fy)
        return LocalResult(y, fy, feasible, self.fevals(n_f, n_grad), viol)


@dataclass(frozen=True)
class CecSolverFactory:
    """Picklable factory for executors: builds a :class:`CecLocalSolver` in each worker."""

    name: str
    convention: FevalConvention = "derivative_as_one"

    def __call__(self) -> CecLocalSolver:
        return CecLocalSolver(get_problem(self.name), convention=self.convention)


def initial_search(problem: CecProblem) -> tuple[FloatArray, FloatArray]:
    """W&P §5 initialisation: mean at the box centre, per-coordinate std covering the box."""
    lb, ub = np.asarray(problem.lb), np.asarray(problem.ub)
    x0 = 0.5 * (lb + ub)
    return x0, sigma_from_bounds(x0, (lb, ub))


def solve_basin_cma(problem: CecProblem, *, seed: int = 1, rel_tol: float = 1e-4,
                    solver: CecLocalSolver | None = None, **kwargs: Any) -> BasinCmaResult:
    """Basin-CMA on a CEC problem, stopping once within ``rel_tol`` of the known optimum."""
    g = solver if solver is not None else CecLocalSolver(problem)
    x0, s0 = initial_search(problem)
    kwargs.setdefault("target_cost", problem.target(rel_tol))
    return basin_cma(g, x0, s0, (problem.lb, problem.ub), seed=seed, **kwargs)


def solve_penalty_cma(problem: CecProblem, *, max_fevals: int, seed: int = 1,
                      rel_tol: float = 1e-4, **kwargs: Any) -> PenaltyCmaResult:
    """Plain penalty CMA-ES baseline (``cma`` library) with the same start distribution."""
    x0, _ = initial_search(problem)
    lb, ub = np.asarray(problem.lb), np.asarray(problem.ub)
    # cma's default sigma is a fraction of the range; a quarter of the box width per coordinate
    s0 = 0.25 * (ub - lb)
    return penalty_cma(problem.evaluate, x0, s0, (lb, ub), max_fevals=max_fevals, seed=seed,
                       target_cost=problem.target(rel_tol), feas_tol=FEAS_TOL, **kwargs)

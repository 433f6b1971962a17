"""Basin-CMA vs plain penalty CMA-ES on CEC-2006 problems (W&P 2009, Appendix A).

Fair budget: plain CMA-ES gets exactly the evaluations basin-CMA spent to reach the optimum,
counted in the *finite-difference* convention — every gradient/Jacobian evaluation of IPOPT
charged as ``n`` function evaluations (W&P's "fevals ratio2", the convention least favourable
to basin-CMA).  Plain CMA-ES also gets IPOP restarts and stops as soon as it is within 1e-4.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from planner.search.cec2006 import (
    EQ_TOL,
    PROBLEMS,
    CecLocalSolver,
    CecSolverFactory,
    get_problem,
    solve_basin_cma,
    solve_penalty_cma,
)

REL_TOL = 1e-4
SEED = 1


@dataclass(frozen=True)
class Row:
    name: str
    dim: int
    basin_cost: float
    basin_ok: bool
    local_solves: int
    fevals: int            # derivative evaluations counted as one (W&P ratio1 convention)
    fevals_fd: int         # derivative evaluations counted as n (ratio2 convention)
    plain_ok: bool
    plain_cost: float
    plain_fevals: int


def _relerr(f: float, f_star: float) -> float:
    return (f - f_star) / max(1.0, abs(f_star))


@pytest.fixture(scope="module")
def comparison() -> dict[str, Row]:
    rows: dict[str, Row] = {}
    for name, p in PROBLEMS.items():
        solver = CecLocalSolver(p)
        r = solve_basin_cma(p, seed=SEED, solver=solver, rel_tol=REL_TOL, max_local_solves=2000)
        fd = solver.n_f + p.dim * solver.n_grad
        plain = solve_penalty_cma(p, max_fevals=fd, seed=SEED, rel_tol=REL_TOL)
        rows[name] = Row(name, p.dim, r.cost, r.feasible and _relerr(r.cost, p.f_star) <= REL_TOL,
                         r.n_local_solves, r.n_fevals, fd,
                         plain.fevals_to_target is not None, plain.cost, plain.n_fevals)
    print("\nproblem dim | basin: solves fevals fevals_fd ok "
          "| plain CMA (budget=fevals_fd): ok best")
    for w in rows.values():
        print(f"{w.name:7s} {w.dim:3d} | {w.local_solves:6d} {w.fevals:6d} {w.fevals_fd:9d} "
              f"{w.basin_ok!s:5s} | {w.plain_ok!s:5s} {w.plain_cost:.8g}")
    return rows


@pytest.mark.parametrize("name", sorted(PROBLEMS))
def test_published_optimum_is_feasible_and_matches(name: str) -> None:
    p = get_problem(name)
    f, viol = p.evaluate(np.array(p.x_star))
    assert abs(_relerr(f, p.f_star)) < 1e-9
    assert viol <= 1e-9
    assert np.all(np.array(p.x_star) >= p.lb) and np.all(np.array(p.x_star) <= p.ub)


def test_g11_uses_cec_equality_tolerance() -> None:
    p = get_problem("g11")
    # exactly on x2 = x1² the optimum is 0.75; the CEC relaxation |h| <= 1e-4 gives 0.7499
    x = np.array([-np.sqrt(0.5 - EQ_TOL), 0.5])
    f, viol = p.evaluate(x)
    assert viol <= 1e-12 and abs(f - 0.7499) < 1e-12


def test_local_solver_projects_to_local_optimum_and_counts_fevals() -> None:
    p = get_problem("g07")
    solver = CecLocalSolver(p)
    r = solver(np.array(p.x_star) + 0.3)
    assert r.feasible and abs(_relerr(r.cost, p.f_star)) < 1e-6
    assert r.n_fevals > 0 and solver.n_calls == 1
    assert r.n_fevals == solver.n_f + solver.n_grad
    fd = CecSolverFactory("g07", convention="finite_difference")()
    r_fd = fd(np.array(p.x_star) + 0.3)
    assert r_fd.n_fevals == fd.n_f + p.dim * fd.n_grad > r.n_fevals


@pytest.mark.parametrize("name", sorted(PROBLEMS))
def test_basin_cma_reaches_known_optimum(comparison: dict[str, Row], name: str) -> None:
    row = comparison[name]
    assert row.basin_ok, row
    assert row.fevals > 0


def test_plain_cma_with_same_budget_falls_short(comparison: dict[str, Row]) -> None:
    failed = [r.name for r in comparison.values() if not r.plain_ok]
    # measured: plain penalty CMA-ES misses 1e-4 on 7 of 9 (reaches it only on g08 and g09)
    assert len(failed) >= 3, comparison
    for r in comparison.values():
        assert r.plain_fevals <= r.fevals_fd

"""Unit tests of the basin-CMA core (W&P 2009 §4.1, eqs 25-27)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from planner.search.basin_cma import (
    PAPER_MU,
    BasinCma,
    BasinCmaError,
    GenerationReport,
    LocalResult,
    basin_cma,
    default_popsize,
    paper_weights,
    penalty_cma,
    sigma_from_bounds,
)


def test_eq25_weights_sum_to_one_and_decrease() -> None:
    for mu in (1, 2, 3, 7, PAPER_MU):
        w = paper_weights(mu)
        assert w.shape == (mu,)
        assert math.isclose(float(w.sum()), 1.0, rel_tol=1e-12)
        assert np.all(w > 0)
        assert np.all(np.diff(w) < 0)
    # explicit eq 25 for µ = 3: (ln4 - ln j) / (3 ln4 - ln1 - ln2 - ln3)
    den = 3 * math.log(4) - math.log(6)
    assert np.allclose(paper_weights(3), [(math.log(4) - math.log(j)) / den for j in (1, 2, 3)])
    with pytest.raises(BasinCmaError):
        paper_weights(0)


def test_lamarckian_mean_is_projected_point() -> None:
    """g maps every sample to y*: after ONE tell the mean (eq 26 with y_j) equals y*."""
    y_star = np.array([0.3, -1.2, 2.5])
    es = BasinCma(np.zeros(3), 5.0, rng=np.random.default_rng(0))
    X = es.ask()
    m_old, C_old = es.mean.copy(), es.C.copy()
    es.tell([y_star] * len(X), [1.0] * len(X), [True] * len(X))
    assert np.allclose(es.mean, y_star)
    d = y_star - m_old   # eq 27 with y_j: all elites equal y*, Σw = 1
    assert np.allclose(es.C, (1 - es.c_cov) * C_old + es.c_cov * np.outer(d, d))


def test_covariance_update_uses_projected_points_eq27() -> None:
    rng = np.random.default_rng(3)
    es = BasinCma(np.array([1.0, 2.0]), [0.5, 2.0], popsize=9, mu=4, c_cov=0.25, rng=rng)
    X = es.ask()
    Y = np.round(X)                          # a projection that moves the points
    costs = (Y**2).sum(axis=1) + 1e-3 * np.arange(len(Y))   # distinct ranks
    m_old, C_old = es.mean.copy(), es.C.copy()
    es.tell(Y, costs, [True] * len(Y))
    elites = Y[np.argsort(costs)[:4]]
    w = paper_weights(4)
    assert np.allclose(es.mean, w @ elites)                                      # eq 26
    rank_mu = sum(wj * np.outer(y - m_old, y - m_old) for wj, y in zip(w, elites, strict=True))
    assert np.allclose(es.C, 0.75 * C_old + 0.25 * rank_mu)                      # eq 27
    # the raw samples would have given a different mean
    assert not np.allclose(es.mean, w @ X[np.argsort(costs)[:4]])


def test_infeasible_ranked_last_by_violation() -> None:
    es = BasinCma(np.zeros(1), 1.0, popsize=5, mu=2)
    costs = [-100.0, 5.0, -50.0, 3.0, 0.0]
    feas = [False, True, False, True, False]
    viol = [2.0, math.nan, 0.5, math.nan, math.nan]
    assert es.rank(costs, feas, viol) == [3, 1, 2, 0, 4]
    # the infeasible but very cheap point must not pull the mean (µ=2 feasible points exist)
    pts = np.array([[-10.0], [1.0], [-5.0], [2.0], [7.0]])
    es.tell(pts, costs, feas, viol)
    w = paper_weights(2)
    assert np.allclose(es.mean, w[0] * 2.0 + w[1] * 1.0)


def _sphere_projection(center: np.ndarray):  # type: ignore[no-untyped-def]
    def g(x: np.ndarray) -> LocalResult:
        y = 0.5 * (x + center)                    # a contraction toward the minimum
        return LocalResult(y, float(((y - center) ** 2).sum()), True, n_fevals=3)
    return g


def test_reproducible_with_seed() -> None:
    g = _sphere_projection(np.array([1.0, -2.0, 0.5]))
    a = basin_cma(g, np.zeros(3), 2.0, (-5, 5), seed=42, max_generations=15, restarts=0)
    b = basin_cma(g, np.zeros(3), 2.0, (-5, 5), seed=42, max_generations=15, restarts=0)
    c = basin_cma(g, np.zeros(3), 2.0, (-5, 5), seed=43, max_generations=15, restarts=0)
    assert np.array_equal(a.x, b.x) and a.cost == b.cost
    assert [h.generation_best_cost for h in a.history] == \
        [h.generation_best_cost for h in b.history]
    assert not np.array_equal(a.x, c.x)
    assert a.n_fevals == 3 * a.n_local_solves


def test_fewer_generations_are_the_longer_run_truncated() -> None:
    """Nothing in a run depends on `max_generations` but where it stops (the stall stop needs
    `stall_generations`, restarts are off): a run of k generations evaluates exactly the first
    k generations' samples of a longer one, so a recorded search truncated after generation k
    is the search with k generations (benchmarks/search_outcomes.py replay)."""
    g = _sphere_projection(np.array([1.0, -2.0, 0.5]))

    def samples(k: int) -> list[np.ndarray]:
        seen: list[np.ndarray] = []

        def recording(x: np.ndarray) -> LocalResult:
            seen.append(np.array(x))
            return g(x)

        basin_cma(recording, np.zeros(3), 2.0, (-5, 5), seed=7, max_generations=k,
                  restarts=0, popsize=8)
        return seen

    full = samples(6)
    assert len(full) == 48
    for k in range(1, 6):
        assert all(np.array_equal(a, b) for a, b in zip(samples(k), full[: 8 * k], strict=False))
        assert len(samples(k)) == 8 * k


def test_bounds_respected_and_converges() -> None:
    lb, ub = np.array([-1.0, 0.0]), np.array([1.0, 3.0])
    seen: list[np.ndarray] = []
    center = np.array([0.9, 0.1])

    def g(x: np.ndarray) -> tuple[np.ndarray, float, bool]:
        seen.append(x.copy())
        return x, float(((x - center) ** 2).sum()), True   # identity projection: plain CMA
    basin_cma(g, [0.0, 1.5], 50.0, (lb, ub), seed=0, max_generations=30, restarts=1)
    X = np.array(seen)
    assert np.all(X >= lb) and np.all(X <= ub)
    assert np.any(X == lb) or np.any(X == ub)      # sigma=50 ≫ box: clipping did happen
    # with an identity projection eq 26-27 is rank-µ CMA without step size: still converges
    for seed in range(3):
        r = basin_cma(g, [0.0, 1.5], 0.5, (lb, ub), seed=seed, max_generations=300)
        assert np.allclose(r.x, center, atol=1e-3)


def test_restarts_double_popsize_and_stop() -> None:
    def g(x: np.ndarray) -> LocalResult:
        return LocalResult(np.zeros_like(x), 1.0, True)    # one basin, flat: stalls
    r = basin_cma(g, [1.0, 1.0], 1.0, (-2, 2), seed=1, restarts=2, stall_generations=3,
                  max_generations=50)
    assert r.n_restarts == 2
    assert r.stop_reason == "restarts_exhausted"
    assert len(r.run_stop_reasons) == 3
    pops = sorted({h.popsize for h in r.history})
    lam = default_popsize(2)
    assert pops == [lam, 2 * lam, 4 * lam]
    assert r.n_local_solves == sum(h.popsize for h in r.history)


def test_tol_x_stop_when_covariance_collapses() -> None:
    def g(x: np.ndarray) -> LocalResult:
        return LocalResult(np.full_like(x, 0.25), 0.0, True)
    r = basin_cma(g, [1.0], 1.0, None, seed=1, restarts=0, tol_x=1e-3,
                  stall_generations=10**6, max_generations=500)
    assert r.run_stop_reasons == ("tol_x",)
    # (1 - c_cov)^k shrink of eq 27: sqrt(0.7)^k < 1e-3 needs ~39 generations
    assert 30 <= r.n_generations <= 45


def test_callback_per_generation_and_stop() -> None:
    reports: list[GenerationReport] = []
    g = _sphere_projection(np.zeros(2))
    r = basin_cma(g, [3.0, 3.0], 1.0, None, seed=0, restarts=0, max_generations=7,
                  stall_generations=100, callback=reports.append)
    assert [rep.generation for rep in reports] == list(range(7)) == \
        [h.generation for h in r.history]
    assert all(isinstance(rep, GenerationReport) for rep in reports)
    rep = reports[-1]
    assert rep.n_feasible == rep.popsize and rep.sigma > 0 and rep.mean.shape == (2,)
    assert all(a.best_cost >= b.best_cost for a, b in itertools.pairwise(reports))
    with pytest.raises(AttributeError):
        rep.generation = 3  # type: ignore[misc]  # frozen
    stopped = basin_cma(g, [3.0, 3.0], 1.0, None, seed=0, callback=lambda rp: rp.generation == 2)
    assert stopped.stop_reason == "callback" and stopped.n_generations == 3


def test_target_and_budget_stops() -> None:
    g = _sphere_projection(np.zeros(2))
    r = basin_cma(g, [3.0, 3.0], 1.0, None, seed=0, target_cost=1e-6)
    assert r.stop_reason == "target" and r.cost <= 1e-6
    b = basin_cma(g, [3.0, 3.0], 1.0, None, seed=0, max_local_solves=20)
    assert b.stop_reason == "max_local_solves" and 20 <= b.n_local_solves < 20 + b.history[
        -1].popsize


def test_infeasible_best_reported_when_nothing_feasible() -> None:
    def g(x: np.ndarray) -> LocalResult:
        return LocalResult(x, float(x[0]), False, violation=abs(float(x[0]) - 1.0))
    r = basin_cma(g, [0.0], 2.0, (-5, 5), seed=0, max_generations=40, restarts=0)
    assert not r.feasible
    assert abs(r.x[0] - 1.0) < 1e-2 and r.violation < 1e-2   # ranked by violation, not cost


def test_bad_inputs_raise() -> None:
    with pytest.raises(BasinCmaError):
        basin_cma(lambda x: 1.0, [0.0], 1.0, seed=0)  # type: ignore[arg-type,return-value]
    with pytest.raises(BasinCmaError):
        basin_cma(lambda x: (np.zeros(3), 1.0, True), [0.0], 1.0, seed=0)
    with pytest.raises(BasinCmaError):
        BasinCma([0.0], -1.0)
    with pytest.raises(BasinCmaError):
        BasinCma([0.0, 0.0], 1.0, popsize=4, mu=5)
    with pytest.raises(BasinCmaError):
        BasinCma([0.0], 1.0, (1.0, 0.0))
    with pytest.raises(BasinCmaError):
        BasinCma([0.0], 1.0, c_cov=0.0)


def test_sigma_from_bounds_matches_paper_rule() -> None:
    s = sigma_from_bounds([1.0, 0.0, 2.0], ([0.0, -np.inf, 0.0], [4.0, 1.0, 3.0]))
    assert np.allclose(s, [3.0, 500.0, 2.0])


def test_penalty_cma_baseline_solves_easy_problem() -> None:
    # min (x-2)^2 + (y-2)^2  s.t.  x + y <= 2   -> (1, 1), f* = 2
    def obj(x: np.ndarray) -> tuple[float, float]:
        return float(((x - 2) ** 2).sum()), max(0.0, float(x.sum() - 2))
    r = penalty_cma(obj, [0.0, 0.0], 1.0, ([-5, -5], [5, 5]), max_fevals=3000, seed=3,
                    penalty=10.0, target_cost=2.0 + 1e-3)
    assert r.feasible and r.fevals_to_target is not None and r.cost <= 2.0 + 1e-3
    assert r.n_fevals == r.fevals_to_target

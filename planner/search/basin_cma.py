"""Basin-CMA: CMA-ES over the basins of attraction of a local constrained solver.

Reference: K. Wampler and Z. Popović, "Optimal gait and form for animal locomotion",
ACM SIGGRAPH 2009 (W&P below), §4.1 "Hybrid optimization", §4.1.1 "Basin-CMA", §5, App. A.

Each generation draws λ samples ``x_j ~ N(m, C)``, clips them to the box ``bounds``, and
projects each one with a *local solve* ``y_j = g(x_j)`` (a derivative-based constrained
optimisation started at ``x_j``, e.g. IPOPT).  The search runs over ``f∘g`` and — this is the
Lamarckian part of basin-CMA — the mean and covariance updates (W&P eqs 26-27) use the
*projected* elites ``y_j`` instead of the samples ``x_j``.

Design decisions (documented here because they differ from textbook CMA-ES):

* **Weights** are W&P eq 25, ``w_j ∝ ln(µ+1) − ln j`` normalised to sum to one.
* **No separate step size / no CSA.**  W&P's variant keeps the whole scale in ``C`` and
  shrinks it through the ``(1 − c_cov)`` factor of eq 27: when the elites agree (all projected
  into the same basin) ``C`` contracts geometrically; when the mean moves, the rank-µ term
  measured around the *old* mean re-inflates ``C`` along the move.  Cumulative step-size
  adaptation is *not* added on purpose: its null hypothesis (under random selection the
  evolution path has the length of an ``N(0, I)`` vector) assumes the selected points are
  samples of ``N(m, σ²C)``; projected points are not — they collapse onto a few basin minima —
  so the path length carries no step-size information.  Premature contraction into a poor
  basin is instead handled by restarts.
* **Population defaults.**  The paper used λ=96, µ=32, c_cov=0.3 for 3-10 timing variables
  with minute-long local solves on a cluster (``PAPER_POPSIZE`` etc.).  For a generic problem
  the default is the usual CMA-ES ``λ = 4 + ⌊3 ln n⌋`` with the paper's ratio ``µ = ⌈λ/3⌉``
  and the paper's ``c_cov = 0.3``; pass ``popsize=96, mu=32`` to reproduce the paper.
* **Ranking.**  Feasible projected points first by cost; infeasible ones after all feasible
  ones, by reported constraint violation (then by cost).
* **Restarts** (IPOP style): when a run stops (``C`` collapsed below ``tol_x``, no improvement
  for ``stall_generations``, or ``max_generations``) a new run starts with the population
  multiplied by ``popsize_factor``, from a uniform random mean inside the bounds (or ``x0``
  where a bound is infinite) and the initial covariance.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from planner.search.executors import Executor

FloatArray = NDArray[np.float64]

#: CMA parameters used by W&P §5 for gait search (n = 3-10 timing variables).
PAPER_POPSIZE = 96
PAPER_MU = 32
PAPER_C_COV = 0.3

StopReason = Literal[
    "target", "max_local_solves", "restarts_exhausted", "callback"
]
RunStopReason = Literal["tol_x", "stall", "max_generations", "target", "max_local_solves",
                        "callback"]


class BasinCmaError(Exception):
    """Invalid arguments to basin-CMA or a malformed local-solve result."""


@dataclass(frozen=True)
class LocalResult:
    """Outcome of one local solve ``y = g(x)`` (W&P §4.1.1).

    ``x_projected`` is the local constrained minimum reached from the start point, ``cost`` its
    objective value, ``feasible`` whether it satisfies the constraints, ``n_fevals`` how many
    function evaluations the solve spent (0 if unknown), ``violation`` the total constraint
    violation (``nan`` if not reported; used to rank infeasible points).
    """

    x_projected: FloatArray
    cost: float
    feasible: bool
    n_fevals: int = 0
    violation: float = math.nan


LocalSolve = Callable[[FloatArray], "LocalResult | tuple[Any, ...]"]


def as_local_result(r: LocalResult | Sequence[Any], n: int) -> LocalResult:
    """Normalise a local-solve return value (``LocalResult`` or a plain tuple
    ``(x_projected, cost, feasible[, n_fevals[, violation]])``) and check its shape."""
    if isinstance(r, LocalResult):
        lr = r
    elif isinstance(r, tuple | list) and 3 <= len(r) <= 5:
        lr = LocalResult(np.asarray(r[0], dtype=float), float(r[1]), bool(r[2]),
                         int(r[3]) if len(r) > 3 else 0,
                         float(r[4]) if len(r) > 4 else math.nan)
    else:
        raise BasinCmaError(
            "local_solve must return LocalResult or (x_projected, cost, feasible"
            f"[, n_fevals[, violation]]); got {type(r).__name__}")
    y = np.asarray(lr.x_projected, dtype=float).reshape(-1)
    if y.shape != (n,):
        raise BasinCmaError(f"local_solve returned x_projected of shape {y.shape}, expected ({n},)")
    return LocalResult(y, float(lr.cost), bool(lr.feasible), int(lr.n_fevals),
                       float(lr.violation))


@dataclass(frozen=True)
class GenerationReport:
    """What the per-generation callback receives."""

    generation: int          # global generation counter (over all restarts), from 0
    restart: int             # 0 for the first run
    popsize: int
    best_cost: float         # best cost so far (feasible preferred)
    best_feasible: bool
    generation_best_cost: float
    mean: FloatArray         # mean after this generation's update (eq 26)
    sigma: float             # RMS standard deviation of C, sqrt(trace(C)/n)
    n_feasible: int
    n_local_solves: int      # cumulative
    n_fevals: int            # cumulative


@dataclass(frozen=True)
class BasinCmaResult:
    x: FloatArray
    cost: float
    feasible: bool
    violation: float
    history: tuple[GenerationReport, ...]
    n_local_solves: int
    n_fevals: int
    n_generations: int
    n_restarts: int
    stop_reason: StopReason
    run_stop_reasons: tuple[RunStopReason, ...]


def paper_weights(mu: int) -> FloatArray:
    """W&P eq 25: ``w_j = (ln(µ+1) − ln j) / (µ ln(µ+1) − Σ_k ln k)``, j = 1..µ."""
    if mu < 1:
        raise BasinCmaError(f"mu must be >= 1, got {mu}")
    j = np.arange(1, mu + 1, dtype=float)
    num = math.log(mu + 1) - np.log(j)
    return np.asarray(num / (mu * math.log(mu + 1) - float(np.sum(np.log(j)))), dtype=float)


def default_popsize(n: int) -> int:
    """``4 + ⌊3 ln n⌋`` (Hansen's default), used instead of the paper's 96 for small problems."""
    return 4 + int(3 * math.log(max(n, 1)))


def sigma_from_bounds(x0: ArrayLike, bounds: tuple[ArrayLike, ArrayLike],
                      unbounded: float = 500.0) -> FloatArray:
    """Per-coordinate initial spread as in W&P §5: the largest distance from ``x0`` to either
    bound (``unbounded`` where a bound is infinite)."""
    x = np.asarray(x0, dtype=float)
    lb, ub = (np.broadcast_to(np.asarray(b, dtype=float), x.shape) for b in bounds)
    d = np.maximum(x - lb, ub - x)
    return np.where(np.isfinite(d), d, unbounded)


def _rank_key(cost: float, feasible: bool, violation: float) -> tuple[int, float, float]:
    c = cost if math.isfinite(cost) else math.inf
    if feasible:
        return (0, c, 0.0)
    v = violation if math.isfinite(violation) else math.inf
    return (1, v, c)


class BasinCma:
    """Ask/tell core of basin-CMA (one run, no restarts).

    ``ask()`` returns λ samples of ``N(m, C)`` clipped to the bounds; the caller projects them
    with its local solver and hands the projected points back to ``tell()``, which performs the
    Lamarckian update of W&P eqs 26-27 with ``y_j`` in place of ``x_j``.
    """

    def __init__(self, mean: ArrayLike, sigma0: float | ArrayLike,
                 bounds: tuple[ArrayLike, ArrayLike] | None = None, *,
                 popsize: int | None = None, mu: int | None = None,
                 c_cov: float | None = None, rng: np.random.Generator | None = None) -> None:
        m = np.array(mean, dtype=float).reshape(-1)
        n = m.size
        if n < 1:
            raise BasinCmaError("x0 must have at least one coordinate")
        s = np.broadcast_to(np.asarray(sigma0, dtype=float), (n,)).copy()
        if not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise BasinCmaError(f"sigma0 must be positive and finite, got {sigma0!r}")
        if bounds is None:
            lb, ub = np.full(n, -np.inf), np.full(n, np.inf)
        else:
            lb = np.broadcast_to(np.asarray(bounds[0], dtype=float), (n,)).copy()
            ub = np.broadcast_to(np.asarray(bounds[1], dtype=float), (n,)).copy()
            if np.any(lb > ub):
                raise BasinCmaError("bounds: lower bound exceeds upper bound")
        self.n = n
        self.lb, self.ub = lb, ub
        self.popsize = popsize if popsize is not None else default_popsize(n)
        self.mu = mu if mu is not None else max(1, math.ceil(self.popsize / 3))
        if self.popsize < 2 or not 1 <= self.mu <= self.popsize:
            raise BasinCmaError(f"need popsize >= 2 and 1 <= mu <= popsize, "
                                f"got popsize={self.popsize}, mu={self.mu}")
        self.c_cov = PAPER_C_COV if c_cov is None else float(c_cov)
        if not 0.0 < self.c_cov <= 1.0:
            raise BasinCmaError(f"c_cov must be in (0, 1], got {self.c_cov}")
        self.weights = paper_weights(self.mu)            # eq 25
        self.mean = np.clip(m, lb, ub)
        self.C = np.diag(s**2)
        self.rng = rng if rng is not None else np.random.default_rng()
        self.generation = 0
        self._eig()

    def _eig(self) -> None:
        self.C = 0.5 * (self.C + self.C.T)
        d2, B = np.linalg.eigh(self.C)
        floor = max(float(np.max(d2)) * 1e-20, 1e-300)
        self._B, self._D = B, np.sqrt(np.maximum(d2, floor))

    @property
    def sigma(self) -> float:
        """RMS standard deviation of the search distribution, ``sqrt(trace(C)/n)``."""
        return math.sqrt(max(float(np.trace(self.C)), 0.0) / self.n)

    @property
    def max_std(self) -> float:
        return float(np.max(self._D))

    def ask(self) -> FloatArray:
        """λ×n samples ``x_j = m + B D z_j`` clipped to the bounds (clipping is part of g)."""
        z = self.rng.standard_normal((self.popsize, self.n))
        x = self.mean + (z * self._D) @ self._B.T
        return np.asarray(np.clip(x, self.lb, self.ub), dtype=float)

    def rank(self, costs: ArrayLike, feasible: ArrayLike,
             violations: ArrayLike | None = None) -> list[int]:
        """Indices best-first: feasible by cost, then infeasible by violation, then cost."""
        c = np.asarray(costs, dtype=float)
        f = np.asarray(feasible, dtype=bool)
        v = np.full(c.size, np.nan) if violations is None else np.asarray(violations, float)
        return sorted(range(c.size), key=lambda i: _rank_key(float(c[i]), bool(f[i]), float(v[i])))

    def tell(self, projected: ArrayLike, costs: ArrayLike, feasible: ArrayLike,
             violations: ArrayLike | None = None) -> None:
        """Lamarckian update from the *projected* points ``y_j = g(x_j)`` (W&P §4.1.1).

        eq 26: ``m' = Σ_j w_j y_j``;
        eq 27: ``C' = (1 − c_cov) C + c_cov Σ_j w_j (y_j − m)(y_j − m)ᵀ`` with ``m`` the mean
        the samples were drawn from (rank-µ update, Hansen & Kern 2004).
        """
        Y = np.asarray(projected, dtype=float).reshape(-1, self.n)
        if Y.shape[0] < self.mu:
            raise BasinCmaError(f"tell() needs at least mu={self.mu} points, got {Y.shape[0]}")
        order = self.rank(costs, feasible, violations)[: self.mu]
        elites = Y[order]
        if not np.all(np.isfinite(elites)):
            raise BasinCmaError("projected elite points contain non-finite values")
        w = self.weights
        new_mean = w @ elites                                       # eq 26
        dev = elites - self.mean
        rank_mu = (dev * w[:, None]).T @ dev                        # Σ w_j d_j d_jᵀ
        self.C = (1.0 - self.c_cov) * self.C + self.c_cov * rank_mu  # eq 27
        self.mean = new_mean
        self.generation += 1
        self._eig()


def _initial_mean(rng: np.random.Generator, x0: FloatArray, lb: FloatArray,
                  ub: FloatArray, restart: int) -> FloatArray:
    if restart == 0:
        return x0
    finite = np.isfinite(lb) & np.isfinite(ub)
    u = rng.uniform(np.where(finite, lb, 0.0), np.where(finite, ub, 1.0))
    return np.where(finite, u, x0)


def basin_cma(
    local_solve: LocalSolve,
    x0: ArrayLike,
    sigma0: float | ArrayLike,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    *,
    popsize: int | None = None,
    mu: int | None = None,
    c_cov: float | None = None,
    max_generations: int = 100,
    restarts: int = 4,
    popsize_factor: float = 2.0,
    max_local_solves: int | None = None,
    target_cost: float | None = None,
    tol_x: float = 1e-8,
    tol_fun: float = 1e-10,
    stall_generations: int = 10,
    seed: int | np.random.Generator | None = None,
    executor: Executor | None = None,
    callback: Callable[[GenerationReport], bool | None] | None = None,
) -> BasinCmaResult:
    """Minimise ``f∘g`` with basin-CMA (W&P §4.1.1) and IPOP-style restarts.

    Args:
        local_solve: ``g``; maps a start point ``x`` (length n, inside ``bounds``) to a
            ``LocalResult`` (or tuple ``(x_projected, cost, feasible[, n_fevals[, violation]])``).
        x0: initial mean of the first run.
        sigma0: initial standard deviation (scalar or per coordinate); C0 = diag(sigma0²).
            W&P §5 make it cover the whole box, see :func:`sigma_from_bounds`.
        bounds: ``(lower, upper)``, scalars or length-n; samples are clipped into them.
        popsize, mu, c_cov: λ, µ, c_cov (defaults: module docstring; paper: 96, 32, 0.3).
        max_generations: per run.  restarts: number of runs after the first.
        popsize_factor: λ multiplier per restart (IPOP); µ keeps its ratio to λ.
        max_local_solves: global budget of local solves (checked per generation).
        target_cost: stop as soon as a feasible projected point has ``cost <= target_cost``.
        tol_x: a run stops when the largest standard deviation of C falls below it.
        tol_fun, stall_generations: a run stops when its best cost has not improved by more
            than ``tol_fun·max(1, |best|)`` for ``stall_generations`` generations.
        seed: seed or ``numpy.random.Generator``; the run is deterministic given it (and a
            deterministic local solve).
        executor: evaluates the λ local solves of a generation (``executor.map``); serial
            in-process loop if ``None``.  See :mod:`planner.search.executors`.
        callback: called after every generation with a :class:`GenerationReport`; returning
            ``True`` stops the search.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    x0a = np.asarray(x0, dtype=float).reshape(-1)
    n = x0a.size
    if bounds is None:
        lb, ub = np.full(n, -np.inf), np.full(n, np.inf)
    else:
        lb = np.broadcast_to(np.asarray(bounds[0], dtype=float), (n,)).copy()
        ub = np.broadcast_to(np.asarray(bounds[1], dtype=float), (n,)).copy()
    if max_generations < 1 or restarts < 0 or popsize_factor < 1.0:
        raise BasinCmaError("need max_generations >= 1, restarts >= 0, popsize_factor >= 1")
    lam0 = popsize if popsize is not None else default_popsize(n)
    mu_ratio = (mu / lam0) if mu is not None else 1.0 / 3.0

    best: LocalResult | None = None
    history: list[GenerationReport] = []
    run_reasons: list[RunStopReason] = []
    n_solves = n_fevals = gen = 0
    stop: StopReason = "restarts_exhausted"

    for restart in range(restarts + 1):
        lam = max(2, round(lam0 * popsize_factor**restart))
        es = BasinCma(_initial_mean(rng, x0a, lb, ub, restart), sigma0, (lb, ub), popsize=lam,
                      mu=max(1, min(lam, math.ceil(mu_ratio * lam))), c_cov=c_cov, rng=rng)
        run_best = math.inf
        since_improve = 0
        reason: RunStopReason = "max_generations"
        for _ in range(max_generations):
            X = es.ask()
            raw = executor.map(local_solve, list(X)) if executor is not None \
                else [local_solve(x) for x in X]
            res = [as_local_result(r, n) for r in raw]
            n_solves += len(res)
            n_fevals += sum(r.n_fevals for r in res)
            costs = [r.cost for r in res]
            feas = [r.feasible for r in res]
            viols = [r.violation for r in res]
            order = es.rank(costs, feas, viols)
            gbest = res[order[0]]
            if best is None or _rank_key(gbest.cost, gbest.feasible, gbest.violation) < \
                    _rank_key(best.cost, best.feasible, best.violation):
                best = gbest
            es.tell([r.x_projected for r in res], costs, feas, viols)
            gbest_key = gbest.cost if gbest.feasible and math.isfinite(gbest.cost) else math.inf
            if gbest_key < run_best - tol_fun * max(1.0, abs(run_best) if
                                                    math.isfinite(run_best) else 1.0):
                run_best, since_improve = gbest_key, 0
            else:
                since_improve += 1
            report = GenerationReport(
                generation=gen, restart=restart, popsize=lam, best_cost=best.cost,
                best_feasible=best.feasible, generation_best_cost=gbest.cost,
                mean=es.mean.copy(), sigma=es.sigma, n_feasible=int(sum(feas)),
                n_local_solves=n_solves, n_fevals=n_fevals)
            history.append(report)
            gen += 1
            if callback is not None and callback(report):
                reason, stop = "callback", "callback"
                break
            if target_cost is not None and best.feasible and best.cost <= target_cost:
                reason, stop = "target", "target"
                break
            if max_local_solves is not None and n_solves >= max_local_solves:
                reason, stop = "max_local_solves", "max_local_solves"
                break
            if es.max_std < tol_x:
                reason = "tol_x"
                break
            if since_improve >= stall_generations:
                reason = "stall"
                break
        run_reasons.append(reason)
        if stop != "restarts_exhausted":
            break

    assert best is not None  # max_generations >= 1 guarantees one generation
    return BasinCmaResult(
        x=best.x_projected, cost=best.cost, feasible=best.feasible, violation=best.violation,
        history=tuple(history), n_local_solves=n_solves, n_fevals=n_fevals,
        n_generations=gen, n_restarts=len(run_reasons) - 1, stop_reason=stop,
        run_stop_reasons=tuple(run_reasons))


# --------------------------------------------------------------------------------------------
# Baseline: plain (non-basin) CMA-ES with a static penalty, via the `cma` library.


@dataclass(frozen=True)
class PenaltyCmaResult:
    x: FloatArray               # best feasible point found (best penalised point if none)
    cost: float                 # its objective value (unpenalised)
    feasible: bool
    violation: float
    n_fevals: int               # evaluations actually spent
    fevals_to_target: int | None  # evaluations until the first feasible cost <= target_cost
    n_restarts: int


def penalty_cma(
    objective: Callable[[FloatArray], tuple[float, float]],
    x0: ArrayLike,
    sigma0: float | ArrayLike,
    bounds: tuple[ArrayLike, ArrayLike],
    *,
    max_fevals: int,
    penalty: float = 1e6,
    feas_tol: float = 1e-6,
    target_cost: float | None = None,
    popsize: int | None = None,
    popsize_factor: float = 2.0,
    seed: int = 1,
) -> PenaltyCmaResult:
    """Plain CMA-ES (``cma.CMAEvolutionStrategy``, Hansen) on ``f(x) + penalty·violation(x)``.

    ``objective(x) -> (f, violation)`` with ``violation = Σ max(0, g_i(x))`` (≥ 0).  Box bounds
    are handled by the library's bound transform; IPOP restarts (popsize × ``popsize_factor``
    from a uniform random mean) until ``max_fevals`` is spent or ``target_cost`` is reached.
    A point counts as feasible when ``violation <= feas_tol``.
    """
    import cma  # local import: only the baseline needs the library

    rng = np.random.default_rng(seed)
    x0a = np.asarray(x0, dtype=float).reshape(-1)
    n = x0a.size
    lb = np.broadcast_to(np.asarray(bounds[0], dtype=float), (n,)).copy()
    ub = np.broadcast_to(np.asarray(bounds[1], dtype=float), (n,)).copy()
    stds = np.broadcast_to(np.asarray(sigma0, dtype=float), (n,)).copy()
    lam = popsize if popsize is not None else default_popsize(n)
    fevals = 0
    hit: int | None = None
    best: tuple[tuple[int, float, float], FloatArray, float, float] | None = None
    restart = 0
    while fevals < max_fevals and hit is None:
        start = x0a if restart == 0 else _initial_mean(rng, x0a, lb, ub, restart)
        opts = {"bounds": [list(lb), list(ub)], "CMA_stds": list(stds), "popsize": lam,
                "seed": int(rng.integers(1, 2**31 - 1)), "verbose": -9,
                "maxfevals": max_fevals - fevals}
        es = cma.CMAEvolutionStrategy(list(np.clip(start, lb, ub)), 1.0, opts)
        while not es.stop() and fevals < max_fevals and hit is None:
            X = es.ask()
            vals = []
            for x in X:
                xa = np.clip(np.asarray(x, dtype=float), lb, ub)
                f, v = objective(xa)
                fevals += 1
                feas = v <= feas_tol
                key = _rank_key(f, feas, v)
                if best is None or key < best[0]:
                    best = (key, xa, float(f), float(v))
                if hit is None and feas and target_cost is not None and f <= target_cost:
                    hit = fevals
                vals.append(f + penalty * v if math.isfinite(f) else math.inf)
                if fevals >= max_fevals or hit is not None:
                    break
            if len(vals) < len(X):
                break
            es.tell(X, vals)
        restart += 1
        lam = round(lam * popsize_factor)
    assert best is not None
    return PenaltyCmaResult(x=best[1], cost=best[2], feasible=best[0][0] == 0,
                            violation=best[3], n_fevals=fevals, fevals_to_target=hit,
                            n_restarts=restart - 1)

"""The schedule's switched-off equality rows freed per solve (`PlannerOptions.inactive_rows`).

The NLP is built once per (robot, N) and the contact schedule switches rows on and off through
the activity parameters C (`planner.nlp.constraints`): "stance height" is C·(z − r) = 0,
"stance no-slip" S·Δx = 0 and S·Δy = 0 with S = C_k ∨ C_{k+1} (`vertical_contact_transitions`;
C_k·C_{k+1} without), and a flat foot's "sole level" C·n_xy = 0 and "sole yaw hold"
S·sin Δψ = 0 (`planner.nlp.flat_foot`). Where the factor is 0 the row reads 0 = 0 whatever x
is: its Jacobian row is exactly zero, so the equality-constraint Jacobian J_c loses one rank per
such row and IPOPT's KKT matrix [W + Σ + δ_w I, J_cᵀ; J_c, −δ_c I] is singular at δ_c = 0.
These rows are the whole rank deficiency (dense SVD of J_c at the cold start and at the optimum:
quad12, hex18, biped, star5, humanoid20 at N = 12 and 30; every other equality row is
independent; docs/results/planner_speed_ipopt.md, session 33, branch rank). MUMPS reports the
KKT matrix singular (INFO(1) = −10) and IPOPT retries the factorisation with δ_c > 0 at each
iteration until its degeneracy test marks the Jacobian degenerate ("Dj" in its log), after
which δ_c > 0 always (Wächter & Biegler 2006, §3.1, the inertia correction).

"free" gives those rows the bounds −∞ ≤ 0 ≤ ∞ for the solve instead of 0 ≤ 0 ≤ 0: the same
feasible set (the row is 0 at every x), but IPOPT now counts it as an inequality d(x) − s = 0
with a free slack s, whose KKT block [0, −1; −1, 0] is non-singular, so J_c has full row rank.
"free stance" frees only the "stance height" and "stance no-slip" rows: on point feet that is
every zero row (the same bounds as "free"); on flat feet the sole rows stay 0 = 0, so the
Jacobian stays rank-deficient and IPOPT follows "rows"' path (the same iteration counts on 12 of
12 converged biped solves).
"regularised" keeps the rows and has IPOPT use δ_c > 0 from the first iteration
(``perturb_always_cd``, `planner.nlp.spacetime.ipopt_options`). Each of "free" and
"regularised" saves the 3 singular factorisations of every solve; neither won at both N = 12
and N = 30 (IPOPT's path changes by more than that); "free" at N = 30 kept every optimum on
point feet but ended a biped schedule at another local optimum, 0.46 % costlier (both are
local optima of the same NLP: each variant warm-started from the other's stays there);
"free stance" kept every optimum on the biped (its path) but on point feet it is "free", which
ended bittle8's template walk at N = 30 2.7 % costlier. So "rows" stays the default
(`config.DEFAULT_INACTIVE_ROWS`), and the search's coarse solves use "rows" whatever the options
say (docs/results/planner_speed_ipopt.md, sessions 33–34).
"""

from __future__ import annotations

import casadi as ca
import numpy as np


class RowActivity:
    """The activity factor of every row that has one (`constraints.Group.activity`), as a
    function of the contact matrix; built once per planner."""

    def __init__(self, p: ca.MX, rows: np.ndarray, activity: ca.MX, n_contact: int) -> None:
        """`p`: the NLP's parameter symbol (its first `n_contact` entries are the contact
        matrix, `planner.nlp.variables.parameter_vector`); `rows`: the rows of g the entries of
        `activity` (an MX column in p) belong to."""
        if int(activity.shape[0]) != rows.size:
            raise ValueError(f"{int(activity.shape[0])} activity factors for {rows.size} rows")
        depends = np.flatnonzero(_columns(activity, p))
        if depends.size and depends.max() >= n_contact:
            raise ValueError("a row's activity depends on parameters other than the contacts")
        self.rows = rows
        self._n_p = int(p.shape[0])
        self._n_contact = n_contact
        self._activity = ca.Function("row_activity", [p], [activity])

    def inactive(self, contact: np.ndarray) -> np.ndarray:
        """The rows of g whose factor is 0 for `contact` (N × F, 1 in stance)."""
        p = np.zeros(self._n_p)
        p[: self._n_contact] = np.asarray(contact, dtype=float).ravel()
        values = np.asarray(self._activity(p)).ravel()
        return self.rows[values == 0.0]


def _columns(expr: ca.MX, p: ca.MX) -> np.ndarray:
    """Which entries of `p` the column `expr` depends on (0/1 per entry of p)."""
    return np.asarray(ca.DM(ca.jacobian(expr, p).sparsity(), 1)).sum(axis=0) > 0


def free_inactive_rows(
    inactive: np.ndarray, lbg: np.ndarray, ubg: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(lbg, ubg) with every row of `inactive` (rows of g that read 0 = 0) unbounded; a row
    whose bounds exclude 0 keeps them (the solve is infeasible either way, and stays so)."""
    lbg, ubg = lbg.copy(), ubg.copy()
    rows = inactive[(lbg[inactive] <= 0.0) & (ubg[inactive] >= 0.0)]
    lbg[rows] = -np.inf
    ubg[rows] = np.inf
    return lbg, ubg

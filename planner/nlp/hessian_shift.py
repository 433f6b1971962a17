"""A constant shift of the Lagrangian Hessian IPOPT is given on some variables
(`PlannerOptions.hessian_shift_acc`, issue #16, session 44 branch inertia).

IPOPT factorises [W + Σ + δ_w I, Jᵀ; J, −δ_c I] and, when its inertia is wrong (the reduced
Hessian of W + Σ on the null space of the equality Jacobian has a negative eigenvalue), it
factorises again with δ_w > 0 (its log's lg(rg) column). On the spacetime NLP the negative
directions are smooth changes of one leg's joint trajectory (99 % of their norm in the lifted
joint accelerations: docs/results/planner_speed_rows.md, session 44), where the cost's curvature
is ≈ 4e-6 and the constraint rows' λ·∇²g (stance no-slip, inverse dynamics, swing clearance,
whole-body moment) briefly exceeds it. IPOPT always tries δ_w = 0 first, so every such
iteration factorises at least twice.

The shift hands IPOPT W + s·σ·D instead of W (σ: IPOPT's objective factor, D the 0/1 diagonal
of the shifted variables): only the Newton model changes, not the NLP — the objective, the rows
and therefore IPOPT's optimality test (which reads gradients, never W) are the same, so a
converged point is a KKT point of the same NLP to the same tolerance. The price is a Newton step
that is too short in the shifted directions (a linearly converging tail if s is not small
against their true curvature)."""

from __future__ import annotations

import casadi as ca
import numpy as np


def shifted_hessian(hess: ca.Function, shifted: np.ndarray, shift: float) -> ca.Function:
    """`hess` — CasADi's ``nlp_hess_l`` signature (x, p, σ, λ) ↦ triu(∇²ₓₓ(σf + λᵀg)) — plus
    σ·`shift` on the diagonal entries where `shifted` (a boolean mask over x) is set."""
    x, p = hess.mx_in(0), hess.mx_in(1)
    lam_f, lam_g = hess.mx_in(2), hess.mx_in(3)
    n = int(x.shape[0])
    mask = np.asarray(shifted, dtype=bool)
    if mask.shape != (n,):
        raise ValueError(f"a mask of {mask.shape} entries for {n} variables")
    rows = np.flatnonzero(mask).tolist()
    diag = ca.DM.triplet(rows, rows, ca.DM.ones(len(rows)), n, n)
    out = hess(x, p, lam_f, lam_g) + lam_f * shift * diag
    return ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [out],
                       ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])

"""The Lagrangian Hessian assembled from one knot Hessian per knot (issue #16, session 29).

CasADi's own Hessian of the un-expanded NLP (``nlp_hess_l``) is forward-over-adjoint AD of the
whole MX graph: the knot map's second derivatives come from ``fwd<n>_adj1_knot`` (one knot
Hessian H per knot times n seed columns, `planner.nlp.solver_cache`), but every other node of the
graph is swept with the n directions too, and where the NLP uses the knot's outputs nonlinearly
(flat feet, soles) it also evaluates the knot's forward derivatives ``fwd<n>_knot`` and its J
inside ``fwd<n>_adj1_knot``.

Here the chain rule is written out, as `planner.nlp.assembled_jacobian` does for the Jacobian.
With the knot outputs Y replaced by a symbol, the Lagrangian is L̃(x, Y) = σ·f(x, Y) + λᵀg(x, Y)
and L(x) = L̃(x, Y(u(x))), with Y_k = knot(u_k) and u affine in x (A = du/dx is a sparse matrix
of constants and parameters; checked when built). Differentiating twice,

    ∇²L = Tᵀ · ∇²_zz L̃ · T + Aᵀ · blockdiag_k(H(u_k, μ_k)) · A,
    T = [I; blockdiag_k(J(u_k)) · A],  z = (x, Y),  μ = ∂L̃/∂Y,

with J(u) the knot's Jacobian and H(u, μ) = ∇²_uu(μᵀ knot(u)) its Lagrangian Hessian (the
`jacobian_and_hessian` pair of `planner.nlp.solver_cache`). ∇²_zz L̃ is CasADi's AD of a graph
without the knot (cheap: the knot is most of the NLP's instructions); its x–Y and Y–Y blocks are
structurally zero where the NLP is linear in Y with constant coefficients, and then neither the
knot's J nor its outputs are evaluated at all. Exact, not an approximation: the same Hessian to
rounding (tests/planner/nlp/test_assembled_hessian.py).
"""

from __future__ import annotations

from typing import Any

import casadi as ca

from planner.errors import PlannerConfigError
from planner.nlp.assembled_jacobian import KnotCall


def assembled_hessian(
    x: Any,
    p: Any,
    f: Any,
    g: Any,
    call: KnotCall,
    jacobian: ca.Function,
    hessian: ca.Function,
    n_knots: int,
) -> ca.Function:
    """CasADi's ``nlp_hess_l`` signature, (x, p, σ, λ) ↦ triu(∇²ₓₓ(σ f + λᵀ g)), assembled as in
    the module docstring; `jacobian`: u ↦ J(u) and `hessian`: (u, μ) ↦ H(u, μ) of one knot (u:
    its inputs stacked in order, μ: one multiplier per output row). Raises `PlannerConfigError`
    if the knot's inputs are not affine in x (the formula would miss their curvature)."""
    n = n_knots
    n_x = int(x.shape[0])
    out_rows = [int(o.shape[0]) for o in call.outputs]
    n_y = sum(out_rows)
    y_flat = ca.MX.sym("y", n_y * n)
    y = ca.reshape(y_flat, n_y, n)  # knot k's outputs stacked in column k
    offsets = [0]
    for rows in out_rows:
        offsets.append(offsets[-1] + rows)
    f_y, g_y = ca.graph_substitute([f, g], list(call.outputs), ca.vertsplit(y, offsets))
    u = ca.vertcat(*[v if int(v.shape[1]) == n else ca.repmat(v, 1, n) for v in call.inputs])
    n_u = int(u.shape[0])
    du_dx = ca.jacobian(ca.vec(u), x)
    if ca.depends_on(du_dx, x):
        raise PlannerConfigError(
            "nlp_hessian='assembled': the knot's inputs are not affine in the NLP variables; "
            "use nlp_hessian='ad'"
        )
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", int(g.shape[0]))
    lagrangian = lam_f * f_y + ca.dot(lam_g, g_y)
    z = ca.vertcat(x, y_flat)
    h_zz, grad_z = ca.hessian(lagrangian, z)
    mu = ca.reshape(grad_z[n_x:], n_y, n)  # ∂L̃/∂Y_k in column k
    h_xx, h_xy, h_yy = h_zz[:n_x, :n_x], h_zz[:n_x, n_x:], h_zz[n_x:, n_x:]
    knot_h = hessian.map(n)(u, mu)  # n_u × (n_u·N): knot k's H in columns k·n_u …
    total = h_xx + ca.mtimes(du_dx.T, ca.mtimes(ca.diagcat(*ca.horzsplit(knot_h, n_u)), du_dx))
    if h_xy.nnz() or h_yy.nnz():
        blocks = jacobian.map(n)(u)  # n_y × (n_u·N)
        jac_a = ca.mtimes(ca.diagcat(*ca.horzsplit(blocks, n_u)), du_dx)  # dY/dx
        if h_xy.nnz():
            cross = ca.mtimes(h_xy, jac_a)
            total = total + cross + cross.T
        if h_yy.nnz():
            total = total + ca.mtimes(jac_a.T, ca.mtimes(h_yy, jac_a))
    (hess,) = ca.graph_substitute(
        [ca.triu(total)], [y_flat], [ca.vec(ca.vertcat(*call.outputs))]
    )
    return ca.Function(
        "nlp_hess_l", [x, p, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"],
        ["triu_hess_gamma_x_x"],
    )

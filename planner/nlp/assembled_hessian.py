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
knot's J nor its outputs are evaluated at all. The NLP's other per-knot SX functions with
derivatives of their own (the flat feet's ``flat_knot`` and the soles' ``soles``,
`planner.nlp.solver_cache.DerivedFunctions`, recorded by `call_mapped`) are treated the same way,
each with its own Y, J and H (z then holds every one's outputs). Exact, not an approximation:
the same Hessian to rounding (tests/planner/nlp/test_assembled_hessian.py).

`knots_read_only` (the half-cycle solve's rows, `planner.nlp.half_cycle`): each function's H and
J are evaluated only at the knots whose outputs L̃ reads (structurally: the entries of ∂L̃/∂Y; the
others' μ_k, rows and columns of ∇²_zz L̃ are structurally zero), and the knot itself too when
its call carries it (`KnotCall.at_knots`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.assembled_jacobian import (
    KnotCall,
    columns,
    knots_with_entries,
    per_knot,
    stacked_inputs,
)

#: one per-knot function's call in the NLP with its J(u) and H(u, μ) (`jacobian_and_hessian`)
KnotTerm = tuple[KnotCall, ca.Function, ca.Function]


def assembled_hessian(
    x: Any, p: Any, f: Any, g: Any, terms: Sequence[KnotTerm], n_knots: int,
    knots_read_only: bool = False,
) -> ca.Function:
    """CasADi's ``nlp_hess_l`` signature, (x, p, σ, λ) ↦ triu(∇²ₓₓ(σ f + λᵀ g)), assembled as in
    the module docstring for every per-knot function of `terms`: its call in f and g, u ↦ J(u)
    and (u, μ) ↦ H(u, μ) of one knot (u: its inputs stacked in order, μ: one multiplier per
    output non-zero). Raises `PlannerConfigError` if a call's inputs are not affine in x (the
    formula would miss their curvature). `knots_read_only`: each function evaluated only at the
    knots whose outputs f and g read (module docstring)."""
    n = n_knots
    n_x = int(x.shape[0])
    y_syms: list[Any] = []
    outputs: list[Any] = []
    substitutes: list[Any] = []
    knot_u: list[Any] = []
    du_dx: list[Any] = []
    for call, _, _ in terms:
        sizes = [int(o.numel()) // n for o in call.outputs]
        y_sym = ca.MX.sym("y", sum(sizes) * n)
        y = ca.reshape(y_sym, sum(sizes), n)  # knot k's outputs stacked in column k
        parts = ca.vertsplit(y, np.cumsum([0, *sizes]).tolist())
        for out, part in zip(call.outputs, parts, strict=True):
            outputs.append(out)
            substitutes.append(ca.reshape(part, out.shape[0], out.shape[1]))
        y_syms.append(y_sym)
        u = stacked_inputs(call, n)
        a = ca.jacobian(ca.vec(u), x)
        if ca.depends_on(a, x):
            raise PlannerConfigError(
                "nlp_hessian='assembled': the inputs of the NLP's per-knot function "
                f"{terms[len(knot_u)][1].name()} are not affine in the NLP variables; use "
                "nlp_hessian='ad'"
            )
        knot_u.append(u)
        du_dx.append(a)
    f_y, g_y = ca.graph_substitute([f, g], outputs, substitutes)
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", int(g.shape[0]))
    z = ca.vertcat(x, *y_syms)
    lagrangian = lam_f * f_y + ca.dot(lam_g, g_y)
    h_zz, grad_z = ca.hessian(lagrangian, z)
    if knots_read_only:
        read = [knots_with_entries(ca.jacobian_sparsity(lagrangian, y_sym),
                                   int(y_sym.shape[0]) // n, n) for y_sym in y_syms]
        hess = _hessian_at_read_knots(terms, read, knot_u, du_dx, y_syms, h_zz, grad_z, n_x, n)
        return ca.Function(
            "nlp_hess_l", [x, p, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"],
            ["triu_hess_gamma_x_x"],
        )
    total = h_zz[:n_x, :n_x]
    offsets = np.cumsum([n_x, *[int(y.shape[0]) for y in y_syms]]).tolist()
    dy_dx = []  # knot outputs by x: blockdiag(J(u_k))·A where ∇²_zz L̃ needs them, else zero
    for (_, jacobian, hessian), u, a, y_sym, lo, hi in zip(
        terms, knot_u, du_dx, y_syms, offsets[:-1], offsets[1:], strict=True
    ):
        n_u = int(u.shape[0])
        mu = ca.reshape(grad_z[lo:hi], int(y_sym.shape[0]) // n, n)  # ∂L̃/∂Y_k in column k
        knot_h = hessian.map(n)(u, mu)  # n_u × (n_u·N): knot k's H in columns k·n_u …
        total = total + ca.mtimes(a.T, ca.mtimes(ca.diagcat(*ca.horzsplit(knot_h, n_u)), a))
        if h_zz[lo:hi, :].nnz():
            blocks = jacobian.map(n)(u)  # n_y × (n_u·N)
            dy_dx.append(ca.mtimes(ca.diagcat(*ca.horzsplit(blocks, n_u)), a))
        else:
            dy_dx.append(ca.MX(int(y_sym.shape[0]), n_x))
    total = _plus_output_terms(total, h_zz[:n_x, n_x:], h_zz[n_x:, n_x:], dy_dx)
    (hess,) = ca.graph_substitute([ca.triu(total)], y_syms, [
        ca.vec(ca.vertcat(*[per_knot(o, n) for o in call.outputs])) for call, _, _ in terms
    ])
    return ca.Function(
        "nlp_hess_l", [x, p, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"],
        ["triu_hess_gamma_x_x"],
    )


def _hessian_at_read_knots(terms: Sequence[KnotTerm], read: list[tuple[int, ...]],
                           knot_u: list[Any], du_dx: list[Any], y_syms: list[Any], h_zz: Any,
                           grad_z: Any, n_x: int, n: int) -> Any:
    """`assembled_hessian`'s triu(∇²L) with each function's H and J (and the function itself,
    if its call carries it) evaluated only at the knots `read` (per term: those whose outputs L̃
    depends on); L̃ does not depend on the other knots' Y, so their μ_k and their rows and
    columns of ∇²_zz L̃ are 0."""
    total = h_zz[:n_x, :n_x]
    read_z: list[int] = []  # z-indices of the outputs read, in the order of `dy_dx`
    dy_dx = []  # those outputs by x: blockdiag(J(u_k))·A_k where ∇²_zz L̃ needs them, else 0
    values = []  # what replaces each y symbol: the outputs, evaluated at the knots read
    lo = n_x
    for (call, jacobian, hessian), knots, u, a, y_sym in zip(
        terms, read, knot_u, du_dx, y_syms, strict=True
    ):
        n_u, n_y = int(u.shape[0]), int(y_sym.shape[0]) // n
        hi = lo + n_y * n
        mu = ca.reshape(grad_z[lo:hi], n_y, n)  # ∂L̃/∂Y_k in column k
        outputs = call.outputs
        if knots:
            u_read = columns(u, knots)
            a_read = a[[k * n_u + i for k in knots for i in range(n_u)], :]
            knot_h = hessian.map(len(knots))(u_read, columns(mu, knots))
            total = total + ca.mtimes(
                a_read.T, ca.mtimes(ca.diagcat(*ca.horzsplit(knot_h, n_u)), a_read))
            rows = [lo + k * n_y + r for k in knots for r in range(n_y)]
            read_z.extend(rows)
            if h_zz[lo:hi, :].nnz():
                blocks = jacobian.map(len(knots))(u_read)
                dy_dx.append(ca.mtimes(ca.diagcat(*ca.horzsplit(blocks, n_u)), a_read))
            else:
                dy_dx.append(ca.MX(len(rows), n_x))
            if call.function is not None:
                outputs = call.at_knots(knots, n)
        values.append(ca.vec(ca.vertcat(*[per_knot(o, n) for o in outputs])))
        lo = hi
    if read_z:
        total = _plus_output_terms(total, h_zz[:n_x, read_z], h_zz[read_z, read_z], dy_dx)
    (hess,) = ca.graph_substitute([ca.triu(total)], y_syms, values)
    return hess


def _plus_output_terms(total: Any, h_xy: Any, h_yy: Any, dy_dx: list[Any]) -> Any:
    """`total` plus the terms of Tᵀ·∇²_zz L̃·T (module docstring) through the outputs:
    ∇²_xY·dY/dx, its transpose and (dY/dx)ᵀ·∇²_YY·dY/dx, with `dy_dx` the outputs (in the order
    of `h_xy`'s columns) by x; only those with entries."""
    if not (h_xy.nnz() or h_yy.nnz()):
        return total
    jac_a = ca.vertcat(*dy_dx)
    if h_xy.nnz():
        cross = ca.mtimes(h_xy, jac_a)
        total = total + cross + cross.T
    if h_yy.nnz():
        total = total + ca.mtimes(jac_a.T, ca.mtimes(h_yy, jac_a))
    return total

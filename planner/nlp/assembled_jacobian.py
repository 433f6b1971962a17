"""The NLP's constraint Jacobian assembled from one Jacobian evaluation per knot (issue #16).

CasADi's own Jacobian of the un-expanded NLP seeds the knot map with forward directions in
batches of at most 64 (`planner.nlp.solver_cache.MAX_DIRECTIONS`), one per colour of the NLP
Jacobian's columns that reaches a knot: a knot whose rows depend on more than 64 NLP variables
(hex18's 88 inputs; any robot's knot once the rates are eliminated, `planner.nlp.lifted`:
its neighbours' poses enter too, 66 on quad12) evaluates every knot's J(u) twice.

Here the chain rule is written out instead. With the knot outputs Y replaced by a symbol,
g = G(x, Y) is cheap to differentiate, and

    dg/dx = ∂G/∂x + ∂G/∂Y · blockdiag_k(J(u_k)) · du/dx,

with u_k the knot's inputs (linear in x, so du/dx is a sparse matrix of constants and
parameters). J(u_k) is evaluated once per knot whatever its input count, and the products
are sparse. Exact, not an approximation: the same Jacobian to rounding (tested).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca


@dataclass(frozen=True)
class KnotCall:
    """The knot map's call in the NLP: its arguments (each rows × N, or a scalar broadcast to
    every knot) and its outputs (rows × N), as the MX nodes the NLP's expressions use."""

    inputs: tuple[Any, ...]
    outputs: tuple[Any, ...]


def assembled_jacobian(
    x: Any, p: Any, g: Any, call: KnotCall, jacobian: ca.Function, n_knots: int
) -> ca.Function:
    """CasADi's ``nlp_jac_g`` signature, (x, p) ↦ (g, ∂g/∂x), with ∂g/∂x assembled as in the
    module docstring; `jacobian`: u ↦ J(u) of one knot (u: its inputs stacked in order)."""
    n = n_knots
    out_rows = [int(o.shape[0]) for o in call.outputs]
    n_y = sum(out_rows)
    y_flat = ca.MX.sym("y", n_y * n)
    y = ca.reshape(y_flat, n_y, n)  # knot k's outputs stacked in column k
    offsets = [0]
    for rows in out_rows:
        offsets.append(offsets[-1] + rows)
    y_parts = ca.vertsplit(y, offsets)
    (g_y,) = ca.graph_substitute([g], list(call.outputs), y_parts)
    u = ca.vertcat(*[v if int(v.shape[1]) == n else ca.repmat(v, 1, n) for v in call.inputs])
    n_u = int(u.shape[0])
    du_dx = ca.jacobian(ca.vec(u), x)
    dg_dx = ca.jacobian(g_y, x)
    dg_dy = ca.jacobian(g_y, y_flat)
    blocks = jacobian.map(n)(u)  # n_y × (n_u·N): knot k's J in columns k·n_u …
    knot_jac = ca.diagcat(*ca.horzsplit(blocks, n_u))
    jac = dg_dx + ca.mtimes(dg_dy, ca.mtimes(knot_jac, du_dx))
    (jac,) = ca.graph_substitute([jac], [y_flat], [ca.vec(ca.vertcat(*call.outputs))])
    return ca.Function("nlp_jac_g", [x, p], [g, jac], ["x", "p"], ["g", "jac_g_x"])

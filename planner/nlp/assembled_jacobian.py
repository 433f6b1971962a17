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

`knots_read_only` (the half-cycle solve's rows, `planner.nlp.half_cycle`): only the knots whose
outputs g reads (structurally, the columns of ∂G/∂Y with entries) are evaluated, J(u_k) and —
when the call carries its one-knot function — the outputs themselves (`KnotCall.at_knots`); the
other knots' blocks of ∂G/∂Y are structurally zero, so the product is the same.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np


@dataclass(frozen=True)
class KnotCall:
    """The knot map's call in the NLP: its arguments (each rows × N, or a scalar broadcast to
    every knot) and its outputs (rows × N), as the MX nodes the NLP's expressions use."""

    inputs: tuple[Any, ...]
    outputs: tuple[Any, ...]
    #: the function mapped, as one knot's u ↦ y (its inputs stacked into one column in order,
    #: its outputs' rows stacked: a `planner.nlp.constraints.stacked_knot`), if the call is of
    #: one: `at_knots` evaluates it at some of the knots only
    function: ca.Function | None = None

    def at_knots(self, knots: Sequence[int], n_knots: int) -> tuple[Any, ...]:
        """The outputs with only `knots` evaluated (`function` mapped over them): the same
        values in those knots' columns, 0 in the others'."""
        if self.function is None:
            raise ValueError("this knot call carries no one-knot function to evaluate")
        u = stacked_inputs(self, n_knots)
        y = self.function.map(len(knots))(columns(u, knots))
        full = ca.horzcat(*[y[:, i] if i >= 0 else ca.MX(int(y.shape[0]), 1)
                            for i in _positions(knots, n_knots)])
        offsets = [0]
        for out in self.outputs:
            offsets.append(offsets[-1] + int(out.shape[0]))
        return tuple(ca.vertsplit(full, offsets))


def per_knot(value: Any, n_knots: int) -> Any:
    """A mapped argument or result (rows × cols·N) as one column per knot (its numel × N, each
    knot's block in column-major order, as the knot's u and y stack them); an argument of one
    knot's shape (broadcast to every knot) repeated N times."""
    rows, cols = int(value.shape[0]), int(value.shape[1])
    if cols >= n_knots and cols % n_knots == 0:
        return ca.reshape(value, rows * cols // n_knots, n_knots)
    return ca.repmat(ca.vec(value), 1, n_knots)


def stacked_inputs(call: KnotCall, n_knots: int) -> Any:
    """u: the call's inputs stacked, one column per knot (`per_knot`)."""
    return ca.vertcat(*[per_knot(v, n_knots) for v in call.inputs])


def columns(m: Any, knots: Sequence[int]) -> Any:
    """`m`'s columns `knots` (one slice when they are consecutive)."""
    lo, hi = knots[0], knots[-1] + 1
    if list(knots) == list(range(lo, hi)):
        return m[:, lo:hi]
    return m[:, list(knots)]


def _positions(knots: Sequence[int], n_knots: int) -> list[int]:
    """Each knot's position in `knots`, −1 for a knot not in it."""
    at = dict(zip(knots, range(len(knots)), strict=True))
    return [at.get(k, -1) for k in range(n_knots)]


def knots_with_entries(sparsity: ca.Sparsity, rows_per_knot: int, n_knots: int
                       ) -> tuple[int, ...]:
    """The knots whose columns (`rows_per_knot` per knot, knot-major) hold a structural entry
    of a matrix of `sparsity`, e.g. ∂G/∂Y: the knots whose outputs G reads."""
    filled = np.flatnonzero(np.diff(np.asarray(sparsity.colind(), dtype=int)))
    # a set, not np.unique: its first call imports numpy.ma (8 ms of a command's first solve,
    # docs/results/planner_speed_startup.md, session 44)
    return tuple(sorted(k for k in set((filled // rows_per_knot).tolist()) if k < n_knots))


def at_read_knots(exprs: Sequence[Any], call: KnotCall, n_knots: int) -> list[Any]:
    """`exprs` with `call`'s outputs evaluated only at the knots whose outputs they read
    (structurally; `KnotCall.at_knots`): the same values. Unchanged if the call carries no
    one-knot function."""
    if call.function is None:
        return list(exprs)
    n_y = sum(int(o.shape[0]) for o in call.outputs)
    y_flat = ca.MX.sym("y", n_y * n_knots)
    parts = ca.vertsplit(ca.reshape(y_flat, n_y, n_knots),
                         np.cumsum([0, *[int(o.shape[0]) for o in call.outputs]]).tolist())
    exprs_y = ca.graph_substitute(list(exprs), list(call.outputs), parts)
    read = sorted({k for e in exprs_y for k in knots_with_entries(
        ca.jacobian_sparsity(ca.vec(e), y_flat), n_y, n_knots)})
    if not read:
        return list(exprs)
    return list(ca.graph_substitute(exprs_y, [y_flat],
                                    [ca.vec(ca.vertcat(*call.at_knots(read, n_knots)))]))


def assembled_jacobian(
    x: Any, p: Any, g: Any, call: KnotCall, jacobian: ca.Function, n_knots: int,
    knots_read_only: bool = False,
) -> ca.Function:
    """CasADi's ``nlp_jac_g`` signature, (x, p) ↦ (g, ∂g/∂x), with ∂g/∂x assembled as in the
    module docstring; `jacobian`: u ↦ J(u) of one knot (u: its inputs stacked in order).
    `knots_read_only`: evaluate J, and the knot itself if `call` carries it, only at the knots
    whose outputs g reads (module docstring)."""
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
    u = stacked_inputs(call, n)
    n_u = int(u.shape[0])
    if knots_read_only:
        return _jacobian_at_read_knots(x, p, g_y, y_flat, u, call, jacobian, n)
    du_dx = ca.jacobian(ca.vec(u), x)
    dg_dx = ca.jacobian(g_y, x)
    dg_dy = ca.jacobian(g_y, y_flat)
    blocks = jacobian.map(n)(u)  # n_y × (n_u·N): knot k's J in columns k·n_u …
    knot_jac = ca.diagcat(*ca.horzsplit(blocks, n_u))
    jac = dg_dx + ca.mtimes(dg_dy, ca.mtimes(knot_jac, du_dx))
    (jac,) = ca.graph_substitute([jac], [y_flat], [ca.vec(ca.vertcat(*call.outputs))])
    return ca.Function("nlp_jac_g", [x, p], [g, jac], ["x", "p"], ["g", "jac_g_x"])


def _jacobian_at_read_knots(x: Any, p: Any, g_y: Any, y_flat: Any, u: Any, call: KnotCall,
                            jacobian: ca.Function, n: int) -> ca.Function:
    """`assembled_jacobian` with J (and the knot, if `call` carries it) evaluated only at the
    knots whose outputs `g_y` (g with the outputs replaced by `y_flat`) reads."""
    n_y, n_u = int(y_flat.shape[0]) // n, int(u.shape[0])
    dg_dx = ca.jacobian(g_y, x)
    dg_dy = ca.jacobian(g_y, y_flat)
    knots = knots_with_entries(dg_dy.sparsity(), n_y, n)
    if knots:
        u_read = columns(u, knots)
        du_dx = ca.jacobian(ca.vec(u_read), x)
        blocks = jacobian.map(len(knots))(u_read)
        knot_jac = ca.diagcat(*ca.horzsplit(blocks, n_u))
        read = [k * n_y + r for k in knots for r in range(n_y)]
        jac = dg_dx + ca.mtimes(dg_dy[:, read], ca.mtimes(knot_jac, du_dx))
    else:
        jac = dg_dx
    outputs = call.outputs if call.function is None or not knots else call.at_knots(knots, n)
    g_out, jac = ca.graph_substitute([g_y, jac], [y_flat], [ca.vec(ca.vertcat(*outputs))])
    return ca.Function("nlp_jac_g", [x, p], [g_out, jac], ["x", "p"], ["g", "jac_g_x"])

"""Per-knot derivatives for the un-expanded NLP (issue #16, "build once, reuse").

With ``expand=True`` `nlpsol` expands the whole NLP to SX and differentiates it: the Jacobian and
the Lagrangian Hessian are N copies of one knot's (1.84M instructions at N = 12 against 152K for
one knot) and building them is most of a planner's build time. With ``expand=False`` CasADi's MX
AD calls the knot function's directional derivatives instead (``fwd<n>_knot``, ``adj1_knot`` and
``fwd<n>_adj1_knot``, mapped over the knots), but it generates each of them as an SX sweep over n
directions — 576K instructions for ``fwd64_knot`` — so it builds slowly and solves slowly.

`with_knot_derivatives` gives the knot function those derivatives from one sparse Jacobian
``J(u)`` and one Lagrangian Hessian ``H(u, λ) = ∇²(λᵀ knot(u))`` of a single knot:

- ``fwd<n>_knot``:       (u, seeds Δu) ↦ J(u)·Δu
- ``adj1_knot``:         (u, λ) ↦ J(u)ᵀ·λ
- ``fwd<n>_adj1_knot``:  (u, λ, Δu, Δλ) ↦ H(u, λ)·Δu + J(u)ᵀ·Δλ

(the exact derivatives, not approximations), prepopulated into the function cache CasADi looks
them up in (`casadi.Function` option ``cache``), for every n up to `MAX_DIRECTIONS` (CasADi's MX
AD batches at most 64 directions). J and H are SX functions of one knot, built once per robot
whatever N is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca

#: CasADi's MX AD propagates at most this many directions at once (option ``max_num_dir``)
MAX_DIRECTIONS = 64


@dataclass(frozen=True, eq=False)
class KnotDerivatives:
    """The knot function with its derivatives prepopulated, and what keeps them alive.

    CasADi's function cache holds weak references: the derivative functions stay in it only while
    `keep_alive` does.
    """

    knot: ca.Function
    jacobian: ca.Function  # u ↦ J(u), u = every knot input stacked
    hessian: ca.Function  # (u, λ) ↦ H(u, λ), λ one multiplier per knot output row
    keep_alive: tuple[ca.Function, ...]


def stacked(values: list[Any]) -> Any:
    return ca.vertcat(*[ca.vec(v) for v in values])


def jacobian_and_hessian(knot: ca.Function) -> tuple[ca.Function, ca.Function]:
    """SX functions J(u) and H(u, λ) of one knot (u: the knot's inputs stacked, λ: its outputs')."""
    sx_in = knot.sx_in()
    u = stacked(sx_in)
    y = stacked(knot.call(sx_in))
    lam = ca.SX.sym("lam", y.shape[0])
    jac = ca.Function(f"J_{knot.name()}", [u], [ca.jacobian(y, u)], ["u"], ["J"])
    hess = ca.Function(
        f"H_{knot.name()}", [u, lam], [ca.hessian(ca.dot(lam, y), u)[0]], ["u", "lam"], ["H"]
    )
    return jac, hess


def with_knot_derivatives(
    knot: ca.Function, jacobian: ca.Function | None = None, hessian: ca.Function | None = None
) -> KnotDerivatives:
    """A copy of the SX `knot` function whose forward/adjoint derivatives are J·Δu, Jᵀ·λ and
    H·Δu + Jᵀ·Δλ (module docstring). `jacobian`/`hessian`: J and H already built or loaded
    (`jacobian_and_hessian` signature), e.g. compiled ones; built here otherwise."""
    if jacobian is None or hessian is None:
        jacobian, hessian = jacobian_and_hessian(knot)
    n_in, n_out = knot.n_in(), knot.n_out()
    names_in = [knot.name_in(i) for i in range(n_in)]
    names_out = [knot.name_out(i) for i in range(n_out)]
    sp_in = [knot.sparsity_in(i) for i in range(n_in)]
    sp_out = [knot.sparsity_out(i) for i in range(n_out)]
    for i, sp in enumerate(sp_in + sp_out):
        if not sp.is_dense():
            raise ValueError(f"knot function {knot.name()}: argument {i} is not dense")

    def syms(prefix: str, names: list[str], sps: list[ca.Sparsity]) -> list[Any]:
        return [ca.MX.sym(prefix + n, sp) for n, sp in zip(names, sps, strict=True)]

    def empty(sps: list[ca.Sparsity], n_dir: int = 1) -> list[ca.Sparsity]:
        return [ca.Sparsity(sp.size1(), sp.size2() * n_dir) for sp in sps]

    def wide(sps: list[ca.Sparsity], n_dir: int) -> list[ca.Sparsity]:
        return [ca.Sparsity.dense(sp.size1(), sp.size2() * n_dir) for sp in sps]

    def seeds(values: list[Any], sps: list[ca.Sparsity], n_dir: int) -> Any:
        """n_dir seeds per argument (argument i: rows_i × cols_i·n_dir) → Σnumel × n_dir."""
        return ca.vertcat(
            *[ca.reshape(v, sp.numel(), n_dir) for v, sp in zip(values, sps, strict=True)]
        )

    def split(matrix: Any, sps: list[ca.Sparsity], n_dir: int) -> list[Any]:
        out, row = [], 0
        for sp in sps:
            block = matrix[row : row + sp.numel(), :]
            out.append(ca.reshape(block, sp.size1(), sp.size2() * n_dir))
            row += sp.numel()
        return out

    # adj1_knot: (u, out_y [empty], adj_y) -> adj_u = Jᵀ·adj_y
    adj_name = f"adj1_{knot.name()}"
    adj_names_in = names_in + [f"out_{n}" for n in names_out] + [f"adj_{n}" for n in names_out]
    adj_names_out = [f"adj_{n}" for n in names_in]
    adj_sp_in = sp_in + empty(sp_out) + sp_out
    adj_cache: dict[str, ca.Function] = {}
    for n_dir in range(1, MAX_DIRECTIONS + 1):
        nominal = syms("", adj_names_in, adj_sp_in)
        results = syms("out_", adj_names_out, empty(sp_in))
        fwd_sp = wide(sp_in, n_dir) + empty(sp_out, n_dir) + wide(sp_out, n_dir)
        fwd = syms("fwd_", adj_names_in, fwd_sp)
        u, lam = stacked(nominal[:n_in]), stacked(nominal[n_in + n_out :])
        du = seeds(fwd[:n_in], sp_in, n_dir)
        dlam = seeds(fwd[n_in + n_out :], sp_out, n_dir)
        sens = ca.mtimes(hessian(u, lam), du) + ca.mtimes(jacobian(u).T, dlam)
        name = f"fwd{n_dir}_{adj_name}"
        adj_cache[name] = ca.Function(
            name,
            nominal + results + fwd,
            split(sens, sp_in, n_dir),
            adj_names_in + [f"out_{n}" for n in adj_names_out] + [f"fwd_{n}" for n in adj_names_in],
            [f"fwd_{n}" for n in adj_names_out],
        )
    nominal = syms("", adj_names_in, adj_sp_in)
    adj_u = ca.mtimes(jacobian(stacked(nominal[:n_in])).T, stacked(nominal[n_in + n_out :]))
    adjoint = ca.Function(
        adj_name, nominal, split(adj_u, sp_in, 1), adj_names_in, adj_names_out,
        {"cache": adj_cache},
    )
    # fwd<n>_knot: (u, out_y [empty], fwd_u) -> fwd_y = J·fwd_u
    cache: dict[str, ca.Function] = {adj_name: adjoint}
    for n_dir in range(1, MAX_DIRECTIONS + 1):
        nominal = syms("", names_in, sp_in)
        results = syms("out_", names_out, empty(sp_out))
        fwd = syms("fwd_", names_in, wide(sp_in, n_dir))
        sens = ca.mtimes(jacobian(stacked(nominal)), seeds(fwd, sp_in, n_dir))
        name = f"fwd{n_dir}_{knot.name()}"
        cache[name] = ca.Function(
            name,
            nominal + results + fwd,
            split(sens, sp_out, n_dir),
            names_in + [f"out_{n}" for n in names_out] + [f"fwd_{n}" for n in names_in],
            [f"fwd_{n}" for n in names_out],
        )
    sx_in = knot.sx_in()
    new = ca.Function(
        knot.name(), sx_in, knot.call(sx_in), names_in, names_out, {"cache": cache}
    )
    keep = (adjoint, *cache.values(), *adj_cache.values())
    return KnotDerivatives(new, jacobian, hessian, keep)

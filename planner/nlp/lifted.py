"""Lifted or eliminated rates and torques of the spacetime NLP (issue #16, a smaller KKT).

By default (`PlannerOptions.lifted_rates`, `lifted_torques`) the base and joint rates v_k,
accelerations a_k and joint torques τ_k are decision variables, tied to the poses by the cyclic
central differences and to the inverse dynamics by equality rows (`planner.nlp.variables`).
Eliminated, they are those expressions themselves: the NLP keeps the same decision-vector
layout (so warm starts, reports and results do not change shape), their slots are fixed at 0
by their bounds — IPOPT removes fixed variables (``fixed_variable_treatment``
``make_parameter``), so it sees neither them nor their equality rows — and a result's warm
start carries the values the expressions take, so a warm start passes between both NLPs.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import casadi as ca
import numpy as np

from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import KnotQuantities, finite_difference_rates
from planner.nlp.variables import LIFTED_LEADING_ROWS, Layout, Symbols


def eliminate_rates(sym: Symbols, n_knots: int, options: PlannerOptions) -> Symbols:
    """`sym` with the eliminated rows of `vel` and `acc` (`PlannerOptions.lifted_rates`)
    replaced by the poses' central differences (unchanged with "all")."""
    kept_vel, kept_acc = LIFTED_LEADING_ROWS[options.lifted_rates]
    if kept_vel is None and kept_acc is None:
        return sym
    vel_fd, acc_fd = finite_difference_rates(sym, n_knots)

    def mixed(lifted: Any, differences: Any, kept: int | None) -> Any:
        if kept is None:
            return lifted
        return ca.vertcat(lifted[:kept, :], differences[kept:, :]) if kept else differences

    return dataclasses.replace(
        sym, vel=mixed(sym.vel, vel_fd, kept_vel), acc=mixed(sym.acc, acc_fd, kept_acc)
    )


def lifted_values_function(sym: Symbols, kq: KnotQuantities) -> ca.Function:
    """(x̃, p) ↦ the lifted part of the decision vector as the NLP's expressions give it:
    rates, accelerations and torques, each knot-major (the `Layout` order)."""
    values = ca.vertcat(ca.vec(sym.vel), ca.vec(sym.acc), ca.vec(kq.tau_nm))
    return ca.Function("lifted_values", [sym.x, sym.p], [values], ["x", "p"], ["lifted"])


def with_lifted_values(
    layout: Layout, x: np.ndarray, values: np.ndarray, mask: np.ndarray
) -> np.ndarray:
    """`x` with its eliminated slots (`mask`) set from `values` (`lifted_values_function`)."""
    out = np.array(x, dtype=float, copy=True)
    if not mask.any():
        return out
    start = layout.n_base + layout.n_q + layout.n_f
    full = np.zeros(layout.size)
    full[start : start + values.size] = np.asarray(values, dtype=float).ravel()
    out[mask] = full[mask]
    return out


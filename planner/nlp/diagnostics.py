"""Which limits bind: constraint violations and multipliers by group at an iterate.

Used to tell the user *why* a request is infeasible ("joint speed: fl_knee needs 1.4× the servo's
limit …") and, for feasible solves, which limits are active (multiplier share by group).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: groups that are physical/servo limits (reported to the user); the rest are model equations
LIMIT_GROUPS = (
    "joint speed",
    "torque envelope",
    "friction",
    "joint limits",
    "swing clearance",
    "body clearance",
    "swing force",
    "tilt",
)
#: limits that are not active in every gait (swing force/friction are trivially active in swing),
#: so their active rows at an infeasible iterate say what ran out
SERVO_LIMITS = ("joint speed", "torque envelope", "joint limits", "tilt")
ACTIVE_TOL = 1e-4
#: At an infeasible iterate (IPOPT stopped before converging) limits are rarely met exactly: a
#: servo limit within this much (group units: rad, or fractions of the servo's limit) counts as
#: the one that ran out when nothing else is violated.
NEAR_TOL = 1e-2

FEASIBILITY_TOL = 1e-4

#: IPOPT return statuses after which the last iterate is used when it meets every constraint
#: within `FEASIBILITY_TOL` (our own check in `judge`): the solver stopped early or could not
#: make progress, but the point it stopped at is a valid (if not proven locally optimal) gait.
#: Before this, a run stopped by the iteration cap with every row met to 1e-8 was reported as
#: "no feasible gait". Statuses that say the problem is infeasible or the numbers broke
#: (Infeasible_Problem_Detected, Invalid_Number_Detected, Diverging_Iterates) are never accepted.
OPTIMAL_STATUSES = ("Solve_Succeeded",)
ACCEPT_IF_FEASIBLE = (
    "Solved_To_Acceptable_Level",
    "Maximum_Iterations_Exceeded",
    "Maximum_CpuTime_Exceeded",
    "Maximum_WallTime_Exceeded",
    "Search_Direction_Becomes_Too_Small",
    "Restoration_Failed",
    "Error_In_Step_Computation",
    "Feasible_Point_Found",
)


def judge(status: str, max_violation: float) -> tuple[bool, bool]:
    """(feasible, optimal) for an IPOPT return status and our own worst constraint violation.

    Feasible: every constraint group and variable bound is met within `FEASIBILITY_TOL` and the
    status is `Solve_Succeeded` or one of `ACCEPT_IF_FEASIBLE`. Optimal: IPOPT also proved the
    point a local optimum to its tolerance (`Solve_Succeeded`).
    """
    met = bool(np.isfinite(max_violation) and max_violation <= FEASIBILITY_TOL)
    feasible = met and (status in OPTIMAL_STATUSES or status in ACCEPT_IF_FEASIBLE)
    return feasible, feasible and status in OPTIMAL_STATUSES


@dataclass(frozen=True)
class GroupReport:
    """One constraint group at an iterate: worst violation (group units), where, multiplier sum."""

    name: str
    max_violation: float
    worst_row: str
    multiplier_sum: float
    n_active: int = 0
    first_active: str = ""
    n_near: int = 0
    first_near: str = ""


def group_reports(
    names_slices: list[tuple[str, slice]],
    g: np.ndarray,
    lbg: np.ndarray,
    ubg: np.ndarray,
    lam_g: np.ndarray,
    labels: dict[str, list[str]],
) -> list[GroupReport]:
    """Violation and |λ| per constraint group (rows of g)."""
    out = []
    for name, sl in names_slices:
        gv, lo, hi = g[sl], lbg[sl], ubg[sl]
        viol = np.maximum(np.maximum(lo - gv, gv - hi), 0.0)
        i = int(np.argmax(viol)) if viol.size else 0
        row_labels = labels.get(name)
        where = row_labels[i] if row_labels is not None and i < len(row_labels) else f"row {i}"
        slack = np.minimum(np.abs(gv - lo), np.abs(gv - hi))
        active = np.flatnonzero(slack <= ACTIVE_TOL)
        near = np.flatnonzero(slack <= NEAR_TOL)

        def label(rows: np.ndarray, labels: list[str] | None = row_labels) -> str:
            if not rows.size:
                return ""
            r = int(rows[0])
            return labels[r] if labels is not None and r < len(labels) else f"row {r}"

        out.append(
            GroupReport(
                name,
                float(viol.max(initial=0.0)),
                where,
                float(np.abs(lam_g[sl]).sum()),
                int(active.size),
                label(active),
                int(near.size),
                label(near),
            )
        )
    return out


@dataclass(frozen=True)
class BoundRows:
    """Rows of a constraint group that the NLP gives IPOPT as variable bounds
    (`planner.nlp.config.PlannerOptions.compact_rows`): row i is x[index[i]] / unit[i] with the
    bounds divided likewise, and they come first in the group's labels (`group_labels`).
    `upper_only`: only the upper bound is the group's (the lower one is another limit's, e.g.
    f_z ≥ 0); the row is then reported as ub − x ≥ 0, as the group's row was."""

    name: str
    index: np.ndarray
    unit: np.ndarray
    upper_only: bool = False


def with_bound_rows(
    names_slices: list[tuple[str, slice]],
    g: np.ndarray,
    lbg: np.ndarray,
    ubg: np.ndarray,
    lam_g: np.ndarray,
    bound_rows: tuple[BoundRows, ...],
    x: np.ndarray,
    lbx: np.ndarray,
    ubx: np.ndarray,
    lam_x: np.ndarray,
) -> tuple[list[tuple[str, slice]], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(slices, g, lbg, ubg, λ_g) with every `BoundRows` put back as rows of its group, in the
    group's units (its multipliers λ_x·unit), before the group's remaining rows; a group with
    no rows left is appended. `group_reports` then reports it as it reported the rows."""
    by_name = {b.name: b for b in bound_rows}
    parts: list[tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def bound_part(b: BoundRows) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        unit = np.asarray(b.unit, dtype=float)
        value, lo, hi = x[b.index] / unit, lbx[b.index] / unit, ubx[b.index] / unit
        lam = lam_x[b.index] * unit
        if b.upper_only:  # ub − x ≥ 0, its multiplier the upper bound's
            return hi - value, np.zeros_like(value), np.full_like(value, np.inf), np.maximum(
                lam, 0.0)
        return value, lo, hi, lam

    for name, sl in names_slices:
        value, lo, hi, lam = g[sl], lbg[sl], ubg[sl], lam_g[sl]
        if name in by_name:
            b_value, b_lo, b_hi, b_lam = bound_part(by_name.pop(name))
            value, lo, hi = np.r_[b_value, value], np.r_[b_lo, lo], np.r_[b_hi, hi]
            lam = np.r_[b_lam, lam]
        parts.append((name, value, lo, hi, lam))
    parts += [(b.name, *bound_part(b)) for b in by_name.values()]
    slices, start = [], 0
    for name, value, *_ in parts:
        slices.append((name, slice(start, start + value.size)))
        start += value.size
    g_all, lb_all, ub_all, lam_all = (np.concatenate([p[i] for p in parts]) if parts
                                      else np.zeros(0) for i in range(1, 5))
    return slices, g_all, lb_all, ub_all, lam_all


def bound_report(
    name: str, x: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, lam_x: np.ndarray, labels: list[str]
) -> GroupReport:
    """The same for a block of variable bounds (e.g. joint limits)."""
    viol = np.maximum(np.maximum(lbx - x, x - ubx), 0.0)
    near = np.minimum(np.abs(x - lbx), np.abs(ubx - x))
    i = int(np.argmax(viol)) if viol.max(initial=0.0) > 0 else int(np.argmin(near))
    active = np.flatnonzero(near <= ACTIVE_TOL)
    close = np.flatnonzero(near <= NEAR_TOL)
    return GroupReport(
        name,
        float(viol.max(initial=0.0)),
        labels[i] if i < len(labels) else f"row {i}",
        float(np.abs(lam_x).sum()),
        int(active.size),
        labels[active[0]] if active.size else "",
        int(close.size),
        labels[close[0]] if close.size else "",
    )


def binding_limits(reports: list[GroupReport], feasible: bool) -> tuple[tuple[str, float], ...]:
    """The limit groups that bind, most binding first.

    Infeasible: the limit groups violated at the last iterate (by violation). Otherwise (or when
    nothing is violated): the limit groups with the largest share of the multipliers.
    """
    limits = [r for r in reports if r.name in LIMIT_GROUPS]
    if not feasible:
        violated = sorted(
            (r for r in limits if r.max_violation > FEASIBILITY_TOL), key=lambda r: -r.max_violation
        )
        saturated = sorted(
            (
                r
                for r in limits
                if r.name in SERVO_LIMITS and r.n_near and r.max_violation <= FEASIBILITY_TOL
            ),
            key=lambda r: (-r.n_active, -r.n_near),
        )
        if violated or saturated:
            return tuple((r.name, r.max_violation) for r in violated) + tuple(
                (r.name, float(r.n_active or r.n_near)) for r in saturated
            )
    total = sum(r.multiplier_sum for r in limits) or 1.0
    active = sorted(
        (r for r in limits if r.multiplier_sum > 1e-3 * total), key=lambda r: -r.multiplier_sum
    )
    return tuple((r.name, r.multiplier_sum / total) for r in active)


def explain(reports: list[GroupReport], binding: tuple[tuple[str, float], ...], status: str) -> str:
    """One-line, user-facing explanation of an infeasible solve."""
    by_name = {r.name: r for r in reports}
    parts = []
    for name, value in binding[:4]:
        r = by_name[name]
        if r.max_violation > FEASIBILITY_TOL:
            parts.append(f"{name} (violated by {r.max_violation:.3g} at {r.worst_row})")
        elif r.name in SERVO_LIMITS and r.n_active:
            parts.append(f"{name} (at its limit in {r.n_active} rows, e.g. {r.first_active})")
        elif r.name in SERVO_LIMITS and r.n_near:
            parts.append(
                f"{name} (within {NEAR_TOL:g} of its limit in {r.n_near} rows, e.g. "
                f"{r.first_near})"
            )
        else:
            parts.append(
                f"{name} ({100 * value:.0f}% of the limit multipliers, e.g. {r.worst_row})"
            )
    equations = sorted(
        (r for r in reports if r.name not in LIMIT_GROUPS and r.max_violation > FEASIBILITY_TOL),
        key=lambda r: -r.max_violation,
    )
    limits = "; ".join(parts) if parts else "no single limit stands out"
    unmet = ", ".join(
        f"{r.name} (residual {r.max_violation:.2g} at {r.worst_row})" for r in equations[:2]
    )
    return f"no feasible gait (IPOPT: {status}); binding limits: {limits}" + (
        f"; left unsatisfied: {unmet}" if unmet else ""
    )

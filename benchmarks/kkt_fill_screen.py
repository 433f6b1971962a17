"""Which parts of the NLP make MUMPS' factor: the KKT matrix of a real solve, screened row group
by row group and structure by structure (issue #16, docs/results/planner_speed_rows.md, s43).

    python benchmarks/kkt_fill_screen.py [--robot quad12] [--speed 0.25] [--gait trot]
        [--knots 30] [--nlp half,full] [--iters 12] [--variants all]

How. One planner with the options `gaitsmith plan ROBOT --search` gives its NLPs
(`gait_search_bench.cli_search_options`, as `half_cycle_bench.py`), one cold solve of the
template with MUMPS' own statistics printed (IPOPT's ``mumps_print_level``): iterations,
numeric factorisations (so factorisations per iteration: inertia corrections), the factor's
doubles (INFO(9)) and MUMPS' own wall time per numeric factorisation. The solver's
constraint Jacobian J and Lagrangian Hessian H are then evaluated at the solution (the
reduced NLP's with ``half``, the full one's with ``full``) and handed, with the solve's
bounds, to IPOPT again as a quadratic program ``min ½xᵀHx + cᵀx, lbg ≤ Jx ≤ ubg`` whose J
and H are parameters of exactly the planner's sparsity (structural zeros included) and
values: IPOPT builds the same augmented KKT system (same fixed variables removed, same
equality / inequality split), MUMPS orders and factorises it. The baseline of that proxy is
checked against the real solve's factor. Each variant then changes the matrices, not the
planner: a row group dropped, the wrap-around (the cyclic knot N−1 → 0; in the half-cycle
NLP the mirrored wrap knot N/2−1 → 0) opened, the rows over all knots removed or written as
running sums with accumulator variables, the Hessian cut to its diagonal (a diagnostic: these
change the problem). Per variant: KKT size (variables, equality and inequality rows), the
factor's doubles, MUMPS' estimated flops and largest front (its analysis statistics) and the
median wall time of its numeric factorisations over ``--iters`` IPOPT iterations.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import re
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

# MUMPS writes through Fortran unit 6: unbuffered, so its lines land in the captured log
os.environ.setdefault("GFORTRAN_UNBUFFERED_PRECONNECTED", "y")
os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import casadi as ca
import numpy as np

#: MUMPS' statistics lines read from a log (``mumps_print_level`` 3 and IPOPT's own lines)
_NUM = r"([0-9.]+(?:[DEde][+-]?[0-9]+)?)"
_PATTERNS = {
    "fact_s": re.compile(r"Elapsed time for factorization\s*=\s*" + _NUM),
    "fact_driver_s": re.compile(r"Elapsed time in factorization driver\s*=\s*" + _NUM),
    "doubles": re.compile(r"INFOG\s*\(\s*9\) Real space for factors\s*=\s*(\d+)"),
    "flops_est": re.compile(r"RINFOG\(1\) Operations during elimination \(estim\)\s*=\s*"
                            + _NUM),
    "flops": re.compile(r"\(3\) Operations in node elimination\s*=\s*" + _NUM),
    "front_max": re.compile(r"INFOG\s*\(11\) Maximum front size\s*=\s*(\d+)"),
    "delayed": re.compile(r"INFOG\s*\(13\) Number of delayed pivots\s*=\s*(\d+)"),
}


@dataclasses.dataclass(frozen=True)
class MumpsLog:
    """What one IPOPT run's log says about MUMPS: per numeric factorisation its wall time,
    doubles, flops, delayed pivots; the analyses' flops estimate and largest front."""

    fact_s: tuple[float, ...]
    fact_driver_s: tuple[float, ...]
    doubles: tuple[int, ...]
    flops: tuple[float, ...]
    delayed: tuple[int, ...]
    flops_est: tuple[float, ...]
    front_max: tuple[int, ...]

    @property
    def factorisations(self) -> int:
        return len(self.fact_driver_s)


def parse_mumps_log(text: str) -> MumpsLog:
    """The MUMPS figures of an IPOPT log printed with ``mumps_print_level`` ≥ 2 (3 for the
    analysis' flops and fronts)."""
    def all_of(key: str, kind: Callable[[str], Any]) -> tuple[Any, ...]:
        return tuple(kind(m.group(1).replace("D", "E").replace("d", "e"))
                     for m in _PATTERNS[key].finditer(text))

    return MumpsLog(all_of("fact_s", float), all_of("fact_driver_s", float),
                    all_of("doubles", int), all_of("flops", float), all_of("delayed", int),
                    all_of("flops_est", float), all_of("front_max", int))


@contextmanager
def captured_stdout() -> Iterator[list[str]]:
    """The C-level stdout (IPOPT, MUMPS) of the block, appended to the yielded list at exit."""
    out: list[str] = []
    with tempfile.TemporaryFile(mode="w+b") as log:
        saved = os.dup(1)
        sys.stdout.flush()
        os.dup2(log.fileno(), 1)
        try:
            yield out
        finally:
            sys.stdout.flush()
            os.dup2(saved, 1)
            os.close(saved)
            log.seek(0)
            out.append(log.read().decode(errors="replace"))


# -- the KKT data of a solve, as triplets -------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class KKTData:
    """A solve's Jacobian J (m × n) and Hessian H (lower triangle, n × n) as triplets with their
    structural zeros, the gradient and bounds, and what each row and variable is."""

    n: int
    m: int
    j_rows: np.ndarray
    j_cols: np.ndarray
    j_vals: np.ndarray
    h_rows: np.ndarray  # ≥ h_cols
    h_cols: np.ndarray
    h_vals: np.ndarray
    grad: np.ndarray
    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    row_group: np.ndarray  # str, one per row
    row_knot: np.ndarray  # int, the row's own knot (its label's), −1 if none
    var_knot: np.ndarray  # int, one per variable; −1: not a knot's (an accumulator)
    n_knots: int  # knots of the variable vector (N, or N/2 for the half-cycle NLP)
    #: per variable: "q", "tau" or "qd" with its joint in `var_joint` (the servo goal's
    #: inputs), "" for any other
    var_kind: np.ndarray | None = None
    var_joint: np.ndarray | None = None
    row_label: np.ndarray | None = None  # str, one per row ("" if none)

    def sizes(self) -> dict[str, int]:
        """IPOPT's view: free variables, equality and inequality rows."""
        free = int(np.sum(self.lbx < self.ubx))
        eq = int(np.sum(self.lbg == self.ubg))
        return {"free": free, "eq": eq, "ineq": self.m - eq, "jac_nnz": int(self.j_rows.size),
                "hess_nnz": int(self.h_rows.size)}


def triplets(dm: ca.DM) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    sp = dm.sparsity()
    r, c = sp.get_triplet()
    return np.asarray(r, dtype=int), np.asarray(c, dtype=int), np.asarray(dm.nonzeros(), float)


def lower_triangle(r: np.ndarray, c: np.ndarray, v: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A symmetric matrix's triplets (full, upper or lower) as its lower triangle."""
    lo, hi = np.maximum(r, c), np.minimum(r, c)
    key = lo.astype(np.int64) * (int(max(lo.max(initial=0), 0)) + 1) + hi
    _, first = np.unique(key, return_index=True)
    return lo[first], hi[first], v[first]


def row_knots_of_labels(labels: list[str | None]) -> np.ndarray:
    from planner.nlp.half_cycle import knot_of_row

    out = []
    for label in labels:
        k = None if label is None else knot_of_row(label)
        out.append(-1 if k is None else int(k))
    return np.asarray(out, dtype=int)


# -- variants ----------------------------------------------------------------------------------


def _replace(d: KKTData, **kw: Any) -> KKTData:
    return dataclasses.replace(d, **kw)


def drop_rows(d: KKTData, drop: np.ndarray) -> KKTData:
    """Without the rows where `drop` (bool, one per row) holds."""
    keep = ~np.asarray(drop, dtype=bool)
    new_index = np.cumsum(keep) - 1
    entry = keep[d.j_rows]
    return _replace(d, m=int(keep.sum()), j_rows=new_index[d.j_rows[entry]],
                    j_cols=d.j_cols[entry], j_vals=d.j_vals[entry], lbg=d.lbg[keep],
                    ubg=d.ubg[keep], row_group=d.row_group[keep], row_knot=d.row_knot[keep],
                    row_label=None if d.row_label is None else d.row_label[keep])


def row_knot_sets(d: KKTData) -> list[set[int]]:
    """The knots each row reads (its variables' knots)."""
    sets: list[set[int]] = [set() for _ in range(d.m)]
    for r, c in zip(d.j_rows, d.j_cols, strict=True):
        k = int(d.var_knot[c])
        if k >= 0:
            sets[r].add(k)
    return sets


def all_knot_rows(d: KKTData) -> np.ndarray:
    """Rows that read more than three knots (drift, mean footprint: sums over the cycle)."""
    return np.asarray([len(s) > 3 for s in row_knot_sets(d)], dtype=bool)


def home_knots(d: KKTData) -> np.ndarray:
    """Each row's own knot: its label's, else the knot most of its entries read."""
    home = d.row_knot.copy()
    counts: dict[int, dict[int, int]] = {}
    for r, c in zip(d.j_rows, d.j_cols, strict=True):
        k = int(d.var_knot[c])
        if k >= 0:
            counts.setdefault(int(r), {}).setdefault(k, 0)
            counts[int(r)][k] += 1
    for r in np.flatnonzero(home < 0):
        if int(r) in counts:
            home[r] = max(counts[int(r)].items(), key=lambda kv: (kv[1], -kv[0]))[0]
    return home


def open_wrap(d: KKTData) -> KKTData:
    """The cycle opened: every Jacobian entry of a (not all-knot) row on a variable more than
    half the knots away from the row's own knot (knot 0's row reading knot K−1, knot K−1's
    reading knot 0) removed, and Hessian entries between such knots. The knots then form a
    chain."""
    home = home_knots(d)
    wide = all_knot_rows(d)
    kc = d.var_knot[d.j_cols]
    far = (~wide[d.j_rows]) & (kc >= 0) & (np.abs(kc - home[d.j_rows]) > d.n_knots // 2)
    ka, kb = d.var_knot[d.h_rows], d.var_knot[d.h_cols]
    hfar = (ka >= 0) & (kb >= 0) & (np.abs(ka - kb) > d.n_knots // 2)
    return _replace(d, j_rows=d.j_rows[~far], j_cols=d.j_cols[~far], j_vals=d.j_vals[~far],
                    h_rows=d.h_rows[~hfar], h_cols=d.h_cols[~hfar], h_vals=d.h_vals[~hfar])


def running_sums(d: KKTData) -> KKTData:
    """Every all-knot row r: Σ_k a_k·x_k ∈ [l, u] written as a chain of accumulators
    s_0 = a_0·x_0, s_k = s_{k−1} + a_k·x_k (k = 1 … K−2) and s_{K−2} + a_{K−1}·x_{K−1} ∈ [l, u]:
    K−1 new free variables and equality rows, the same feasible set; each row then reads two
    neighbouring knots (and a variable of no knot its row's knot's)."""
    wide = np.flatnonzero(all_knot_rows(d))
    if wide.size == 0:
        return d
    j_rows, j_cols, j_vals = [d.j_rows], [d.j_cols], [d.j_vals]
    lbg, ubg, groups, rknots = [d.lbg], [d.ubg], [d.row_group], [d.row_knot]
    var_knot = [d.var_knot]
    n, m = d.n, d.m
    final = np.ones(d.j_rows.size, dtype=bool)
    for r in wide:
        entries = np.flatnonzero(d.j_rows == r)
        knots = d.var_knot[d.j_cols[entries]]
        order = sorted(set(int(k) for k in knots))
        last = order[-1]
        prev = -1
        for k in order[:-1]:  # accumulator s_k: row  s_k − s_prev − a_k·x_k = 0
            at = entries[knots == k]
            final[at] = False
            s = n
            n += 1
            rows = [m] * (at.size + 1 + (prev >= 0))
            cols = [*d.j_cols[at].tolist(), s, *([prev] if prev >= 0 else [])]
            vals = [*(-d.j_vals[at]).tolist(), 1.0, *([-1.0] if prev >= 0 else [])]
            j_rows.append(np.asarray(rows))
            j_cols.append(np.asarray(cols))
            j_vals.append(np.asarray(vals))
            lbg.append(np.zeros(1))
            ubg.append(np.zeros(1))
            groups.append(np.asarray([f"{d.row_group[r]} (sum)"]))
            rknots.append(np.asarray([k]))
            var_knot.append(np.asarray([k]))
            m += 1
            prev = s
        # the original row keeps its last knot's entries and reads the last accumulator
        j_rows.append(np.asarray([r]))
        j_cols.append(np.asarray([prev]))
        j_vals.append(np.asarray([1.0]))
        del last
    keep = final | ~np.isin(d.j_rows, wide)
    j_rows[0], j_cols[0], j_vals[0] = d.j_rows[keep], d.j_cols[keep], d.j_vals[keep]
    extra = n - d.n
    return _replace(
        d, n=n, m=m, j_rows=np.concatenate(j_rows), j_cols=np.concatenate(j_cols),
        j_vals=np.concatenate(j_vals), grad=np.r_[d.grad, np.zeros(extra)],
        x0=np.r_[d.x0, np.zeros(extra)], lbx=np.r_[d.lbx, np.full(extra, -np.inf)],
        ubx=np.r_[d.ubx, np.full(extra, np.inf)], lbg=np.concatenate(lbg),
        ubg=np.concatenate(ubg), row_group=np.concatenate(groups),
        row_knot=np.concatenate(rknots), var_knot=np.concatenate(var_knot),
        row_label=None if d.row_label is None else np.r_[d.row_label, np.full(m - d.m, "")],
        **_more_vars(d, extra))


def _with_equalities(d: KKTData, keep: np.ndarray | None, add_r: list[int], add_c: list[int],
                     add_v: list[float], n: int, group: str, row_knots: Any, var_knots: Any,
                     kind: str = "") -> KKTData:
    """`d` with its Jacobian entries `keep` (None: all) and the new entries (`add_r`, `add_c`,
    `add_v`), n − d.n free variables appended (start 0, no gradient; knots `var_knots`, kind
    `kind`) and one equality row (= 0) of `group` per entry of `row_knots` (their knots)."""
    extra, more = n - d.n, len(row_knots)
    mask = np.ones(d.j_rows.size, dtype=bool) if keep is None else keep
    return _replace(
        d, n=n, m=d.m + more, j_rows=np.r_[d.j_rows[mask], add_r].astype(int),
        j_cols=np.r_[d.j_cols[mask], add_c].astype(int), j_vals=np.r_[d.j_vals[mask], add_v],
        grad=np.r_[d.grad, np.zeros(extra)], x0=np.r_[d.x0, np.zeros(extra)],
        lbx=np.r_[d.lbx, np.full(extra, -np.inf)], ubx=np.r_[d.ubx, np.full(extra, np.inf)],
        lbg=np.r_[d.lbg, np.zeros(more)], ubg=np.r_[d.ubg, np.zeros(more)],
        row_group=np.r_[d.row_group, np.full(more, group)],
        row_knot=np.r_[d.row_knot, row_knots], var_knot=np.r_[d.var_knot, var_knots],
        row_label=None if d.row_label is None else np.r_[d.row_label, np.full(more, "")],
        **_more_vars(d, extra, kind))


def _more_vars(d: KKTData, extra: int, kind: str = "") -> dict[str, Any]:
    if d.var_kind is None or d.var_joint is None:
        return {}
    return {"var_kind": np.r_[d.var_kind.astype(object), np.full(extra, kind, dtype=object)]
            .astype(str),
            "var_joint": np.r_[d.var_joint, np.full(extra, -1)]}


GOAL_GROUPS = ("servo goal limits", "servo goal spline", "servo goal speed")


def lifted_goals(d: KKTData) -> KKTData:
    """The servo goal g = q + τ/k_p + (d/k_p)·q̇ of every joint and knot as a variable with its
    equality row, the servo-goal rows (limits, spline, speed samples) reading g instead of
    q, τ, q̇: the same feasible set; each such row's entries on a joint's q, τ, q̇ become one
    entry on its g (its coefficient on q). The goal rows then couple neighbouring knots
    through g and the slopes only."""
    if d.var_kind is None or d.var_joint is None:
        raise ValueError("lifted_goals needs var_kind and var_joint")
    kind, joint = d.var_kind, d.var_joint
    goal_row = np.isin(d.row_group, GOAL_GROUPS)
    on_goal = goal_row[d.j_rows] & np.isin(kind[d.j_cols], ("q", "tau", "qd"))
    slots: dict[tuple[int, int], int] = {}  # (knot, joint) → new variable
    n = d.n
    coef: dict[tuple[int, int], dict[str, float]] = {}
    add_r, add_c, add_v = [], [], []
    for e in np.flatnonzero(on_goal):
        c = int(d.j_cols[e])
        key = (int(d.var_knot[c]), int(joint[c]))
        if key not in slots:
            slots[key] = n
            n += 1
        coef.setdefault(key, {})
        if kind[c] == "q":
            add_r.append(int(d.j_rows[e]))
            add_c.append(slots[key])
            add_v.append(float(d.j_vals[e]))
    # the goal's own row g − q − τ/k_p − (d/k_p)·q̇ = 0: the coefficients from a limit row
    # (whose row is g itself); the variables of each (knot, joint) found from the entries
    ref: dict[tuple[int, int], dict[str, tuple[int, float]]] = {}
    for e in np.flatnonzero(on_goal):
        c = int(d.j_cols[e])
        key = (int(d.var_knot[c]), int(joint[c]))
        k = str(kind[c])
        if d.row_group[d.j_rows[e]] == "servo goal limits" or k not in ref.get(key, {}):
            ref.setdefault(key, {})[k] = (c, float(d.j_vals[e]))
    m = d.m
    new_rows = []
    for key, g in slots.items():
        new_rows.append(m)
        add_r.append(m)
        add_c.append(g)
        add_v.append(1.0)
        for c, v in ref[key].values():
            add_r.append(m)
            add_c.append(c)
            add_v.append(-v)
        m += 1
    assert len(new_rows) == len(slots) and m == d.m + len(slots)
    knots = [k for k, _ in slots]
    return _with_equalities(d, ~on_goal, add_r, add_c, add_v, n, "servo goal", knots, knots, "g")


def first_order_spline(d: KKTData) -> KKTData:
    """On lifted goals (`lifted_goals`): the spline's cyclic tridiagonal rows (second order:
    knot k reads k − 1 and k + 1) in first-order form with the spline's second derivative M
    at every knot a variable: per interval k two rows, M_k and M_{k+1} each equal to the
    Hermite cubic's second derivative at its ends (reading g_k, s_k, g_{k+1}, s_{k+1}): the C²
    condition, so the same spline. The interval's four variables are read off its speed-sample
    rows. A structural probe: signs across the mirrored wrap are not kept."""
    if d.var_kind is None:
        raise ValueError("first_order_spline needs var_kind")
    kind = d.var_kind
    spline = np.flatnonzero(d.row_group == "servo goal spline")
    speed = np.flatnonzero(d.row_group == "servo goal speed")
    if not np.any(kind == "g"):
        raise ValueError("first_order_spline needs lifted goals")
    # h from a spline row: coefficient on its own s (4/ω₀) over that on a g (3/(h·ω₀))
    e = np.flatnonzero(d.j_rows == spline[0])
    home = d.row_knot[spline[0]]
    cs = [abs(v) for c, v in zip(d.j_cols[e], d.j_vals[e], strict=True)
          if kind[c] == "s" and d.var_knot[c] == home]
    cg = [abs(v) for c, v in zip(d.j_cols[e], d.j_vals[e], strict=True) if kind[c] == "g"]
    h = 3.0 * cs[0] / (4.0 * cg[0])
    intervals: dict[tuple[int, ...], tuple[int, int, int, int]] = {}
    for r in speed:
        cols = d.j_cols[d.j_rows == r]
        if cols.size != 4:
            continue
        k = d.row_knot[r]
        g0 = [int(c) for c in cols if kind[c] == "g" and d.var_knot[c] == k]
        g1 = [int(c) for c in cols if kind[c] == "g" and d.var_knot[c] != k]
        s0 = [int(c) for c in cols if kind[c] == "s" and d.var_knot[c] == k]
        s1 = [int(c) for c in cols if kind[c] == "s" and d.var_knot[c] != k]
        if len(g0) == len(g1) == len(s0) == len(s1) == 1:
            intervals[tuple(sorted(cols.tolist()))] = (g0[0], s0[0], g1[0], s1[0])
    dropped = drop_rows(d, d.row_group == "servo goal spline")
    n, m = dropped.n, dropped.m
    m_of: dict[int, int] = {}  # g column → its knot's M variable
    knots: list[int] = []
    for g0, _, g1, _ in intervals.values():
        for g in (g0, g1):
            if g not in m_of:
                m_of[g] = n
                knots.append(int(d.var_knot[g]))
                n += 1
    add_r: list[int] = []
    add_c: list[int] = []
    add_v: list[float] = []
    for g0, s0, g1, s1 in intervals.values():
        # M_k = (6(g1 − g0)/h − 4 s0 − 2 s1)/h ;  M_{k+1} = (−6(g1 − g0)/h + 2 s0 + 4 s1)/h
        for mv, coeffs in ((m_of[g0], (6, -6, 4, 2)), (m_of[g1], (-6, 6, -2, -4))):
            a_g0, a_g1, a_s0, a_s1 = coeffs
            add_r += [m] * 5
            add_c += [mv, g0, g1, s0, s1]
            add_v += [1.0, a_g0 / h**2, a_g1 / h**2, a_s0 / h, a_s1 / h]
            m += 1
    return _with_equalities(dropped, None, add_r, add_c, add_v, n, "spline ends",
                            np.full(m - dropped.m, -1), knots, "M")


def lifted_feet(d: KKTData) -> KKTData:
    """The stance no-slip rows on lifted foot positions: per (foot, axis, knot) a variable P
    with the row P − FK(pose) = 0 (the no-slip row's own entries on that knot), and each no-slip
    row reading the two P of its knots. The same feasible set (a structural probe: which
    variables the rows between neighbouring knots read)."""
    if d.row_label is None:
        raise ValueError("lifted_feet needs row labels")
    rows = np.flatnonzero(d.row_group == "stance no-slip")
    seen: dict[str, int] = {}
    key_var: dict[tuple[int, int, frozenset[int]], int] = {}
    n, m = d.n, d.m
    drop = np.zeros(d.j_rows.size, dtype=bool)
    add_r: list[int] = []
    add_c: list[int] = []
    add_v: list[float] = []
    new_knots: list[int] = []
    for r in rows:
        label = str(d.row_label[r])
        axis = seen.get(label, 0)
        seen[label] = axis + 1
        home = int(d.row_knot[r])
        entries = np.flatnonzero(d.j_rows == r)
        knots = d.var_knot[d.j_cols[entries]]
        for k in sorted(set(int(v) for v in knots)):
            at = entries[knots == k]
            drop[at] = True
            cols = frozenset(int(c) for c in d.j_cols[at])
            key = (axis, k, cols)
            sign = -1.0 if k == home else 1.0
            if key not in key_var:
                key_var[key] = n
                add_r += [m] * (at.size + 1)
                add_c += [n, *d.j_cols[at].tolist()]
                add_v += [1.0, *(-sign * d.j_vals[at]).tolist()]
                new_knots.append(k)
                n += 1
                m += 1
            add_r.append(int(r))
            add_c.append(key_var[key])
            add_v.append(sign)
    assert len(new_knots) == m - d.m
    return _with_equalities(d, ~drop, add_r, add_c, add_v, n, "foot position", new_knots,
                            new_knots)


def decoupled_knots(d: KKTData) -> KKTData:
    """Every Jacobian entry of a row on a variable of another knot than the row's own removed
    (and the Hessian's between knots): N independent knot blocks, what the factor costs without
    any coupling between knots (a diagnostic)."""
    home = home_knots(d)
    kc = d.var_knot[d.j_cols]
    other = (kc >= 0) & (home[d.j_rows] >= 0) & (kc != home[d.j_rows])
    ka, kb = d.var_knot[d.h_rows], d.var_knot[d.h_cols]
    hother = (ka >= 0) & (kb >= 0) & (ka != kb)
    return _replace(d, j_rows=d.j_rows[~other], j_cols=d.j_cols[~other],
                    j_vals=d.j_vals[~other], h_rows=d.h_rows[~hother],
                    h_cols=d.h_cols[~hother], h_vals=d.h_vals[~hother])


def hessian_diagonal(d: KKTData) -> KKTData:
    """H cut to its diagonal (a diagnostic: how much of the factor the knots' Hessian blocks
    make)."""
    on = d.h_rows == d.h_cols
    return _replace(d, h_rows=d.h_rows[on], h_cols=d.h_cols[on], h_vals=d.h_vals[on])


def permuted(d: KKTData, xp: np.ndarray, gp: np.ndarray) -> KKTData:
    """`d` with its variables in the order `xp` and its rows in the order `gp` (new position →
    old index): a symmetric permutation of the KKT matrix, H kept in its lower triangle."""
    xi, gi = np.argsort(xp), np.argsort(gp)  # new index of old variable / row
    hr, hc = xi[d.h_rows], xi[d.h_cols]
    return _replace(
        d, j_rows=gi[d.j_rows], j_cols=xi[d.j_cols], h_rows=np.maximum(hr, hc),
        h_cols=np.minimum(hr, hc), grad=d.grad[xp], x0=d.x0[xp], lbx=d.lbx[xp], ubx=d.ubx[xp],
        lbg=d.lbg[gp], ubg=d.ubg[gp], row_group=d.row_group[gp], row_knot=d.row_knot[gp],
        row_label=None if d.row_label is None else d.row_label[gp],
        var_knot=d.var_knot[xp],
        var_kind=None if d.var_kind is None else d.var_kind[xp],
        var_joint=None if d.var_joint is None else d.var_joint[xp])


def relabelled(d: KKTData, seed: int) -> KKTData:
    """The same matrices with variables and rows in a random order (a symmetric permutation of
    the KKT matrix: the same factor in exact arithmetic with the same ordering; METIS' ordering
    depends on the labels, so this samples its spread)."""
    rng = np.random.default_rng(seed)
    xp, gp = rng.permutation(d.n), rng.permutation(d.m)
    return permuted(d, xp, gp)


def knot_major(d: KKTData) -> KKTData:
    """The same matrices with the variables and the rows sorted by knot (stable: within a knot
    in their order), the all-knot rows and variables of no knot last: a symmetric permutation
    (the same factor with the same pivot order) that hands METIS the chain in order."""
    home = home_knots(d)
    big = d.n_knots + 1
    xp = np.lexsort((np.arange(d.n), np.where(d.var_knot >= 0, d.var_knot, big)))
    wide = all_knot_rows(d)
    gp = np.lexsort((np.arange(d.m), np.where((home >= 0) & ~wide, home, big)))
    return permuted(d, xp, gp)


def variants(d: KKTData, which: str) -> dict[str, KKTData]:
    """The screen's variants of `d` by name (`which`: "all", or names joined by commas;
    "drop:GROUP" drops one group)."""
    groups = list(dict.fromkeys(d.row_group.tolist()))
    out: dict[str, Callable[[], KKTData]] = {
        "base": lambda: d,
        "open wrap": lambda: open_wrap(d),
        "no all-knot rows": lambda: drop_rows(d, all_knot_rows(d)),
        "all-knot rows as running sums": lambda: running_sums(d),
        "open wrap, no all-knot rows": lambda: drop_rows(open_wrap(d), all_knot_rows(d)),
        "Hessian diagonal": lambda: hessian_diagonal(d),
        "decoupled knots": lambda: decoupled_knots(d),
        "lifted servo goals": lambda: lifted_goals(d),
        "lifted feet": lambda: lifted_feet(d),
        "lifted servo goals and feet": lambda: lifted_feet(lifted_goals(d)),
        "first-order spline": lambda: first_order_spline(d),
        "knot-major order": lambda: knot_major(d),
        "no inequality rows": lambda: drop_rows(d, d.lbg != d.ubg),
    }
    for g in groups:
        out[f"drop:{g}"] = (lambda g=g: drop_rows(d, d.row_group == g))
    names = list(out) if which == "all" else which.split(",")
    unknown = [n for n in names if n not in out]
    if unknown:
        raise SystemExit(f"--variants: unknown {unknown}; known: {', '.join(out)}")
    return {name: out[name]() for name in names}


# -- IPOPT on the proxy QP ---------------------------------------------------------------------


def proxy_solver(d: KKTData, ipopt: dict[str, Any]) -> tuple[Any, np.ndarray]:
    """IPOPT on ``min ½xᵀHx + cᵀx, lbg ≤ Jx ≤ ubg`` with J, H, c parameters of `d`'s sparsity,
    and the parameter vector of `d`'s values."""
    x = ca.MX.sym("x", d.n)
    jn, hn = d.j_rows.size, d.h_rows.size
    pj, ph, pc = ca.MX.sym("pj", jn), ca.MX.sym("ph", hn), ca.MX.sym("pc", d.n)
    jsp = ca.Sparsity.triplet(d.m, d.n, d.j_rows.tolist(), d.j_cols.tolist())
    hsp = ca.Sparsity.triplet(d.n, d.n, d.h_rows.tolist(), d.h_cols.tolist())
    # triplet() sorts the entries column-major: the values must follow the same order
    jorder = np.lexsort((d.j_rows, d.j_cols))
    horder = np.lexsort((d.h_rows, d.h_cols))
    jm = ca.MX(jsp, pj)
    hm = ca.MX(hsp, ph)
    f = ca.dot(pc, x) + ca.dot(x, ca.mtimes(hm, x))  # x'Lx with L's diagonal halved: ½x'Hx
    g = ca.mtimes(jm, x)
    hv = np.where(d.h_rows == d.h_cols, 0.5, 1.0) * d.h_vals
    p = np.r_[d.j_vals[jorder], hv[horder], d.grad]
    solver = ca.nlpsol("kkt_proxy", "ipopt",
                       {"x": x, "p": ca.vertcat(pj, ph, pc), "f": f, "g": g},
                       {"ipopt": ipopt, "print_time": False, "error_on_fail": False})
    return solver, p


@dataclasses.dataclass(frozen=True)
class ProxyRun:
    sizes: dict[str, int]
    log: MumpsLog
    iterations: int
    cpu_s: float


def run_proxy(d: KKTData, ipopt: dict[str, Any]) -> ProxyRun:
    solver, p = proxy_solver(d, ipopt)
    with captured_stdout() as out:
        c0 = time.process_time()
        solver(x0=d.x0, p=p, lbx=d.lbx, ubx=d.ubx, lbg=d.lbg, ubg=d.ubg)
        cpu = time.process_time() - c0
        iterations = int(solver.stats()["iter_count"])
        del solver  # MUMPS' farewell lines inside the capture
    return ProxyRun(d.sizes(), parse_mumps_log(out[0]), iterations, cpu)


# -- the planner side --------------------------------------------------------------------------


class _Recorder:
    """A solver stand-in: calls the casadi nlpsol and keeps its arguments and result."""

    def __init__(self, solver: Any) -> None:
        self.solver = solver
        self.args: dict[str, Any] = {}
        self.out: dict[str, Any] = {}

    def __call__(self, **kw: Any) -> Any:
        self.args = kw
        self.out = self.solver(**kw)
        return self.out

    def stats(self) -> Any:
        return self.solver.stats()


def recording_planner(robot: Any, n_knots: int, options: Any, mumps_print_level: int) -> Any:
    """A `GaitPlanner` (IPOPT's options + ``mumps_print_level``) whose solves record the
    arguments and result of their IPOPT call (``planner.recorder``). The option is added by
    replacing `planner.nlp.spacetime.ipopt_options` for the rest of the process (a benchmark
    script's process: every later planner prints MUMPS' statistics too)."""
    from planner.nlp import spacetime

    base_options = spacetime.ipopt_options

    def with_mumps_print(opts: Any, warm: bool) -> dict[str, Any]:
        return {**base_options(opts, warm), "mumps_print_level": mumps_print_level}

    spacetime.ipopt_options = with_mumps_print  # type: ignore[assignment]

    class Recording(spacetime.GaitPlanner):
        recorder: _Recorder | None = None

        def _half_solver(self, half: Any, warm: bool) -> Any:
            self.recorder = _Recorder(super()._half_solver(half, warm))
            return self.recorder

        def _solver_for(self, warm: bool) -> Any:
            self.recorder = _Recorder(super()._solver_for(warm))
            return self.recorder

    return Recording(robot, n_knots, options)


def kkt_data(planner: Any, half: bool) -> KKTData:
    """J and H of the last solve's NLP at its solution, its bounds and row / variable facts."""
    rec = planner.recorder
    solver = rec.solver
    x = np.asarray(rec.out["x"]).ravel()
    lam_g = np.asarray(rec.out["lam_g"]).ravel()
    p = rec.args["p"]
    jac = solver.get_function("nlp_jac_g")
    hess = solver.get_function("nlp_hess_l")
    jout = jac(x=x, p=p)
    jdm = jout[jac.name_out(1)] if jac.n_out() > 1 else jout[jac.name_out(0)]
    grad_f = solver.get_function("nlp_grad_f")
    gout = grad_f(x=x, p=p)
    grad = np.asarray(gout[grad_f.name_out(1)] if grad_f.n_out() > 1
                      else gout[grad_f.name_out(0)]).ravel()
    hdm = hess(x=x, p=p, lam_f=1.0, lam_g=lam_g)[hess.name_out(0)]
    jr, jc, jv = triplets(jdm)
    hr, hc, hv = lower_triangle(*triplets(hdm))
    layout = planner.layout
    var_knot_full = np.empty(layout.size, dtype=int)
    kind_full = np.full(layout.size, "", dtype=object)
    joint_full = np.full(layout.size, -1)
    from planner.nlp.variables import BLOCKS

    for name in BLOCKS:
        if layout.width(name):
            idx = layout.indices(name)
            var_knot_full[idx] = np.arange(layout.n_knots)[:, None]
            if name in ("q", "tau"):
                kind_full[idx] = name
                joint_full[idx] = np.arange(layout.width(name))[None, :]
            if name == "goal_slope":
                kind_full[idx] = "s"
            if name == "vel":
                kind_full[idx[:, 6:]] = "qd"
                joint_full[idx[:, 6:]] = np.arange(layout.n_joints)[None, :]
    group_full = np.empty(planner._lbg.size, dtype=object)
    label_full: list[str | None] = [None] * planner._lbg.size
    for name, sl in planner._slices:
        group_full[sl] = name
        names = planner._labels.get(name)
        if names is not None and len(names) == sl.stop - sl.start:
            label_full[sl] = names
    if half:
        hc_nlp = planner._half_cycle
        rows = hc_nlp.rows.keep
        var_knot = var_knot_full[hc_nlp.mirror.half]
        kind, joint = kind_full[hc_nlp.mirror.half], joint_full[hc_nlp.mirror.half]
        n_knots = planner.n_knots // 2
    else:
        rows = np.arange(planner._lbg.size)
        var_knot = var_knot_full
        kind, joint = kind_full, joint_full
        n_knots = planner.n_knots
    return KKTData(
        n=x.size, m=int(rows.size), j_rows=jr, j_cols=jc, j_vals=jv, h_rows=hr, h_cols=hc,
        h_vals=hv, grad=grad, x0=np.asarray(rec.args["x0"], float).ravel(),
        lbx=np.asarray(rec.args["lbx"], float).ravel(),
        ubx=np.asarray(rec.args["ubx"], float).ravel(),
        lbg=np.asarray(rec.args["lbg"], float).ravel(),
        ubg=np.asarray(rec.args["ubg"], float).ravel(),
        row_group=np.asarray(group_full[rows].tolist()),
        row_knot=row_knots_of_labels([label_full[r] for r in rows]), var_knot=var_knot,
        n_knots=n_knots, var_kind=np.asarray(kind.tolist()), var_joint=joint,
        row_label=np.asarray([label_full[r] or "" for r in rows]))


def summary(log: MumpsLog) -> str:
    med = statistics.median(log.fact_driver_s) * 1e3 if log.fact_driver_s else float("nan")
    return (f"{log.doubles[0] if log.doubles else -1} doubles, "
            f"flops {log.flops[0] if log.flops else float('nan'):.3g}, front max "
            f"{log.front_max[0] if log.front_max else -1}, {log.factorisations} fact. "
            f"median {med:.2f} ms")


def timed_alternating(which: str, chosen: dict[str, KKTData], ipopt: dict[str, Any],
                      reps: int) -> None:
    """MUMPS' numeric factorisation time of each variant: `reps` proxy runs each, the variants
    alternating run by run; median and quartiles of every factorisation, ratio to the first."""
    times: dict[str, list[float]] = {name: [] for name in chosen}
    cpu: dict[str, list[float]] = {name: [] for name in chosen}
    for _ in range(reps):
        for name, variant in chosen.items():
            run = run_proxy(variant, ipopt)
            times[name] += list(run.log.fact_driver_s)
            cpu[name].append(run.cpu_s / max(run.iterations, 1))
    first = statistics.median(times[next(iter(chosen))])
    print(f"[{which}] | variant | factorisations | median ms | quartiles ms | ratio | "
          f"proxy CPU ms/it (median) |")
    for name, t in times.items():
        q = statistics.quantiles(t, n=4) if len(t) > 1 else [t[0]] * 3
        med = statistics.median(t)
        print(f"[{which}] | {name} | {len(t)} | {med * 1e3:.2f} | {q[0] * 1e3:.2f}–"
              f"{q[2] * 1e3:.2f} | {med / first:.3f} | "
              f"{statistics.median(cpu[name]) * 1e3:.1f} |", flush=True)


def factorisations_per_iteration(robot: Any, args: Any, options: Any) -> None:
    """Cold solves of every template (half-cycle solve as the options say): iterations,
    numeric factorisations, their ratio (> 1: inertia corrections or a singular KKT matrix)."""
    from planner.templates import make_schedule, templates_for

    planner = recording_planner(robot, args.knots, options, 2)
    print("| template | it | factorisations | per it | half | feasible | MUMPS fact. total [s] "
          "| median ms/fact. |")
    print("|---|---|---|---|---|---|---|---|")
    total_it = total_f = 0
    for gait in templates_for(robot):
        try:
            schedule = make_schedule(robot, gait)
            with captured_stdout() as out:
                result = planner.solve(schedule, args.speed, warm_start=False)
        except Exception as exc:  # a stand at a moving command, say
            print(f"| {gait} | refused: {type(exc).__name__} |")
            continue
        log = parse_mumps_log(out[0])
        it = max(result.iterations, 1)
        total_it += result.iterations
        total_f += log.factorisations
        med = statistics.median(log.fact_driver_s) * 1e3 if log.fact_driver_s else float("nan")
        print(f"| {gait} | {result.iterations} | {log.factorisations} | "
              f"{log.factorisations / it:.2f} | {result.stats['half_cycle']} | "
              f"{result.feasible} | {sum(log.fact_driver_s):.3f} | {med:.1f} |", flush=True)
    print(f"| all | {total_it} | {total_f} | {total_f / max(total_it, 1):.2f} | | | | |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--gait", default="trot")
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--nlp", default="half,full", help="half, full or both")
    ap.add_argument("--iters", type=int, default=12, help="IPOPT iterations per proxy run")
    ap.add_argument("--variants", default="all")
    ap.add_argument("--mumps-print-level", type=int, default=3)
    ap.add_argument("--relabel", type=int, default=0,
                    help="also factorise each variant under this many random relabellings "
                         "(METIS' spread): median and range of flops and doubles")
    ap.add_argument("--on", choices=("direct", "lifted"), default="direct",
                    help="the variants' base: the NLP's KKT, or with the servo goals lifted")
    ap.add_argument("--servo-goal-form", default="direct",
                    help="the planner's `PlannerOptions.servo_goal_form` (real solves)")
    ap.add_argument("--time-reps", type=int, default=0,
                    help="only time the variants: this many proxy runs each, alternating, "
                         "every numeric factorisation's MUMPS wall time pooled")
    ap.add_argument("--templates", action="store_true",
                    help="only count factorisations per iteration over the robot's templates")
    args = ap.parse_args(argv)

    from gait_search_bench import cli_search_options

    import robots
    from planner.nlp.spacetime import ipopt_options
    from planner.templates import make_schedule

    robot = robots.load(args.robot)
    options, _ = cli_search_options(robot, speed_m_s=args.speed)
    options = dataclasses.replace(options, servo_goal_form=args.servo_goal_form)
    if args.templates:
        factorisations_per_iteration(robot, args, options)
        return
    schedule = make_schedule(robot, args.gait)
    print(f"{args.robot} {args.gait} {args.speed} m/s N={args.knots}, "
          f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.2f}",
          flush=True)
    proxy_ipopt = {**ipopt_options(options, False), "max_iter": args.iters, "tol": 1e-12,
                   "acceptable_iter": 0, "print_level": 0,
                   "mumps_print_level": args.mumps_print_level}
    for which in args.nlp.split(","):
        half = which == "half"
        opts = dataclasses.replace(options, half_cycle_solve=half)
        planner = recording_planner(robot, args.knots, opts, args.mumps_print_level)
        with captured_stdout() as out:
            c0 = time.process_time()
            result = planner.solve(schedule, args.speed, warm_start=False)
            cpu = time.process_time() - c0
        log = parse_mumps_log(out[0])
        print(f"[{which}] real solve: {result.iterations} it, cost {result.cost:.8g}, "
              f"feasible {result.feasible}, half_cycle {result.stats['half_cycle']}, CPU "
              f"{cpu:.2f} s; {log.factorisations} factorisations "
              f"({log.factorisations / max(result.iterations, 1):.2f}/it), "
              f"{summary(log)}; MUMPS factorisation total "
              f"{sum(log.fact_driver_s):.3f} s", flush=True)
        data = kkt_data(planner, half and bool(result.stats["half_cycle"]))
        print(f"[{which}] | variant | free x | eq rows | ineq rows | jac nnz | hess nnz | "
              f"doubles (INFO 9) | ratio | flops (RINFOG 3) | ratio | max front | fact. | "
              f"median ms/fact. | ratio |")
        if args.on == "lifted":
            data = lifted_goals(data)
        chosen = variants(data, args.variants)
        if args.time_reps:
            timed_alternating(which, chosen, proxy_ipopt, args.time_reps)
            continue
        base: ProxyRun | None = None
        for name, variant in chosen.items():
            run = run_proxy(variant, proxy_ipopt)
            lg = run.log
            if base is None:
                base = run
            med = statistics.median(lg.fact_driver_s) if lg.fact_driver_s else float("nan")
            bmed = statistics.median(base.log.fact_driver_s) if base.log.fact_driver_s else 1.0
            d0 = lg.doubles[0] if lg.doubles else 0
            b0 = base.log.doubles[0] if base.log.doubles else 1
            fl = lg.flops[0] if lg.flops else float("nan")
            bfl = base.log.flops[0] if base.log.flops else float("nan")
            s = run.sizes
            print(f"[{which}] | {name} | {s['free']} | {s['eq']} | {s['ineq']} | "
                  f"{s['jac_nnz']} | {s['hess_nnz']} | {d0} | {d0 / b0:.3f} | {fl:.3g} | "
                  f"{fl / bfl:.3f} | {lg.front_max[0] if lg.front_max else -1} | "
                  f"{lg.factorisations} | {med * 1e3:.2f} | {med / bmed:.3f} |", flush=True)
            if args.relabel:
                runs = [run_proxy(relabelled(variant, seed), {**proxy_ipopt, "max_iter": 1})
                        for seed in range(args.relabel)]
                fls = [r.log.flops[0] for r in runs if r.log.flops]
                dbs = [r.log.doubles[0] for r in runs if r.log.doubles]
                print(f"[{which}] |   {name}, {len(fls)} relabellings | | | | | | "
                      f"median {statistics.median(dbs):.0f} ({min(dbs)}–{max(dbs)}) | | "
                      f"median {statistics.median(fls):.3g} ({min(fls):.3g}–{max(fls):.3g}) "
                      "| | | | | |", flush=True)
    print(f"end {time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

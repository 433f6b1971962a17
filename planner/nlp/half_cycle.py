"""Half-cycle solve: a mirror-symmetric gait's NLP solved on the first half of its knots.

A straight gait of a left–right symmetric body on a schedule that is half-cycle mirror symmetric
at the knots (every foot does half a cycle later what its mirror image does: trot, pace, tripod,
a biped's walk — every sample of the gait search's symmetric timing space) has a symmetric NLP:
the map x ↦ 𝓜x that moves knot k to knot k + N/2 and mirrors it under y → −y (the joint and foot
images of `planner.nlp.mirror` and `planner.templates.mirror_permutation`) takes the feasible set
and the objective to themselves. IPOPT's cold start is symmetric, and a Newton step from a
symmetric point of a symmetric problem is symmetric, so IPOPT's iterates stay on the subspace
x = 𝓜x up to rounding: the gait search's converged 12-knot solves on quad12 are symmetric to
1e-12 (docs/results/planner_speed_search.md, session 36; solves that stop at the iteration cap
drift off it, by rounding amplified along an unstable direction). The two paths take the same
iterates only while the full NLP needs no inertia correction: when IPOPT regularises the full
KKT matrix (δ_w > 0) for negative curvature that lies in the antisymmetric directions, the
reduced matrix has the right inertia without it, and from that iteration on the runs differ
(their ends agree when both converge, 20 of 22 probed pairs; "Session 36 (branch halfzoo)").

On that subspace the second half of the knots is a copy: x = E·x̃, x̃ the first N/2 knots' entries
of every block and E a signed selection (one ±1 per row). The reduced NLP IPOPT solves here is

    min ½·f(E·x̃)   s.t.   lb_r ≤ W·g_r(E·x̃) ≤ ub_r,   E·lbx ≥ …  (the first half's bounds),

with g_r the rows of the first half's knots (each later knot's row is the mirror image of one of
them, so it holds on the subspace by construction) plus the rows over the whole cycle (drift):
one of each mirror pair, none of those that vanish on the subspace (the sideways drift), and
W = ½ on a row that is its own image. The ½ makes it exactly half of the full barrier problem
restricted to the subspace — objective, barrier terms, constraint violation and multipliers
(λ̃ = λ of the kept rows) — so IPOPT's steps, filter and stopping tests see the same numbers as
on the full NLP at a symmetric point. Its derivatives are the full NLP's: J̃ = W·J_r·E and
∇²L̃ = Eᵀ·∇²L(E·x̃; σ/2, λ)·E, with the dropped rows' λ = 0. Assembled from one knot J and H per
knot (`planner.nlp.assembled_jacobian`, `assembled_hessian`), they are built for the kept rows
alone and evaluate the knot, J and H only at the knots those rows read (`reduced_nlp`): the
first N/2 and knot N/2 (the stance no-slip rows of knot N/2 − 1 compare it with the next) — 16
of 30 knots, the same values bit for bit as from all N. The KKT system is half the size, so a
factorisation costs about half (its fill follows the knots' band).

The result is judged on the full NLP: `GaitPlanner._result` evaluates every row and bound of all
N knots at E·x̃ (a schedule or bound that is not symmetric would show there as a violation, not
be hidden). The multipliers of the dropped rows are reported as 0.
Not used when the command turns or side-steps, the schedule is not symmetric at the knots, the
start is not on the subspace (a warm start from an asymmetric plan), the variable bounds are not
mirror images, the NLP is nondimensional (`PlannerOptions.nondimensional`), or the full NLP is
not its own mirror image at a probe point off the subspace (`nlp_mirror_defect`: a body whose
joints and feet mirror but whose masses, inertias or servo limits do not — its half-cycle plan
would break the later half's rows); the full NLP is solved then.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.assembled_hessian import KnotTerm, assembled_hessian
from planner.nlp.assembled_jacobian import assembled_jacobian, at_read_knots
from planner.nlp.variables import BLOCKS, Layout
from robots import Robot

#: base pose (x, y, z, roll, pitch, yaw) under y → −y, x and z relative to the cycle's mean
#: progression (`planner.nlp.mirror.mirror_rows`)
BASE_SIGN = (1.0, -1.0, 1.0, -1.0, 1.0, -1.0)
#: a force under y → −y (polar vector) and a moment (axial vector: −M·m)
FORCE_SIGN = (1.0, -1.0, 1.0)
MOMENT_SIGN = (-1.0, 1.0, -1.0)
#: a start or a bound is on the subspace when E·x̃ reproduces it to this (absolute)
SYMMETRY_TOL = 1e-9
#: rows whose label ends in "@knot k" (k may be fractional: the servo goal's speed samples)
_KNOT_LABEL = re.compile(r"@knot (\d+(?:\.\d+)?)$")


@dataclass(frozen=True)
class VariableMirror:
    """x = E·x̃: full entry i is `sign[i]` × reduced entry `source[i]`; `half` are the full
    indices the reduced vector holds, in order (the first N/2 knots of every block)."""

    source: np.ndarray  # int, one per full entry
    sign: np.ndarray  # ±1.0, one per full entry
    half: np.ndarray  # int, the full indices of the reduced entries

    @property
    def n_reduced(self) -> int:
        return int(self.half.size)

    def matrix(self) -> ca.DM:
        """E as a sparse matrix (full × reduced)."""
        return ca.DM.triplet(list(range(self.source.size)), self.source.tolist(),
                             ca.DM(self.sign), self.source.size, self.n_reduced)

    def expand(self, x_reduced: np.ndarray) -> np.ndarray:
        """E·x̃."""
        return np.asarray(x_reduced, dtype=float)[self.source] * self.sign

    def on_subspace(self, x: np.ndarray) -> bool:
        """Is `x` (full) its own mirror image, E·x[half] = x?"""
        x = np.asarray(x, dtype=float)
        return _same(x, self.expand(x[self.half]))

    def bounds_mirrored(self, lb: np.ndarray, ub: np.ndarray) -> bool:
        """Are the bounds of every later-half entry the (sign-flipped) bounds of its source?"""
        lb_r, ub_r = lb[self.half][self.source], ub[self.half][self.source]
        lo = np.where(self.sign > 0, lb_r, -ub_r)
        hi = np.where(self.sign > 0, ub_r, -lb_r)
        return bool(_same(lo, lb) and _same(hi, ub))


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal to `SYMMETRY_TOL` (relative to max(1, |a|)), infinities of the same sign equal."""
    finite = np.isfinite(a) & np.isfinite(b)
    if not np.array_equal(np.where(finite, 0.0, a), np.where(finite, 0.0, b)):
        return False  # an infinite bound against a finite one, or −∞ against +∞
    fa, fb = np.where(finite, a, 0.0), np.where(finite, b, 0.0)
    return bool(np.all(np.abs(fa - fb) <= SYMMETRY_TOL * np.maximum(1.0, np.abs(fa))))


def element_images(layout: Layout, joint_image: tuple[int, ...], joint_sign: tuple[float, ...],
                   foot_image: tuple[int, ...], flat_feet: tuple[int, ...]
                   ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per block, each per-knot entry's mirror image (index within the knot's entries) and sign."""
    jimg, jsgn = np.asarray(joint_image, dtype=int), np.asarray(joint_sign, dtype=float)
    base_img, base_sgn = np.arange(6), np.asarray(BASE_SIGN)
    rates = (np.concatenate([base_img, 6 + jimg]), np.concatenate([base_sgn, jsgn]))
    feet = np.asarray(foot_image, dtype=int)
    force_img = (3 * feet[:, None] + np.arange(3)[None, :]).ravel()
    force_sgn = np.tile(FORCE_SIGN, feet.size)
    slot = {foot: s for s, foot in enumerate(flat_feet)}
    if any(int(feet[foot]) not in slot for foot in flat_feet):
        raise PlannerConfigError(
            "half-cycle solve: a flat foot's mirror image is not a flat foot; the model is not "
            "left–right symmetric")
    flat_img = np.array([3 * slot[int(feet[foot])] + a for foot in flat_feet for a in range(3)],
                        dtype=int)
    images = {
        "base": (base_img, base_sgn),
        "q": (jimg, jsgn),
        "forces": (force_img, force_sgn),
        "vel": rates,
        "acc": rates,
        "tau": (jimg, jsgn),
        "goal_slope": (jimg, jsgn),
        "moments": (flat_img, np.tile(MOMENT_SIGN, len(flat_feet))),
        "goal": (jimg, jsgn) if layout.lifted_goals else (jimg[:0], jsgn[:0]),
    }
    for name in BLOCKS:
        img, sgn = images[name]
        if img.size != layout.width(name) or sgn.size != layout.width(name):
            raise PlannerConfigError(
                f"half-cycle solve: block {name!r} has {layout.width(name)} entries per knot, "
                f"its mirror map {img.size}")
    return images


def variable_mirror(layout: Layout, images: dict[str, tuple[np.ndarray, np.ndarray]]
                    ) -> VariableMirror:
    """The map E of the module docstring for `layout` (N even)."""
    n = layout.n_knots
    if n % 2:
        raise PlannerConfigError(f"half-cycle solve needs an even number of knots, got {n}")
    h = n // 2
    half = np.concatenate([layout.indices(name)[:h].ravel() for name in BLOCKS])
    half.sort()
    position = np.full(layout.size, -1, dtype=int)
    position[half] = np.arange(half.size)
    source = np.empty(layout.size, dtype=int)
    sign = np.empty(layout.size)
    for name in BLOCKS:
        ind = layout.indices(name)  # N × width
        img, sgn = images[name]
        source[ind[:h]] = position[ind[:h]]
        sign[ind[:h]] = 1.0
        source[ind[h:]] = position[ind[:h][:, img]]
        sign[ind[h:]] = np.broadcast_to(sgn, ind[h:].shape)
    if (source < 0).any():
        raise PlannerConfigError("half-cycle solve: an entry of the second half has no source")
    return VariableMirror(source, sign, half)


def robot_variable_mirror(robot: Robot, layout: Layout, flat_feet: tuple[int, ...]
                          ) -> VariableMirror | None:
    """E for `robot`'s NLP, or None if the body is not left–right symmetric (no joint or foot
    images; `planner.nlp.mirror.joint_mirror`, `planner.templates.mirror_permutation`)."""
    from planner.nlp.mirror import joint_mirror
    from planner.templates import mirror_permutation

    feet = mirror_permutation(robot)
    if feet is None or layout.n_knots % 2:
        return None
    try:
        joints = joint_mirror(robot)
        return variable_mirror(layout, element_images(layout, joints.image, joints.sign, feet,
                                                      flat_feet))
    except PlannerConfigError:
        return None


#: `nlp_mirror_defect` above this (relative to the rows' size) says the NLP is not mirror
#: symmetric enough for a half-cycle solve. Measured (docs/results/planner_speed_template_half.md,
#: session 42, quad12 variants, N = 30 trot): the half-cycle plan broke the later half's rows by
#: 2–8× the defect (one shank 1e-4 heavier: defect 2.4e-6, rows broken by 7.3e-6; the torso's
#: centre of mass 10 µm to the side: 6.0e-5 and 1.2e-4); every built-in and zoo body ≤ 2.2e-16.
#: At 1e-7 an admitted body's half plan misses the full rows by ≲ 1e-6, 1 % of
#: `diagnostics.FEASIBILITY_TOL` (below what its masses are known to); `GaitPlanner.solve`'s
#: full-cycle fallback catches what the probe misjudges
MIRROR_DEFECT_TOL = 1e-7
#: the probe point: the start moved by this fraction of each entry's bound span (or of
#: max(1, |x|) where a bound is infinite), so that it is off the mirror subspace
MIRROR_PROBE_STEP = 0.01


@dataclass(frozen=True)
class MirrorDefect:
    """How far the full NLP is from its own mirror image at a probe point: the worst row group
    (or "objective") and its defect, relative to max(1, the group's largest |row|)."""

    rows: str
    defect: float

    @property
    def symmetric(self) -> bool:
        return self.defect <= MIRROR_DEFECT_TOL


def mirror_involution(mirror: VariableMirror) -> tuple[np.ndarray, np.ndarray]:
    """The full mirror map 𝓜 (knot k ↔ k + N/2, each entry to its y → −y image) as a signed
    permutation of the full vector: (𝓜x)[i] = sign[i] · x[image[i]]. On the subspace 𝓜x = x;
    E pairs each later-half entry with its first-half source, and 𝓜 swaps the two."""
    n = mirror.source.size
    image, sign = np.arange(n), np.ones(n)
    paired = mirror.half[mirror.source]
    later = np.flatnonzero(paired != np.arange(n))
    image[later], sign[later] = paired[later], mirror.sign[later]
    image[paired[later]], sign[paired[later]] = later, mirror.sign[later]
    return image, sign


def probe_point(x: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, seed: int = 0) -> np.ndarray:
    """`x` moved off the mirror subspace by `MIRROR_PROBE_STEP` (seeded: the same probe for
    the same start)."""
    x = np.asarray(x, dtype=float)
    span = np.where(np.isfinite(lbx) & np.isfinite(ubx), ubx - lbx, np.maximum(1.0, np.abs(x)))
    step = MIRROR_PROBE_STEP * np.where(np.isfinite(span), span, 1.0)
    return x + step * np.random.default_rng(seed).standard_normal(x.size)


def nlp_mirror_defect(f_and_g: ca.Function, mirror: VariableMirror, x: np.ndarray,
                      p: np.ndarray, groups: Sequence[tuple[str, slice]]) -> MirrorDefect:
    """Is the full NLP its own mirror image: f(𝓜x) = f(x) and g(𝓜x) a signed permutation of
    g(x) within each row group? `f_and_g`: (x, p) → (f, g); `x` a point off the subspace
    (`probe_point`), `p` a half-cycle symmetric schedule's parameters; `groups`: each row
    group's name and rows. The rows' signed permutation is not needed: within a group the
    sorted |g| of the two points must agree (a lower bound on the rows' own defect, 0 when the
    NLP is symmetric). A body whose joints and feet mirror but whose masses, inertias or servo
    limits do not shows here before any half-cycle solve is spent on it."""
    image, sign = mirror_involution(mirror)
    f1, g1 = f_and_g(x, p)
    f2, g2 = f_and_g(sign * np.asarray(x, dtype=float)[image], p)
    g1, g2 = np.asarray(g1, dtype=float).ravel(), np.asarray(g2, dtype=float).ravel()
    worst = MirrorDefect("objective", abs(float(f1) - float(f2)) / max(1.0, abs(float(f1))))
    for name, rows in groups:
        a, b = np.sort(np.abs(g1[rows])), np.sort(np.abs(g2[rows]))
        if a.size == 0:
            continue
        defect = float(np.max(np.abs(a - b))) / max(1.0, float(a[-1]), float(b[-1]))
        if not np.isfinite(defect) or defect > worst.defect:
            worst = MirrorDefect(name, defect if np.isfinite(defect) else math.inf)
    return worst


def knot_of_row(label: str) -> float | None:
    """The knot a row belongs to from its report label ("…@knot k"), or None."""
    m = _KNOT_LABEL.search(label)
    return None if m is None else float(m.group(1))


#: the rows `PlannerOptions.half_cycle_mirror` adds: met by construction on the subspace
MIRROR_ROWS = "half-cycle mirror"


def first_half_rows(slices: list[tuple[str, slice]], labels: dict[str, list[str]],
                    n_knots: int) -> tuple[list[int], list[int]]:
    """The rows of the first N/2 knots (by their report labels, "…@knot k") and the rows
    without a knot of their own (a group without labels: rows over the whole cycle, for
    `classify_cycle_rows`). `slices`: each constraint group's name and rows."""
    h = n_knots // 2
    keep: list[int] = []
    cycle: list[int] = []
    # each distinct label parsed once (a group's labels repeat: per face, per sample, …)
    known: dict[str, float | None] = {}
    for name, sl in slices:
        if name == MIRROR_ROWS:
            continue
        names = labels.get(name)
        if names is not None and len(names) == sl.stop - sl.start:
            for label in set(names).difference(known):
                known[label] = knot_of_row(label)
            knots = [known[label] for label in names]
        else:
            knots = None
        if knots is None or None in knots:
            cycle.extend(range(sl.start, sl.stop))
            continue
        # int(k) < h for the knots k ≥ 0 of the labels
        first = np.floor(np.asarray(knots, dtype=float)) < h
        keep.extend((sl.start + np.flatnonzero(first)).tolist())
    return keep, cycle


@dataclass(frozen=True)
class RowSelection:
    """The rows of the reduced NLP: `keep` (full row indices, in order) and their weights W."""

    keep: np.ndarray
    weight: np.ndarray

    def lam_full(self, lam_reduced: np.ndarray, n_rows: int) -> np.ndarray:
        """The full NLP's row multipliers: the kept rows' (λ̃, module docstring), 0 elsewhere."""
        out = np.zeros(n_rows)
        out[self.keep] = np.asarray(lam_reduced, dtype=float)
        return out


def classify_cycle_rows(g: np.ndarray, jac_reduced: Any, rows: np.ndarray,
                        lbg: np.ndarray, ubg: np.ndarray) -> tuple[list[int], list[float]]:
    """Rows over the whole cycle (no knot of their own): at a point of the subspace, a row
    whose reduced Jacobian row and value vanish is dropped (its mirror image is its negative),
    one of two rows that agree up to sign (value, reduced Jacobian and bounds) is kept with
    W = 1, a row equal to no other is its own image: kept with W = ½."""
    jac = ca.DM(jac_reduced)
    dense = np.asarray(ca.densify(jac[rows.tolist(), :]))
    keep: list[int] = []
    weight: list[float] = []
    taken: set[int] = set()
    for a, row in enumerate(rows):
        if a in taken:
            continue
        ja, va = dense[a], g[row]
        scale = max(1.0, float(np.abs(ja).max(initial=0.0)), abs(float(va)))
        if np.abs(ja).max(initial=0.0) <= 1e-12 * scale and abs(va) <= 1e-12 * scale:
            continue
        partner = None
        for b in range(a + 1, len(rows)):
            if b in taken:
                continue
            for s in (1.0, -1.0):
                lo, hi = (lbg[row], ubg[row]) if s > 0 else (-ubg[row], -lbg[row])
                if (np.allclose(dense[b], s * ja, rtol=1e-8, atol=1e-12 * scale)
                        and math.isclose(g[rows[b]], s * va, rel_tol=1e-8, abs_tol=1e-12 * scale)
                        and _same(np.array([lbg[rows[b]], ubg[rows[b]]]), np.array([lo, hi]))):
                    partner = b
                    break
            if partner is not None:
                break
        if partner is not None:
            taken.add(partner)
        keep.append(int(row))
        weight.append(1.0 if partner is not None else 0.5)
    return keep, weight


@dataclass
class HalfCycleNLP:
    """The reduced NLP (module docstring) of a planner's full NLP and its IPOPT instance."""

    mirror: VariableMirror
    rows: RowSelection
    solver: Any
    abort: Any | None = None
    #: the reduced NLP and its nlpsol options, for an IPOPT instance with the warm options
    #: (`PlannerOptions.warm_half_cycle`), created at its first warm solve
    nlp: dict[str, Any] | None = None
    solver_options: dict[str, Any] | None = None
    warm_solver: Any | None = None


def reduced_nlp(mirror: VariableMirror, rows: RowSelection, x: Any, p: Any, f: Any, g: Any,
                jac_g: ca.Function | None, hess_l: ca.Function | None,
                knot_terms: Sequence[KnotTerm] = (), n_knots: int = 0, *,
                assembled: tuple[bool, bool] | None = None,
                ) -> tuple[dict[str, Any], dict[str, ca.Function]]:
    """The reduced NLP's expressions (``x``, ``p``, ``f``, ``g``) and, when the full NLP has
    them, its assembled ``jac_g`` and ``hess_lag`` functions (module docstring) from the full
    NLP's symbols `x`, `p`, objective `f`, rows `g` and derivative functions.

    `knot_terms` (the full NLP's per-knot calls with their J and H, the knot's first, as
    `assembled_hessian` takes them; `n_knots` its knots): the reduced functions evaluate each
    only at the knots whose outputs the kept rows and f read — the first half's and the knot
    after it (the stance no-slip rows compare knot k with k + 1) — with J and ∇²L assembled for
    the kept rows alone (`assembled_jacobian`, `assembled_hessian` with `knots_read_only`),
    instead of calling the full NLP's `jac_g` and `hess_l` (every knot and row, half of them
    thrown away). The same values, bit for bit where measured (quad12, hex18, the biped;
    tests/planner/nlp/test_half_cycle.py, docs/results/planner_speed_halfeval.md).

    `assembled`: with `knot_terms`, whether the full NLP has its ``jac_g`` and ``hess_lag``
    (then `jac_g` and `hess_l` themselves are not used and may be None: the planner builds the
    full NLP's only for a full solve); None: whether `jac_g` and `hess_l` are given."""
    e = mirror.matrix()
    xr = ca.MX.sym("x_half", mirror.n_reduced)
    pr = ca.MX.sym("p", p.shape[0], p.shape[1])
    keep = rows.keep.tolist()
    f_read, g_kept = f, g[keep]
    if knot_terms:
        f_read, g_kept = at_read_knots([f, g_kept], knot_terms[0][0], n_knots)
    # two functions: one of both would make IPOPT's f and ∇f evaluate every row too
    objective = ca.Function("full_f", [x, p], [f_read])
    rows_of = ca.Function("kept_g", [x, p], [g_kept])
    x_full = ca.mtimes(e, xr)
    w = ca.DM(rows.weight)
    nlp = {"x": xr, "p": pr, "f": 0.5 * objective(x_full, pr), "g": w * rows_of(x_full, pr)}
    has_jac, has_hess = (jac_g is not None, hess_l is not None) if (
        assembled is None or not knot_terms) else assembled
    derivatives: dict[str, ca.Function] = {}
    if has_jac:
        if knot_terms:
            call, jacobian, _ = knot_terms[0]
            g_j, jac = assembled_jacobian(x, p, g[keep], call, jacobian, n_knots,
                                          knots_read_only=True)(x_full, pr)
        else:
            assert jac_g is not None
            g_j, jac = jac_g(x_full, pr)
            g_j, jac = g_j[keep], jac[keep, :]
        jac_r = ca.mtimes(ca.diag(w), ca.mtimes(jac, e))
        derivatives["jac_g"] = ca.Function("nlp_jac_g", [xr, pr], [w * g_j, jac_r],
                                           ["x", "p"], ["g", "jac_g_x"])
    if has_hess:
        lam_f = ca.MX.sym("lam_f")
        lam_g = ca.MX.sym("lam_g", rows.keep.size)
        if knot_terms:
            hess = assembled_hessian(x, p, f, g[keep], knot_terms, n_knots,
                                     knots_read_only=True)(x_full, pr, 0.5 * lam_f, w * lam_g)
        else:
            assert hess_l is not None
            n_rows = int(g.shape[0])
            select = ca.DM.triplet(keep, list(range(rows.keep.size)),
                                   ca.DM.ones(rows.keep.size), n_rows, rows.keep.size)
            hess = hess_l(x_full, pr, 0.5 * lam_f, ca.mtimes(select, w * lam_g))
        sym_hess = ca.triu2symm(hess)
        hess_r = ca.triu(ca.mtimes(e.T, ca.mtimes(sym_hess, e)))
        derivatives["hess_lag"] = ca.Function(
            "nlp_hess_l", [xr, pr, lam_f, lam_g], [hess_r], ["x", "p", "lam_f", "lam_g"],
            ["triu_hess_gamma_x_x"])
    return nlp, derivatives

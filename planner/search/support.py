"""Open-loop tipping of a contact schedule: the support term of the gait search.

The spacetime NLP has exact whole-body dynamics, so it can balance a robot on a *support line* —
two feet (a trot's diagonal pair, a pace's lateral pair) or any set of collinear feet — by
keeping the centre of pressure exactly on that line. That is an unstable equilibrium. The
position servos play the gait open loop, so an error e₀ of the centre of mass across the line
grows like the linear inverted pendulum, e(t) = e₀·cosh(t/τ) with τ = √(h/g) (Kajita et al.
2001, the LIP with zero initial error velocity), until a foot lands and widens the support.
Three or more non-collinear feet span a polygon of non-zero width in which the contact forces
absorb the error; flight phases are ballistic and tip nothing.

`tipping_amplification` sums (cosh(T_i/τ) − 1) over the line-support runs i of one cycle: 0 for
a gait that always stands on a polygon (a walk with duty ≥ 0.75), about 2·(T/τ)²/2 for a trot
with short swings, and it grows exponentially once a swing outlasts τ (quad12: τ ≈ 0.14 s).
MuJoCo with the servo model shows the cost of long line phases as lost speed rather than falls:
a quad12 duty-0.6 trot planned for 0.2 m/s achieves 0.212, 0.202, 0.181, 0.162 and 0.162 m/s
with two-foot phases of 0.14, 0.19, 0.28, 0.36 and 0.48 s (12 cycles each, 2026-11-25).

Simplifications (documented, deliberate): the polygon is judged from the feet's *nominal* stance
positions (a foot's stance position moves by half a stride, which does not make three quad12
feet collinear); the CoM is assumed inside the polygon whenever one exists (the NLP's unilateral
contact forces put the centre of pressure there); errors do not carry across polygon phases.
The term depends on the timing only, so basin-CMA adds it to the projected cost: the NLP cannot
change timings (W&P §4.1.2), and f(g(x)) + r(x) is still a function of the timing x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from robots import ContactSchedule, Robot

GRAVITY_M_S2 = 9.81
#: A stance set whose largest triangle covers less than this fraction of the full footprint
#: (the largest triangle of all feet) counts as a support line.
LINE_AREA_FRACTION = 0.05


@dataclass(frozen=True)
class SupportPhase:
    """A maximal interval of one cycle with a constant set of stance feet."""

    start_phase: float
    duration_s: float
    stance: tuple[int, ...]
    kind: str  # "polygon", "line" (1 or 2 feet, or collinear feet) or "flight"


def _largest_triangle_area_m2(points_xy: np.ndarray) -> float:
    best = 0.0
    for a, b, c in combinations(range(len(points_xy)), 3):
        u, v = points_xy[b] - points_xy[a], points_xy[c] - points_xy[a]
        best = max(best, 0.5 * abs(float(u[0] * v[1] - u[1] * v[0])))
    return best


def support_phases(schedule: ContactSchedule, feet_xy_m: np.ndarray) -> tuple[SupportPhase, ...]:
    """The cycle split at every touchdown and lift-off, each piece classified by its support.

    `feet_xy_m` (F × 2) are the nominal stance foot positions in the body frame.
    """
    feet_xy_m = np.asarray(feet_xy_m, dtype=float)[:, :2]
    td = np.asarray(schedule.touchdown_phase)
    lo = (td + np.asarray(schedule.duty_factor)) % 1.0
    events = np.unique(np.r_[td, lo, 0.0] % 1.0)
    footprint = _largest_triangle_area_m2(feet_xy_m)
    phases: list[SupportPhase] = []
    for start, end in zip(events, np.r_[events[1:], 1.0], strict=True):
        if end - start <= 1e-12:
            continue
        mid = 0.5 * (start + end)
        stance = tuple(f for f in range(schedule.n_feet) if schedule.in_stance(f, mid))
        if not stance:
            kind = "flight"
        elif _largest_triangle_area_m2(feet_xy_m[list(stance)]) < LINE_AREA_FRACTION * footprint:
            kind = "line"
        else:
            kind = "polygon"
        phases.append(SupportPhase(float(start), float((end - start) * schedule.period_s),
                                   stance, kind))
    # the cycle wraps: merge the last piece into the first when they share a stance set
    if len(phases) > 1 and phases[0].stance == phases[-1].stance:
        last = phases.pop()
        first = phases[0]
        phases[0] = SupportPhase(last.start_phase, first.duration_s + last.duration_s,
                                 first.stance, first.kind)
    return tuple(phases)


def tipping_time_constant_s(com_height_m: float) -> float:
    """τ = √(h/g) of the linear inverted pendulum of height `com_height_m`."""
    if not (math.isfinite(com_height_m) and com_height_m > 0):
        raise ValueError(f"CoM height must be a positive number of metres, got {com_height_m!r}")
    return math.sqrt(com_height_m / GRAVITY_M_S2)


def tipping_amplification(
    schedule: ContactSchedule, feet_xy_m: np.ndarray, com_height_m: float
) -> float:
    """Σ over the cycle's line-support phases of cosh(T_i/τ) − 1 (0: never on a line)."""
    tau = tipping_time_constant_s(com_height_m)
    return float(sum(math.cosh(t / tau) - 1.0 for t in line_support_durations_s(
        schedule, feet_xy_m)))


def line_support_durations_s(schedule: ContactSchedule, feet_xy_m: np.ndarray) -> list[float]:
    """Durations of the cycle's uninterrupted line-support runs.

    Consecutive line phases form one run (a gallop's one-foot → two-foot → one-foot sequence
    keeps tipping): only a polygon or a flight phase ends it.
    """
    phases = support_phases(schedule, feet_xy_m)
    if all(p.kind == "line" for p in phases):
        return [schedule.period_s]
    # rotate so the cycle starts at a non-line phase; then runs never wrap around
    first = next(i for i, p in enumerate(phases) if p.kind != "line")
    runs: list[float] = []
    current = 0.0
    for p in phases[first:] + phases[:first]:
        if p.kind == "line":
            current += p.duration_s
        elif current > 0.0:
            runs.append(current)
            current = 0.0
    if current > 0.0:
        runs.append(current)
    return runs


@dataclass(frozen=True)
class PolygonEdge:
    """A possible edge i → j of a stance polygon, feet in counter-clockwise order.

    It is an edge of the stance set S exactly when i, j ∈ S, no foot of `between` (those after
    i and before j going counter-clockwise) is in S, and some foot of `beyond` (the rest, after
    j and before i) is: then S has ≥ 3 feet and lies on the left of i → j.
    """

    i: int
    j: int
    between: tuple[int, ...]
    beyond: tuple[int, ...]

    def active(self, stance: np.ndarray) -> bool:
        """Is this an edge of the polygon of the stance feet `stance` (F booleans)?"""
        s = np.asarray(stance, dtype=bool)
        return bool(s[self.i] and s[self.j] and not s[list(self.between)].any()
                    and s[list(self.beyond)].any())


def polygon_edges(feet_xy_m: np.ndarray) -> tuple[PolygonEdge, ...]:
    """Every ordered pair of feet as a `PolygonEdge`, the feet ordered counter-clockwise by
    their angle about the centroid of `feet_xy_m` (F × 2, nominal stance, body frame).

    The order is that of the nominal footprint, so the edges are exact while the feet stay in
    convex position around the body (legs do not cross); a stance set of collinear feet has
    edges both ways and no interior (the planner constrains polygon knots only).
    """
    xy = np.asarray(feet_xy_m, dtype=float)[:, :2]
    centre = xy.mean(axis=0)
    order = [int(f) for f in np.argsort(np.arctan2(xy[:, 1] - centre[1], xy[:, 0] - centre[0]))]
    n = len(order)
    edges = []
    for a in range(n):
        for step in range(1, n):
            b = (a + step) % n
            between = tuple(order[(a + s) % n] for s in range(1, step))
            beyond = tuple(order[(b + s) % n] for s in range(1, n - step))
            edges.append(PolygonEdge(order[a], order[b], between, beyond))
    return tuple(edges)


def static_margin_m(com_xy_m: np.ndarray, feet_xy_m: np.ndarray, stance: np.ndarray,
                    edges: tuple[PolygonEdge, ...]) -> float | None:
    """Signed distance of the CoM inside the polygon of the stance feet (None: no polygon)."""
    com, xy = np.asarray(com_xy_m, dtype=float), np.asarray(feet_xy_m, dtype=float)[:, :2]
    best: float | None = None
    for e in edges:
        if e.active(stance):
            u, v = xy[e.j] - xy[e.i], com - xy[e.i]
            d = float(u[0] * v[1] - u[1] * v[0]) / float(np.hypot(*u))
            best = d if best is None else min(best, d)
    return best


@dataclass(frozen=True)
class TippingCost:
    """`weight` × `tipping_amplification` for one robot: the search's support term.

    `com_height_m` is the nominal stance height of the base (the LIP height), `feet_xy_m` the
    nominal stance foot positions (F × 2, body frame).
    """

    feet_xy_m: tuple[tuple[float, float], ...]
    com_height_m: float
    weight: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.weight) and self.weight >= 0):
            raise ValueError(f"tipping weight must be a finite number ≥ 0, got {self.weight!r}")
        tipping_time_constant_s(self.com_height_m)  # validates the height

    @staticmethod
    def for_robot(robot: Robot, weight: float) -> TippingCost:
        from planner.templates import stance_foot_positions_m

        xy = stance_foot_positions_m(robot)[:, :2]
        return TippingCost(tuple((float(x), float(y)) for x, y in xy),
                           float(robot.stance_base_height_m), float(weight))

    def amplification(self, schedule: ContactSchedule) -> float:
        return tipping_amplification(schedule, np.asarray(self.feet_xy_m), self.com_height_m)

    def __call__(self, schedule: ContactSchedule) -> float:
        return self.weight * self.amplification(schedule) if self.weight > 0 else 0.0


__all__ = [
    "LINE_AREA_FRACTION",
    "PolygonEdge",
    "SupportPhase",
    "TippingCost",
    "line_support_durations_s",
    "polygon_edges",
    "static_margin_m",
    "support_phases",
    "tipping_amplification",
    "tipping_time_constant_s",
]

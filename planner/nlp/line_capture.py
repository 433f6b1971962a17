"""Line-capture margin: on two-foot support the capture point leans toward the next touchdown.

A robot standing on two point feet stands on a *support line*. Its centre of mass moves like a
linear inverted pendulum across that line (Kajita et al. 2001), and the instantaneous capture
point ξ = c + ċ/ω, ω = √(g/h) (Pratt et al. 2006; Hof's extrapolated centre of mass, 2008)
diverges from the line as ξ̇ = ω·(ξ − p), p the centre of pressure, which contact forces can
only put *on* the line. So the side of the line ξ is on decides which way the body falls,
whatever the legs do, until another foot lands. The spacetime NLP has exact dynamics and plans
such phases as controlled falls toward the foot that lands next; the position servos play them
open loop, and MuJoCo does not start every fall where the plan does.

Measured on knee8 (8 × STS3215 with the identified 0.0284 kg·m² rotor, hip-and-knee legs,
duty-0.6 lateral-sequence walk at 0.182 m/s, docs/results/heavy_rotor.md §7): the plan starts
its diagonal-support phase with ξ 15 mm toward the front foot that lands next; in MuJoCo it
starts on the line (2.9 mm, cycle mean) and grows to only 15 mm where the plan has 58 mm, so
the body stays over the hind corner whose foot has just lifted: pitched 9° nose-up, that
swinging hind foot scuffs the ground through a third of its swing and the front foot lands
0.13 cycle late (the robot makes 0.162 of 0.182 m/s). Stiffer servos (×2) change none of it;
the joints track the plan to 1–3°.

The rows: at every knot where exactly two feet i, j stand, with u the line from i to j and d(ξ)
the signed distance of the capture point from it,

    S_ij(k)·d(ξ_k) ≥ |S_ij(k)|·m,        S_ij(k) = Σ_f w_f(k)·side_ij(f)

over the swing feet f, side_ij(f) = ±1 the side of the line f's nominal stance position is on,
and w_f(k) = Σ_{j≥1} γ^(j−1)·[f swings from k to k+j−1 and stands at k+j]: ≈ 1 for the foot that
lands first, γ < 1/2 times less for each knot later (`next_touchdown_weights`). So the capture
point must lie at least m on the side where the next foot lands. Feet landing on the same knot
on both sides of the line (a trot's diagonal pair) give S = 0: no row in force, since neither
side is the safe one. Knots with other stance counts have no row in force (their factor is 0),
so one build serves every schedule, as the static-margin rows do; the rows not in force for
the schedule being solved are freed (bounds ±inf) for that solve (`rows_in_force`), since a
row that is identically 0 ≥ 0 is a degenerate active constraint for IPOPT (bittle8's walk,
which has no two-foot knot at all, stopped at the iteration cap with them bounded). Robots
with fewer than three feet have no rows (a biped's support is one foot, a point or a sole,
not a line).

ċ is the central difference of the centre of mass over the cycle in the world (the stance feet
are at rest there; `planner.nlp.command` frames), h the robot's nominal stance height
(`Robot.stance_base_height_m`, the height `planner.search.support` uses for its tipping time
constant).

Not from W&P 2009 (no actuator or open-loop model there); the margin m is this project's, set
by `PlannerOptions.line_capture_margin_leg_lengths` (m/L).
"""

from __future__ import annotations

import math
from itertools import combinations
from typing import Any

import casadi as ca
import numpy as np

from planner.nlp.config import GRAVITY_M_S2
from planner.nlp.variables import cyclic_shift

#: γ of `next_touchdown_weights`: below 1/2, so the first foot to land outweighs all later ones
NEXT_TOUCHDOWN_DECAY = 0.3


def next_touchdown_weights(contact: Any, gamma: float = NEXT_TOUCHDOWN_DECAY) -> list[Any]:
    """Per foot, a 1 × N row: w_f(k) = Σ_{j≥1} γ^(j−1)·[f is in swing at k … k+j−1 and in stance
    at k+j] (cyclic), for a 0/1 contact matrix F × N (numbers or CasADi expressions). 0 for a
    foot in stance at k; γ^(j−1) for a swing foot that lands j knots later."""
    if not 0.0 < gamma < 0.5:
        raise ValueError(f"the decay must be in (0, 1/2), got {gamma!r}")
    n = int(contact.shape[1])
    out = []
    for f in range(int(contact.shape[0])):
        row = contact[f, :]
        swinging = 1 - row
        w = 0 * row
        for j in range(1, n):
            w = w + gamma ** (j - 1) * swinging * cyclic_shift(row, j)
            swinging = swinging * (1 - cyclic_shift(row, j))
        out.append(w)
    return out


def line_sides(feet_xy_m: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """For every pair i < j of feet: side_ij(f) = ±1 (0 on the line) of every foot f's nominal
    position relative to the line from i to j (left of i → j: +1)."""
    xy = np.asarray(feet_xy_m, dtype=float)[:, :2]
    out = {}
    for i, j in combinations(range(len(xy)), 2):
        u = xy[j] - xy[i]
        rel = xy - xy[i]
        out[(i, j)] = np.sign(u[0] * rel[:, 1] - u[1] * rel[:, 0])
    return out


def capture_point(com_m: Any, com_next_xy: tuple[Any, Any], com_prev_xy: tuple[Any, Any],
                  inv_h: Any, omega: float) -> tuple[Any, Any]:
    """ξ = c + ċ/ω in x, y, with ċ the central difference of the neighbours (already in knot
    k's frame: `planner.nlp.command`) over 2h (`inv_h` = 1/h)."""
    vx = (com_next_xy[0] - com_prev_xy[0]) * (0.5 * inv_h)
    vy = (com_next_xy[1] - com_prev_xy[1]) * (0.5 * inv_h)
    return com_m[0, :] + vx / omega, com_m[1, :] + vy / omega


def line_capture_rows(contact: Any, feet_m: Any, icp_xy: tuple[Any, Any],
                      nominal_xy_m: np.ndarray, margin_m: float,
                      gamma: float = NEXT_TOUCHDOWN_DECAY) -> Any:
    """The rows (module docstring), pairs in `combinations` order, each 1 × N, stacked and
    vectorised knot-major (knot k's rows together). `feet_m`: 3F × N foot positions (x, y, z per
    foot), `icp_xy`: the capture point's x, y (1 × N each). Each row ≥ 0."""
    nf = int(contact.shape[0])
    weights = next_touchdown_weights(contact, gamma)
    sides = line_sides(nominal_xy_m)
    fx, fy = feet_m[0::3, :], feet_m[1::3, :]
    rows = []
    for (i, j), side_of in sides.items():
        others = [f for f in range(nf) if f not in (i, j)]
        active = contact[i, :] * contact[j, :]
        s = 0 * active
        for f in others:
            active = active * (1 - contact[f, :])
            s = s + float(side_of[f]) * weights[f]
        ux, uy = fx[j, :] - fx[i, :], fy[j, :] - fy[i, :]
        norm = ca.sqrt(ux * ux + uy * uy + 1e-12)
        d = (ux * (icp_xy[1] - fy[i, :]) - uy * (icp_xy[0] - fx[i, :])) / norm
        rows.append(active * (s * d - ca.fabs(s) * margin_m))
    return ca.vec(ca.vertcat(*rows))


def rows_in_force(contact: np.ndarray, nominal_xy_m: np.ndarray,
                  gamma: float = NEXT_TOUCHDOWN_DECAY) -> np.ndarray:
    """Which rows of `line_capture_rows` (same order) constrain anything for this 0/1 contact
    matrix (F × N): a knot where exactly that pair stands and the next touchdown has a side
    (S ≠ 0). The others are identically 0 ≥ 0 — constraints with a zero gradient, which IPOPT
    must carry as degenerate active rows; the planner frees them (bounds ±inf) per solve."""
    c = ca.DM(np.asarray(contact, dtype=float))
    nf, n = c.shape
    zeros = ca.DM.zeros(3 * nf, n)
    icp = (ca.DM.zeros(1, n), ca.DM.zeros(1, n))
    rows = np.asarray(ca.DM(line_capture_rows(c, zeros, icp, nominal_xy_m, 1.0, gamma))).ravel()
    return rows < 0  # = −active·|S| with the capture point on the line and m = 1


def lip_rate_s(height_m: float, gravity_m_s2: float = GRAVITY_M_S2) -> float:
    """ω = √(g/h) [1/s] of the linear inverted pendulum of height `height_m`."""
    if not (math.isfinite(height_m) and height_m > 0):
        raise ValueError(f"pendulum height must be a positive number of metres, got {height_m!r}")
    return math.sqrt(gravity_m_s2 / height_m)


def line_capture_labels(foot_names: tuple[str, ...], n_knots: int) -> list[str]:
    """Row labels in `line_capture_rows` order."""
    pairs = list(combinations(foot_names, 2))
    return [f"{a}-{b} line@knot {k}" for k in range(n_knots) for a, b in pairs]

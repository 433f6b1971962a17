"""Feet keep apart: neighbouring feet may not cross or overlap (a self-collision row).

The simulator's legs do not collide with each other (only feet touch the ground), and nothing
else in the NLP stops two feet from sharing the same patch of ground. A biped exploits that: its
cheapest walk puts each foot under the centre of mass, so the planned feet *crossed* (biped, 0.1
m/s: left sole centre at y = −0.03 m, right at +0.03 m, soles 75 mm wide) — a gait no real build
can play. Here each pair of feet that stand close together keeps, at every knot, its separation
along the direction between them at the nominal stance:

    (p_j − p_i)_h · u_ij ≥ e_i(u_ij) + e_j(u_ij) + g,

with p the contact points (sole centres of flat feet), (·)_h their horizontal offset in the base's
heading frame (rotated by −yaw), u_ij the unit horizontal direction from foot i to foot j at the
stance, e the foot's extent along u (a sphere: its radius; a flat sole with half length l and
half width w: l·|a·u| + w·|b·u| with a its long axis at that knot, horizontal, in the heading
frame, and b ⟂ a — the separating-axis test of two rectangles along u, so soles that yaw may not
overlap at the toes either; |x| is smoothed as √(x² + ε²)), and g = `FOOT_GAP_LEG_LENGTHS`·L a gap
for the shank above the sole. Without the yaw term the biped's soles yawed 22° inwards and their
toes overlapped by 20 mm. Only pairs whose stance
separation leaves less than `PAIR_SLACK_LEG_LENGTHS`·L of room get a row (a biped's two feet,
or a narrow robot's side-by-side feet); feet a body length apart cannot meet and add no rows.

The rows are handed to the solver divided by a unit length (`PlannerOptions.
separation_unit_leg_lengths`, 0.4 leg lengths by default; metres before session 42): the same
feasible set, but in metres a violation of a few centimetres weighed little in IPOPT's filter
beside the dynamics rows, and the biped's half-cycle solves with the swing wrench by bounds carried
a swing foot across the other and took up to 118 iterations to undo it
(docs/results/planner_speed_coldstart.md, sessions 41–42). Reports of the group read in that unit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from planner.nlp.model import RobotModel
from planner.nlp.solver_cache import call_mapped, same_function

#: clearance between the feet's extents, in leg lengths (5 mm for the built-in biped)
FOOT_GAP_LEG_LENGTHS = 0.02
#: pairs whose stance room (separation − extents − gap) is below this get a row, in leg lengths
PAIR_SLACK_LEG_LENGTHS = 0.5


def foot_pairs(model: RobotModel) -> tuple[tuple[int, int, np.ndarray, float], ...]:
    """(i, j, u_ij (2,), minimum separation [m]) for every pair of feet that needs a row."""
    robot = model.robot
    stance = np.array(robot.nominal_stance_rad, dtype=float)
    zero = np.zeros(3)
    feet = np.array(model.fk(zero, zero, stance)[0], dtype=float)  # 3 × F, base at the origin
    sole_rot = np.array(model.soles(zero, zero, stance), dtype=float)
    axes: dict[int, np.ndarray] = {
        f: sole_rot[:, 3 * k : 3 * k + 3] for k, f in enumerate(model.flat_feet)
    }
    length = robot.leg_length_m
    gap = FOOT_GAP_LEG_LENGTHS * length
    out = []
    for i in range(model.n_feet):
        for j in range(i + 1, model.n_feet):
            delta = feet[:2, j] - feet[:2, i]
            dist = float(np.linalg.norm(delta))
            if dist < 1e-9:
                continue  # coincident at stance: no direction to keep
            u = delta / dist
            need = _extent(robot.legs[i], axes.get(i), u, model.foot_radius_m) + _extent(
                robot.legs[j], axes.get(j), u, model.foot_radius_m) + gap
            if dist - need < PAIR_SLACK_LEG_LENGTHS * length:
                out.append((i, j, u, min(need, dist)))  # a stance closer than `need` stays legal
    return tuple(out)


def _extent(leg: Any, rot: np.ndarray | None, u: np.ndarray, radius_m: float) -> float:
    """Half extent of a foot along the horizontal unit vector u (base frame at the stance)."""
    if rot is None or leg.sole_half_extents_m is None:
        return float(radius_m)
    half_length, half_width = leg.sole_half_extents_m
    return float(half_length * abs(rot[:2, 0] @ u) + half_width * abs(rot[:2, 1] @ u))


#: smoothing of |x| in the sole extent (a sole axis within 0.01 of ⟂ u counts 0.01)
_ABS_EPS = 1e-2


def foot_separation_rows(
    model: RobotModel,
    sym: Any,
    feet_m: Any,
    derived: Callable[[ca.Function], ca.Function] = same_function,
    unit_m: float = 1.0,
) -> tuple[Any, np.ndarray]:
    """(rows P·N: (separation − minimum) / `unit_m`, pair by pair for each knot; lower bounds 0).

    `unit_m` is the length the rows are counted in (`PlannerOptions.separation_unit_leg_lengths`
    times the leg length; 1: metres); the feasible set is the same for every unit."""
    if not unit_m > 0:
        raise ValueError(f"unit_m must be > 0, got {unit_m!r}")
    pairs = foot_pairs(model)
    if not pairs:
        return ca.MX(0, 1), np.zeros(0)
    n = feet_m.shape[1]
    base = sym.base
    cos_y, sin_y = ca.cos(base[5, :]), ca.sin(base[5, :])
    rots = (call_mapped(derived, model.soles, n, base[:3, :], base[3:, :], sym.q)[0]
            if model.flat_feet else None)
    flat_index = {f: k for k, f in enumerate(model.flat_feet)}

    def heading_frame(x: Any, y: Any) -> tuple[Any, Any]:
        return cos_y * x + sin_y * y, -sin_y * x + cos_y * y

    def extent(f: int, u: np.ndarray) -> Any:
        leg = model.robot.legs[f]
        if f not in flat_index or leg.sole_half_extents_m is None or rots is None:
            return model.foot_radius_m
        half_length, half_width = leg.sole_half_extents_m
        # the map puts each knot's 3 × 3F_flat block side by side; the sole's x axis is column
        # 3·(its flat index) of its knot's block
        col, step = 3 * flat_index[f], 3 * len(model.flat_feet)
        ax, ay = rots[0, col::step], rots[1, col::step]
        ax, ay = heading_frame(ax, ay)
        norm = ca.sqrt(ax * ax + ay * ay + 1e-12)
        along = (float(u[0]) * ax + float(u[1]) * ay) / norm  # a·u
        across = (float(u[1]) * ax - float(u[0]) * ay) / norm  # b·u with b = (−a_y, a_x)
        return (half_length * ca.sqrt(along * along + _ABS_EPS**2)
                + half_width * ca.sqrt(across * across + _ABS_EPS**2))

    rows = []
    for i, j, u, need in pairs:
        dx = feet_m[3 * j, :] - feet_m[3 * i, :]
        dy = feet_m[3 * j + 1, :] - feet_m[3 * i + 1, :]
        along, lateral = heading_frame(dx, dy)
        gap = need - _extent(model.robot.legs[i], _stance_axes(model, i), u, model.foot_radius_m) \
            - _extent(model.robot.legs[j], _stance_axes(model, j), u, model.foot_radius_m)
        rows.append(float(u[0]) * along + float(u[1]) * lateral - extent(i, u) - extent(j, u) - gap)
    return ca.vec(ca.vertcat(*rows)) / unit_m, np.zeros(len(pairs) * n)


def _stance_axes(model: RobotModel, foot: int) -> np.ndarray | None:
    if foot not in model.flat_feet:
        return None
    k = model.flat_feet.index(foot)
    zero = np.zeros(3)
    rot = np.array(model.soles(zero, zero, np.array(model.robot.nominal_stance_rad)), dtype=float)
    return rot[:, 3 * k : 3 * k + 3]


def foot_separation_labels(model: RobotModel, n_knots: int) -> list[str]:
    feet = model.robot.foot_names
    return [f"feet {feet[i]}–{feet[j]}@knot {k}" for k in range(n_knots)
            for i, j, _, _ in foot_pairs(model)]

"""Capture margin of single support on a flat foot: the body must be able to stop on that foot.

Why (measured on the built-in biped, docs/results/biped_walk_robustness.md): the cheapest walk
barely sways (base y within ±4.8 mm, hips 45 mm either side of it) and balances each single
support *dynamically*: the centre of pressure sits on the stance sole's inner edge and the body
falls slowly towards the swing foot, which catches it. Its instantaneous capture point lies
0.92–1.17 half widths inside of the stance sole's centre, i.e. up to 17 % beyond the inner
edge: if the swing foot lands a little late, or the servos sag, no centre of pressure inside
the sole can stop the fall, and in MuJoCo the sole rolls onto an edge.

The rows: at every knot where exactly one foot is down and it is flat, the instantaneous capture
point of the linear inverted pendulum (Pratt, Carff, Drakunov & Goswami 2006, "Capture point: a
step toward humanoid push recovery", Humanoids; Koolen et al. 2012, IJRR 31(9), eq. 9)

    ξ = c + ċ / ω₀,   ω₀ = √(g / c_z)

of the centre of mass c (its ground projection; c_z its height above the sole, ċ the world
velocity by the same cyclic central differences as the base rates) stays across the stance
sole within its half width shrunk by `PlannerOptions.capture_sole_fraction` = s:
|ŷ·(ξ − p)| ≤ sY (p the sole centre, ŷ its lateral axis). With ξ inside the sole laterally, a
centre of pressure exists that stops the sideways motion over the foot (Koolen et al. 2012, the
0-step capture region, in the lateral plane), so a late touchdown is survivable instead of a
fall. Only across: forwards a walk falls onto the next foot by design (ξ leads the CoM by
v/ω₀, 17 mm at 0.1 m/s), and the rectangle's forward rows, tried first, made every N = 12 plan
at 0.08–0.12 m/s fall at 3.0–4.1 s in MuJoCo (results file). The rows are
multiplied by the schedule's single-support indicator C_i·Π_{j≠i}(1 − C_j) (contact parameters),
so double support, flight and point feet get none and one build serves every schedule.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from planner.nlp.model import RobotModel
from planner.nlp.variables import cyclic_shift

N_CAPTURE_ROWS = 2  # ±y (across the sole) per flat foot and knot


def single_support(contact: Any, foot: int) -> Any:
    """1 × N: 1 where `foot` is the only foot down (contact parameters C, F × N)."""
    alone = contact[foot, :]
    for j in range(contact.shape[0]):
        if j != foot:
            alone = alone * (1 - contact[j, :])
    return alone


def com_with_neighbours(model: RobotModel, sym: Any, n_knots: int
                        ) -> tuple[Any, tuple[Any, Any], tuple[Any, Any]]:
    """The centre of mass of every knot (3 × N, world) and the x, y of its next and previous
    knots' in knot k's command frame (`planner.nlp.command`: they carry the commanded motion over
    ±h), the terms of its cyclic central difference (the world velocity)."""
    _, _, com = model.fk.map(n_knots)(sym.base[:3, :], sym.base[3:, :], sym.q)
    nxt = sym.motion.next_in_frame(cyclic_shift(com[0, :], 1), cyclic_shift(com[1, :], 1))
    prv = sym.motion.previous_in_frame(cyclic_shift(com[0, :], -1), cyclic_shift(com[1, :], -1))
    return com, nxt, prv


def capture_point_xy(model: RobotModel, sym: Any, n_knots: int) -> Any:
    """2 × N instantaneous capture point ξ = c + ċ/ω₀ of the knots (command frame of each knot).

    ċ: the cyclic central difference of c with the neighbours expressed in knot k's command
    frame (`planner.nlp.command`: they carry the commanded motion over ±h), i.e. the world
    velocity, as in the "finite differences" rows before the command is subtracted."""
    com, (nxt_x, nxt_y), (prv_x, prv_y) = com_with_neighbours(model, sym, n_knots)
    inv_h = n_knots / sym.period_s
    cd_x = (nxt_x - prv_x) * (0.5 * inv_h)
    cd_y = (nxt_y - prv_y) * (0.5 * inv_h)
    g = float(np.linalg.norm(model.gravity_m_s2))
    inv_omega = ca.sqrt(ca.fmax(com[2, :], 1e-3) / g)  # 1/ω₀ = √(c_z/g)
    return ca.vertcat(com[0, :] + cd_x * inv_omega, com[1, :] + cd_y * inv_omega)


def capture_margin_rows(
    model: RobotModel,
    sym: Any,
    n_knots: int,
    centre_xy: Any,
    heading_xy: Any,
    sole_fraction: float,
) -> Any:
    """The rows (each ≥ 0 when satisfied), flat-foot-major then ±y, then knots.

    `centre_xy`, `heading_xy`: 2·F_flat × N, each flat sole's centre and x̂ (x, y rows
    interleaved, `planner.nlp.flat_foot._knot_function`'s outputs)."""
    xi = capture_point_xy(model, sym, n_knots)
    rows = []
    for k, i in enumerate(model.flat_feet):
        _, hy = model.robot.legs[i].sole_half_extents_m or (0.0, 0.0)
        ux, uy = heading_xy[2 * k, :], heading_xy[2 * k + 1, :]
        dx, dy = xi[0, :] - centre_xy[2 * k, :], xi[1, :] - centre_xy[2 * k + 1, :]
        across = -uy * dx + ux * dy  # ŷ·(ξ − p), ŷ = ẑ × x̂ on level ground
        alone = single_support(sym.contact, i)
        for r in (sole_fraction * hy - across, sole_fraction * hy + across):
            rows.append(alone * r)
    return ca.vec(ca.vertcat(*rows).T)


def capture_margin_labels(model: RobotModel, n_knots: int) -> list[str]:
    names = [model.robot.legs[i].name for i in model.flat_feet]
    return [
        f"{side} foot {f}@knot {k}"
        for f in names
        for side in ("left", "right")
        for k in range(n_knots)
    ]

"""Feet that cannot move sideways relative to the body, and the tolerance of their lateral rows.

A leg whose hinges all turn about the body's lateral (y) axis — the hip-and-knee legs of
Petoi Bittle-class quadrupeds and most 2-DOF hobby legs — moves its foot only in the body's
sagittal plane. The world-lateral coordinate of such a stance foot is then
y_i = y_b + c_i + ψ·x_i − φ·z_i + (higher order), and the no-slip rows
y_i(k+1) − y_i(k) = 0 (W&P 2009 eq 3) of two such feet at the same fore-aft position x_i are
the same row to first order; with every stance foot alike, only Δy_b + h·Δφ and Δψ are
constrained, however many feet are down. The equality Jacobian is then (nearly) rank deficient,
the linear-independence constraint qualification fails, IPOPT's multipliers of those rows grow
without bound and its dual infeasibility stalls: bittle8's templates ran 250-1000 iterations
without converging (docs/results/zoo_gaits.md, iteration_cap.md), while robots with hip roll
(quad12: 21-45 iterations) were not affected.

The cure keeps the physics and removes the degeneracy: the lateral no-slip rows of these feet
become the band |Δy| ≤ ε per knot interval, ε = `PlannerOptions.sideways_slip_leg_lengths`·L
(default `SIDEWAYS_SLIP_LEG_LENGTHS`; L the leg length; 0 restores the equality rows).
Degenerate inequalities with an interior satisfy the Mangasarian–Fromovitz qualification, under
which interior-point multipliers stay bounded (Nocedal & Wright 2006, §12.6). At 1e-4·L the
planned sideways creep is below a tenth of a millimetre over a stance on a 7.5 cm leg.
"""

from __future__ import annotations

import numpy as np

from robots import Robot

#: a hinge counts as lateral when its axis is within this angle of the body's y axis at stance
LATERAL_AXIS_TOLERANCE_RAD = np.deg2rad(2.0)
#: ε of the lateral no-slip band, per knot interval, in leg lengths (module docstring)
SIDEWAYS_SLIP_LEG_LENGTHS = 1e-4


def sideways_locked_feet(robot: Robot) -> tuple[bool, ...]:
    """Per leg (`robot.legs` order): True when every hinge of the leg turns about the body's
    lateral axis at the stance pose, so the leg cannot move its foot sideways by itself."""
    from planner.stance import stance_kinematics

    stance = stance_kinematics(robot)
    index = {j.name: i for i, j in enumerate(robot.joints)}
    axes = np.asarray(stance.data.xaxis[list(stance.joint_ids)], dtype=float)
    cos_tol = float(np.cos(LATERAL_AXIS_TOLERANCE_RAD))
    locked = []
    for leg in robot.legs:
        rows = [axes[index[name]] for name in leg.joints if not robot.joints[index[name]].held]
        locked.append(bool(rows) and all(abs(float(a[1])) >= cos_tol for a in rows))
    return tuple(locked)


def lateral_slip_bounds_m(robot: Robot, n_knots: int, slip_leg_lengths: float
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the stance no-slip group's lateral rows (foot-major within each knot, as
    `planner.nlp.constraints.build_groups` lays them out: `ca.vec` of an F × N block): ±ε for
    sideways-locked feet (ε = `slip_leg_lengths`·L), 0 for the others."""
    eps = slip_leg_lengths * robot.leg_length_m
    per_foot = np.where(np.array(sideways_locked_feet(robot), dtype=bool), eps, 0.0)
    ub = np.tile(per_foot, n_knots)
    return -ub, ub

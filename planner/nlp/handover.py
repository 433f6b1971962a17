"""Handover torque bound: the landing leg can carry the trailing foot's load before lift-off.

Why (measured in MuJoCo on humanoid20, docs/results/zoo_gaits.md "Session 24"): in the double
support of a servo biped's walk, MuJoCo's trailing foot lets go ≈ 40 ms (2-3 knots) before its
planned lift-off and gives no push-off (0 N where the plan has ≈ 12-37 N). The total vertical
force stays as planned, so the landing foot carries the trailing foot's load early: its knee
reaches 0.76-0.86 of stall where the plan asked 0.41-0.47 (limit 0.8 in `sim.validate`).

The physics. The joint rows of the knot's inverse dynamics (`RobotModel.inverse_dynamics`,
the "inverse dynamics" group of `planner.nlp.constraints`) are

    τ = τ_free(b, q, q̇, q̈) − Σ_i J_i(q)ᵀ F_i,      F_i = m·g·f_i  (world, at foot i's site)

with J_i the joint columns of foot i's position Jacobian in the world. τ is linear in the
contact forces, so moving the trailing foot a's normal load F_z,a = m·g·f_z,a onto the landing
foot b (same posture, rates and accelerations) gives

    τ_alt = τ + m·g·f_z,a · (∂z_a/∂q − ∂z_b/∂q)ᵀ.

On a tree whose legs share no joint, ∂z_a/∂q is zero on the landing leg's joints, so there
τ_alt = τ − m·g·f_z,a·(∂z_b/∂q)ᵀ (a joint shared by both feet, e.g. a waist, gets both terms).
The rows bound τ_alt of every joint that moves the landing foot vertically by the same servo
envelope as the torque rows, |τ_alt| ≤ margin·τ_stall·(1 − |q̇|/ω₀) (four faces), on the knots
where foot a is in stance and lifts off within the next m knots while foot b is in stance:

    C_a,k · (1 − Π_{j=1..m} C_a,k+j) · C_b,k,        m = max(1, round(w·N))

with w = `PlannerOptions.handover_window_cycles` (a fraction of the period; the rows are
multiplied by this product of schedule parameters, so the NLP is still built once per robot
and N). The simplification: the load case is not a dynamically consistent motion — the moved
force's moment about the centre of mass changes, and the base rows would not balance; it is the
quasi-static load MuJoCo produces (the same total vertical force, all of it on the landing leg,
at the planned posture), and the planned motion itself is unchanged. Tangential forces and the
flat soles' contact moments stay where they are planned.

Which feet: robots with exactly two feet (a biped's stance-to-stance handover: the trailing and
the landing foot are the only stance feet of the double support). With more feet the load of a
lifting foot is shared by several stance feet, and moving all of it onto any one of them is a
load case neither the plan nor MuJoCo produces (a trot hands over from one diagonal pair to the
other); there the option adds no rows.

The W&P 2009 formulation (eqs 1-10) has no such row: its actuators follow the planned forces
exactly; a position servo does not.

Measured (docs/results/zoo_gaits.md "Session 24b"), humanoid20 template at 0.215 m/s, N 30,
w = 0.1 (3 knots: its whole double support): the rows bind (landing knee −0.77 of stall with
the load moved, on the last double-support knot) and MuJoCo's landing knee at that instant
follows them (−0.76), but the run's peak sample sits elsewhere — with ρ 5 on the stance knee
at the other foot's touchdown, with ρ 8 on the landing knee ≈ 100 ms into single support, where
the plan now puts more load because IPOPT meets the rows by unloading the landing foot, not the
trailing one — so the verdict does not improve: 100 % of stall with ρ 5 (100 % without), 94 %
with ρ 8 (85 % without); without the rate bound the template now stays up
(101 %) where it falls at 3.1 s. The same rows at the touchdown end (the landing foot's load on
the trailing foot, 1 or 3 knots) made every plan fall; that variant was removed. So the default
is off (None); the built-in biped's template passes with w = 0.1 as without.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from planner.nlp.model import RobotModel

#: default of `PlannerOptions.handover_window_cycles`: off (no rows)
HANDOVER_WINDOW_CYCLES: float | None = None


@dataclass(frozen=True)
class HandoverPair:
    """One ordered stance-to-stance handover: `trailing` lifts off, `landing` takes its load;
    `joints`: the joints whose torque the rows bound (those that move the landing foot)."""

    trailing: int
    landing: int
    joints: tuple[int, ...]


def foot_height_jacobian(model: RobotModel) -> ca.Function:
    """SX function (rpy, q) ↦ ∂z_i/∂q, F × J: the joint columns of every foot site's height
    Jacobian (the base position does not enter)."""
    rpy, q = ca.SX.sym("rpy", 3), ca.SX.sym("q", model.n_joints)
    feet, _, _ = model.fk(ca.SX.zeros(3), rpy, q)
    return ca.Function("foot_dz_dq", [rpy, q], [ca.jacobian(feet[2, :].T, q)],
                       ["rpy", "q"], ["dz_dq"])


def handover_pairs(model: RobotModel) -> tuple[HandoverPair, ...]:
    """Both ordered pairs of a two-footed robot, each with the joints that structurally move the
    landing foot's height; () for any other foot count (module docstring)."""
    if model.n_feet != 2:
        return ()
    sparsity = foot_height_jacobian(model).sparsity_out(0)
    moves = np.asarray(ca.DM(sparsity, 1).full()) != 0  # F × J
    return tuple(
        HandoverPair(a, b, tuple(int(j) for j in np.flatnonzero(moves[b])))
        for a, b in ((0, 1), (1, 0))
    )


def window_knots(window_cycles: float, n_knots: int) -> int:
    """m: the knots before lift-off the rows cover, round(w·N), at least 1 and below N."""
    if not (np.isfinite(window_cycles) and 0 < window_cycles < 1):
        raise ValueError(f"a handover window is a fraction of the period in (0, 1), "
                         f"got {window_cycles!r}")
    return int(min(n_knots - 1, max(1, round(window_cycles * n_knots))))


def lift_off_window(contact: Any, m: int) -> Any:
    """F × N: C_k·(1 − Π_{j=1..m} C_k+j) (cyclic): 1 on a foot's last m stance knots for a 0/1
    schedule C (F × N), 0 elsewhere."""
    n = int(contact.shape[1])
    ahead = 1
    for j in range(1, m + 1):
        ahead = ahead * ca.horzcat(contact[:, j % n:], contact[:, :j % n])
    return contact * (1 - ahead)


def handover_torques_nm(tau_nm: Any, fz_weights: Any, dz_dq: list[Any], weight_n: float,
                        pair: HandoverPair) -> Any:
    """len(joints) × N: τ_alt = τ + m·g·f_z,a·(∂z_a/∂q − ∂z_b/∂q)ᵀ on the pair's joints.
    `tau_nm`: J × N; `fz_weights`: F × N in body weights; `dz_dq`: per foot, J × N."""
    rows = list(pair.joints)
    load = fz_weights[pair.trailing, :] * weight_n
    moved = dz_dq[pair.trailing][rows, :] - dz_dq[pair.landing][rows, :]
    return tau_nm[rows, :] + moved * ca.repmat(load, len(rows), 1)


def handover_labels(model: RobotModel, n_knots: int) -> list[str]:
    """Row labels in the order of the "handover torque" group (4 faces × pairs × knots × joints
    of the pair, column-major per face and pair)."""
    names = model.robot.joint_names
    feet = model.robot.foot_names
    return [
        f"{names[j]} ({feet[p.trailing]}→{feet[p.landing]}) {face}@knot {k}"
        for face in ("+τ+q̇", "+τ−q̇", "−τ+q̇", "−τ−q̇")
        for p in handover_pairs(model)
        for k in range(n_knots)
        for j in p.joints
    ]

"""Flat feet in the spacetime NLP: a sole that lies on the ground, with a contact wrench.

A flat foot (`robots.sole`, ``foot = "flat"`` in robot.toml) touches the ground with a rectangle
of half length X and half width Y (sole frame: x along the length, z the sole normal). Its
contact is a wrench — force f and moment m about the sole centre, both in the world frame, f in
units of m·g like the point feet's forces and m in units of m·g·L (L = `Robot.leg_length_m`) —
and the planner imposes:

- in stance the sole lies on the ground: sole centre at z = 0 (the "stance height" group with a
  zero offset), sole normal vertical (the sole frame's roll and pitch are zero: the x and y
  components of its z-axis vanish), no slip of the centre ("stance no-slip") and no yaw slip
  (the sole's heading is the same at knots k and k+1: sin Δψ = (x̂_k × x̂_{k+1})·ẑ = 0, on the
  same knot pairs as "stance no-slip");
- the wrench lies in the contact wrench cone of a rectangle, the closed form of Caron, Pham &
  Nakamura 2015, "Stability of surface contacts for humanoid robots: closed-form formulae of the
  contact wrench cone for rectangular support areas" (ICRA 2015), Theorem 1 / eq. (16), in the
  sole frame (w = Rᵀf, τ = Rᵀm; R the sole rotation):

      |f_x| ≤ µ f_z,   |f_y| ≤ µ f_z                         (friction pyramid)
      |τ_x| ≤ Y f_z,   |τ_y| ≤ X f_z                         (centre of pressure in the sole)
      τ_min ≤ τ_z ≤ τ_max                                    (yaw torque), with
      τ_min = −µ(X+Y) f_z + |Y f_x − µ τ_x| + |X f_y − µ τ_y|
      τ_max = +µ(X+Y) f_z − |Y f_x + µ τ_x| − |X f_y + µ τ_y|

  — the full CWC (16 linear rows once the absolute values are split), not the simplified box
  |τ_z| ≤ µ_t f_z. µ is the linear pyramid inscribed in the Coulomb cone, µ_opt/√2, as for the
  point feet (W&P eq 9), applied at every corner of the sole, so the rows are conservative. With
  f_z = 0 (swing: the "swing force" group) they force the whole wrench to zero. The planner
  imposes the cone of the sole shrunk by `PlannerOptions.cop_sole_fraction` (X, Y → sX, sY): a
  centre-of-pressure and torsional-friction margin, `planner.nlp.contact_margin`;
- in swing the whole sole clears the ground: all four corners at least the swing profile H high;
- the "body clearance" rows (W&P eq 1) spare the ankle: a flat foot's body and the ancestors
  sharing its origin stand only the ankle height above the sole, which its corners keep clear.

Point feet are untouched: without flat feet none of this is built and the NLP is the same, bit
for bit (checked on quad12 and hex18: g, torques and cost terms at random points).

Whole-body dynamics (Newton–Euler balance and the joint torques) take the moment through
`RobotModel.inverse_dynamics_wrench`: a world moment m at the foot body adds m to the body's
spatial force, i.e. Jᵀ(f, m) with the foot body's Jacobian.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from planner.nlp.capture_margin import N_CAPTURE_ROWS, capture_margin_labels, capture_margin_rows
from planner.nlp.config import PlannerOptions
from planner.nlp.contact_margin import shrunk_half_extents
from planner.nlp.model import RobotModel
from planner.nlp.solver_cache import call_mapped, same_function

N_CWC_ROWS = 16
N_CORNERS = 4


def cwc_rows(force: Any, moment: Any, half_length_m: float, half_width_m: float, mu: float) -> Any:
    """The 16 rows of the rectangle's contact wrench cone, each ≥ 0 inside the cone.

    `force`, `moment`: 3-vectors in the sole frame, the moment about the sole centre (numpy or
    CasADi, any consistent units: a moment in units of length·force needs X, Y in that length).
    Caron, Pham & Nakamura 2015, Theorem 1; the absolute values split into their two signs.
    """
    fx, fy, fz = force[0], force[1], force[2]
    tx, ty, tz = moment[0], moment[1], moment[2]
    big_x, big_y = half_length_m, half_width_m
    rows = [
        mu * fz - fx,
        mu * fz + fx,
        mu * fz - fy,
        mu * fz + fy,
        big_y * fz - tx,
        big_y * fz + tx,
        big_x * fz - ty,
        big_x * fz + ty,
    ]
    torsion = mu * (big_x + big_y) * fz
    for sx in (1.0, -1.0):
        for sy in (1.0, -1.0):
            # τ_z ≥ τ_min: τ_z + µ(X+Y)f_z − |Y f_x − µ τ_x| − |X f_y − µ τ_y| ≥ 0
            rows.append(tz + torsion - sx * (big_y * fx - mu * tx) - sy * (big_x * fy - mu * ty))
    for sx in (1.0, -1.0):
        for sy in (1.0, -1.0):
            # τ_z ≤ τ_max: µ(X+Y)f_z − |Y f_x + µ τ_x| − |X f_y + µ τ_y| − τ_z ≥ 0
            rows.append(torsion - sx * (big_y * fx + mu * tx) - sy * (big_x * fy + mu * ty) - tz)
    if isinstance(force, np.ndarray):
        return np.array(rows, dtype=float)
    return ca.vertcat(*rows)


def wrench_of_corner_forces(
    corner_forces: np.ndarray, half_extents_m: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """(force, moment about the centre) of 4 point forces at the sole corners (sole frame)."""
    hx, hy = half_extents_m
    corners = np.array([[hx, hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0], [hx, -hy, 0.0]])
    force = corner_forces.sum(axis=0)
    moment = np.cross(corners, corner_forces).sum(axis=0)
    return force, moment


def n_flat(model: RobotModel) -> int:
    return len(model.flat_feet)


def contact_offsets(model: RobotModel, n_knots: int) -> Any:
    """Height of each contact point above the ground in stance: the foot radius for point feet
    (the sphere's centre), 0 for flat feet (the sole centre). A float when all feet are points,
    as before flat feet existed; else an F × N matrix."""
    r = model.foot_radius_m
    if not model.flat_feet:
        return r
    offsets = np.full(model.n_feet, r)
    offsets[list(model.flat_feet)] = 0.0
    return ca.repmat(ca.DM(offsets), 1, n_knots)


#: bodies whose origin is this close to a flat foot's body origin are part of its ankle
ANKLE_COINCIDENT_M = 1e-3


def body_clearance_lower_bounds(model: RobotModel, n_knots: int) -> np.ndarray:
    """Lower bounds of the "body clearance" rows (body-major within each knot): 0, except −∞
    for a flat foot's body and its ancestors whose origin coincides with it (a 2-DOF ankle built
    of bodies at one point). Their origin is the ankle, which stands only its height above the
    sole; the sole's corners (the "sole clearance" group) keep that part off the ground instead.
    """
    lb = np.zeros(model.n_bodies)
    if model.flat_feet:
        q_ref = np.asarray(model.mj_model.qpos0)[model.joint_qposadr]
        origins = np.asarray(model.fk(np.zeros(3), np.zeros(3), q_ref)[1])
        for i in model.flat_feet:
            body = model.foot_body_index(i)
            ankle = origins[:, body].copy()
            while body >= 0 and np.linalg.norm(origins[:, body] - ankle) < ANKLE_COINCIDENT_M:
                lb[body] = -np.inf
                body = model.body_parent(body)
    return np.tile(lb, n_knots)


def spare_flat_foot_ankles(model: RobotModel, groups: list[Any], n_knots: int) -> list[Any]:
    """`groups` with the "body clearance" rows of flat-foot ankles unbounded below
    (`body_clearance_lower_bounds`); unchanged without flat feet."""
    if not model.flat_feet:
        return groups
    lb = body_clearance_lower_bounds(model, n_knots)
    return [
        dataclasses.replace(g, lb=np.minimum(g.lb, lb)) if g.name == "body clearance" else g
        for g in groups
    ]


def moment_scale(model: RobotModel) -> float:
    """[N·m] per unit of the moment variables: m·g·L."""
    weight_n = model.total_mass_kg * float(np.linalg.norm(model.gravity_m_s2))
    return weight_n * model.robot.leg_length_m


def moments_world(model: RobotModel, m_flat: Any) -> Any:
    """3 × F world moments [N·m] of all feet from the flat feet's 3·F_flat scaled variables
    (zero for point feet)."""
    cols: list[Any] = [ca.SX.zeros(3, 1)] * model.n_feet
    for k, i in enumerate(model.flat_feet):
        cols[i] = m_flat[3 * k : 3 * k + 3] * moment_scale(model)
    return ca.horzcat(*cols)


def _half_extents(model: RobotModel, foot: int) -> tuple[float, float]:
    half = model.robot.legs[foot].sole_half_extents_m
    assert half is not None, "a flat foot always has its sole (robots.load)"
    return half


def _knot_function(model: RobotModel, mu: float, sole_fraction: float = 1.0) -> ca.Function:
    """SX function of one knot: sole normal xy, sole heading x̂ (xy), corner heights, CWC rows
    (the cone of the sole shrunk by `sole_fraction`, `planner.nlp.contact_margin`)."""
    nj, nf, nff = model.n_joints, model.n_feet, n_flat(model)
    b, q = ca.SX.sym("b", 6), ca.SX.sym("q", nj)
    f, m = ca.SX.sym("f", 3 * nf), ca.SX.sym("m", 3 * nff)
    feet, _, _ = model.fk(b[:3], b[3:], q)
    rots = model.soles(b[:3], b[3:], q)
    length = model.robot.leg_length_m
    normal, heading, centres, corners, cone = [], [], [], [], []
    for k, i in enumerate(model.flat_feet):
        rot = rots[:, 3 * k : 3 * k + 3]
        normal.append(rot[:2, 2])
        heading.append(rot[:2, 0])
        centre = feet[:, i]
        centres.append(centre[:2])
        hx, hy = _half_extents(model, i)
        for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
            corners.append(centre[2] + rot[2, 0] * sx * hx + rot[2, 1] * sy * hy)
        force_sole = rot.T @ f[3 * i : 3 * i + 3]
        moment_sole = rot.T @ m[3 * k : 3 * k + 3]  # units m·g·L: half extents in units of L
        cx, cy = shrunk_half_extents((hx, hy), sole_fraction)
        cone.append(cwc_rows(force_sole, moment_sole, cx / length, cy / length, mu))
    return ca.Function(
        "flat_knot",
        [b, q, f, m],
        [ca.vertcat(*normal), ca.vertcat(*heading), ca.vertcat(*corners), ca.vertcat(*cone),
         ca.vertcat(*centres)],
        ["b", "q", "f", "m"],
        ["normal_xy", "heading_xy", "corner_z", "cwc", "centre_xy"],
    )


def flat_foot_groups(
    model: RobotModel,
    sym: Any,
    n_knots: int,
    options: PlannerOptions,
    stick: Any,
    group: Any,
    derived: Callable[[ca.Function], ca.Function] = same_function,
) -> list[Any]:
    """The flat feet's constraint groups (empty without flat feet). `stick` (F × N) marks the
    knot pairs k, k+1 a foot holds still ("stance no-slip"); `group` is `constraints.Group`."""
    if not model.flat_feet:
        return []
    n, nff = n_knots, n_flat(model)
    mu = options.mu / math.sqrt(2.0)
    normal, heading, corner_z, cone, centre = call_mapped(
        derived, _knot_function(model, mu, options.cop_sole_fraction), n, sym.base, sym.q,
        sym.forces, sym.moments,
    )
    flat = list(model.flat_feet)
    c = sym.contact[flat, :]
    hold = stick[flat, :]
    min_h = sym.min_height_m[flat, :]
    hx_k, hy_k = heading[0::2, :], heading[1::2, :]
    nxt_x = ca.horzcat(hx_k[:, 1:], hx_k[:, :1])
    nxt_y = ca.horzcat(hy_k[:, 1:], hy_k[:, :1])
    if getattr(sym, "motion", None) is not None:  # knot k+1's heading in knot k's command frame
        nxt_x, nxt_y = sym.motion.rotate_next(nxt_x, nxt_y)
    yaw_slip = hx_k * nxt_y - hy_k * nxt_x  # sin of the heading change from knot k to k+1
    swing = 1 - c
    corner_rows = []
    for j in range(N_CORNERS):
        corner_rows.append(ca.vec(swing * (corner_z[j::N_CORNERS, :] - min_h)))
    zeros, inf = np.zeros, np.inf
    capture = []
    if options.capture_sole_fraction is not None:
        rows = capture_margin_rows(model, sym, n, centre, heading, options.capture_sole_fraction)
        size = N_CAPTURE_ROWS * nff * n
        capture = [group("capture margin", rows, zeros(size), np.full(size, inf),
                         model.robot.leg_length_m)]
    return [
        *_anchored_footprint(model, sym, n, options),
        group(
            "sole level",
            ca.vertcat(ca.vec(c * normal[0::2, :]), ca.vec(c * normal[1::2, :])),
            zeros(2 * nff * n),
            zeros(2 * nff * n),
            activity=ca.vertcat(ca.vec(c), ca.vec(c)),
        ),
        group("sole yaw hold", ca.vec(hold * yaw_slip), zeros(nff * n), zeros(nff * n),
              activity=ca.vec(hold)),
        group(
            "sole clearance",
            ca.vertcat(*corner_rows),
            zeros(N_CORNERS * nff * n),
            np.full(N_CORNERS * nff * n, inf),
        ),
        group(
            "contact wrench cone",
            ca.vec(cone),
            zeros(N_CWC_ROWS * nff * n),
            np.full(N_CWC_ROWS * nff * n, inf),
        ),
        *capture,
    ]


def _anchored_footprint(model: RobotModel, sym: Any, n_knots: int,
                        options: PlannerOptions) -> list[Any]:
    """The "mean footprint" rows (`PlannerOptions.mean_footprint_leg_lengths`) at
    `PlannerOptions.flat_mean_footprint_leg_lengths` for a robot with flat feet, unless the
    option already asks for them (`planner.nlp.contact_margin`: the limping optimum)."""
    t = options.flat_mean_footprint_leg_lengths
    if t is None or options.mean_footprint_leg_lengths is not None:
        return []
    from planner.nlp.constraints import _mean_footprint_groups  # it imports this module

    return _mean_footprint_groups(
        model, sym, n_knots, dataclasses.replace(options, mean_footprint_leg_lengths=t)
    )


def flat_foot_labels(model: RobotModel, n_knots: int) -> dict[str, list[str]]:
    """Row labels of `flat_foot_groups`, in their row order."""
    if not model.flat_feet:
        return {}
    names = [model.robot.legs[i].name for i in model.flat_feet]
    per_foot = [f"foot {f}@knot {k}" for k in range(n_knots) for f in names]
    corners = [
        f"{c} {lab}"
        for c in ("front-left", "rear-left", "rear-right", "front-right")
        for lab in per_foot
    ]
    cwc = [
        f"row {r} foot {f}@knot {k}"
        for k in range(n_knots)
        for f in names
        for r in range(N_CWC_ROWS)
    ]
    return {
        "sole level": [f"normal {a} {lab}" for a in ("x", "y") for lab in per_foot],
        "sole yaw hold": per_foot,
        "sole clearance": corners,
        "contact wrench cone": cwc,
        "capture margin": capture_margin_labels(model, n_knots),
    }


def sole_tilt_rad(model: RobotModel, base_pose: np.ndarray, q_rad: np.ndarray) -> np.ndarray:
    """N × F_flat angle [rad] between each flat foot's sole normal and the vertical."""
    out = np.zeros((len(base_pose), n_flat(model)))
    for k, (b, q) in enumerate(zip(base_pose, q_rad, strict=True)):
        rots = np.asarray(model.soles(b[:3], b[3:], q))
        for j in range(n_flat(model)):
            out[k, j] = math.acos(float(np.clip(rots[2, 3 * j + 2], -1.0, 1.0)))
    return out

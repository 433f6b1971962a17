"""A standing pose: every foot on the ground, body level, joints away from their limits.

Nonlinear least squares (`scipy.optimize.least_squares`, bounded trust region) over the leg
joint angles q and the base height h, with the base level at (0, 0, h). Residuals, each scaled
to be dimensionless (L = mean hip-to-foot distance in the zero pose):

- feet on the ground: W_GROUND · (z_foot − r) / L            (contact centre one radius up)
- feet where the model puts them (zero-pose footprint, pulled in to FOOTPRINT_REACH × the
  leg's span from its first joint for legs drawn sprawled out): W_FOOTPRINT · Δxy / L
- joints near mid-range: W_MID · (q − q_mid) / (q_hi − q_lo)
- centre of mass over the centroid of the feet: W_COM · Δxy / L
- flat soles flat: W_FLAT · (horizontal part of the sole normal)
- a foot body's other collidable geoms (two-geom feet) not below the ground: W_GROUND · depth / L

The solution is then checked, not trusted: a foot more than GROUND_TOL_M off the ground or a
body geom lower than the feet is reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.optimize import least_squares

from robots.scaffold.legs import FoundLeg, geom_points, zero_pose

W_GROUND, W_FOOTPRINT, W_MID, W_COM, W_FLAT = 30.0, 1.0, 1.0, 3.0, 3.0
FOOTPRINT_REACH = 0.6  # a sprawled zero pose: aim the foot at most this × the leg's span out
LIMIT_MARGIN = 0.05  # keep the stance this fraction of the range inside each limit
GROUND_TOL_M = 2e-3


@dataclass(frozen=True)
class Stance:
    q_rad: dict[int, float]  # joint id → angle (legs and held joints)
    base_height_m: float
    max_foot_error_m: float  # largest |foot height − radius|
    com_offset_m: float  # horizontal distance of the CoM from the feet's centroid
    lowest_body_clearance_m: float  # lowest non-foot geom above the ground


def _site_world(data: mujoco.MjData, leg: FoundLeg) -> np.ndarray:
    b = leg.foot.body
    return data.xpos[b] + data.xmat[b].reshape(3, 3) @ leg.foot.site_local


def find_stance(
    model: mujoco.MjModel,
    legs: list[FoundLeg],
    limits_rad: dict[int, tuple[float, float]],
    held_rad: dict[int, float],
) -> Stance:
    """Solve for the standing pose (see module docstring)."""
    data = zero_pose(model)
    root = int(model.jnt_bodyid[0])
    targets = []
    for leg in legs:
        anchor = data.xanchor[leg.joints[0]][:2]
        out = _site_world(data, leg)[:2] - anchor
        reach = FOOTPRINT_REACH * float(
            np.linalg.norm(_site_world(data, leg) - data.xanchor[leg.joints[0]])
        )
        dist = float(np.linalg.norm(out))
        targets.append(anchor + out * (min(dist, reach) / dist if dist > 0 else 0.0))
    spans = [
        float(np.linalg.norm(_site_world(data, leg) - data.xanchor[leg.joints[0]])) for leg in legs
    ]
    length = max(float(np.mean(spans)), 1e-3)
    jids = [j for leg in legs for j in leg.joints]
    lo = np.array([limits_rad[j][0] for j in jids])
    hi = np.array([limits_rad[j][1] for j in jids])
    margin = LIMIT_MARGIN * (hi - lo)
    lo_b, hi_b = lo + margin, hi - margin
    mid = 0.5 * (lo + hi)
    adr = np.array([model.jnt_qposadr[j] for j in jids])

    def pose(x: np.ndarray) -> None:
        data.qpos[:] = model.qpos0
        data.qpos[0:3] = (0.0, 0.0, x[-1])
        data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        for j, q in held_rad.items():
            data.qpos[model.jnt_qposadr[j]] = q
        data.qpos[adr] = x[:-1]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)

    # other collidable geoms on a foot body (a two-geom foot) may touch but not sink in
    extra = {
        leg.name: [
            g
            for g in range(model.ngeom)
            if model.geom_bodyid[g] == leg.foot.body
            and g != leg.foot.geom
            and (model.geom_contype[g] or model.geom_conaffinity[g])
        ]
        for leg in legs
    }

    def sunk(leg: FoundLeg) -> float:
        """How far the foot body's other geoms reach below the ground (≥ 0)."""
        depth = 0.0
        for g in extra[leg.name]:
            pts, radius = geom_points(model, data, g)
            depth = max(depth, -(float(pts[:, 2].min()) - radius))
        return depth

    def residuals(x: np.ndarray) -> np.ndarray:
        pose(x)
        feet = [_site_world(data, leg) for leg in legs]
        res: list[float] = []
        for leg, foot, target in zip(legs, feet, targets, strict=True):
            res.append(W_GROUND * (foot[2] - leg.foot.radius_m) / length)
            res.append(W_GROUND * sunk(leg) / length)
            res.extend(W_FOOTPRINT * (foot[:2] - target) / length)
            if leg.foot.flat:
                up = data.xmat[leg.foot.body].reshape(3, 3) @ leg.foot.sole_normal_local
                res.extend(W_FLAT * up[:2])
        res.extend(W_MID * (x[:-1] - mid) / (hi - lo))
        centroid = np.mean([f[:2] for f in feet], axis=0)
        res.extend(W_COM * (data.subtree_com[root][:2] - centroid) / length)
        return np.asarray(res)

    x0 = np.append(np.clip(mid, lo_b, hi_b), 0.0)
    pose(x0)
    x0[-1] = float(np.mean([leg.foot.radius_m - _site_world(data, leg)[2] for leg in legs]))
    h_hi = max(4.0 * length, x0[-1] + length)
    x0[-1] = float(np.clip(x0[-1], 1e-3, h_hi))
    sol = least_squares(
        residuals,
        x0,
        bounds=(np.append(lo_b, 1e-3), np.append(hi_b, h_hi)),
        x_scale=np.append(hi - lo, length),
        xtol=1e-10,
        ftol=1e-10,
        max_nfev=400,
    )
    x = sol.x
    pose(x)
    feet = [_site_world(data, leg) for leg in legs]
    err = max(
        max(abs(float(f[2]) - leg.foot.radius_m), sunk(leg))
        for f, leg in zip(feet, legs, strict=True)
    )
    centroid = np.mean([f[:2] for f in feet], axis=0)
    foot_bodies = {leg.foot.body for leg in legs}
    mujoco.mj_forward(model, data)
    clearance = np.inf
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == 0 or model.geom_bodyid[g] in foot_bodies:
            continue
        if not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        pts, radius = geom_points(model, data, g)
        clearance = min(clearance, float(pts[:, 2].min()) - radius)
    q = {j: float(v) for j, v in zip(jids, x[:-1], strict=True)}
    q.update(held_rad)
    return Stance(
        q_rad=q,
        base_height_m=float(x[-1]),
        max_foot_error_m=err,
        com_offset_m=float(np.linalg.norm(data.subtree_com[root][:2] - centroid)),
        lowest_body_clearance_m=float(clearance),
    )

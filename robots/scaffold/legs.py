"""Find the legs of a compiled model: hinge chains from the root body to its lowest links.

In the model's zero pose (root at the origin, level) every chain of hinge joints that ends in a
body with no jointed descendant is a limb; its lowest geom point is the candidate foot. The
limbs whose foot lies within `LEG_HEIGHT_TOLERANCE` × the robot's size of the lowest one are the
legs; the other hinge joints are held (`role = "hold"`). Legs are named by where their first
joint sits on the body: front/middle/rear × left/right when they come in mirrored pairs,
otherwise by azimuth (`leg_000` straight ahead, counter-clockwise seen from above).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from robots.scaffold.errors import ScaffoldError

LEG_HEIGHT_TOLERANCE = 0.25  # × the largest extent of the robot's geoms
FLAT_FOOT_RADIUS_M = 0.005  # contact radius given to a flat (box/mesh/cylinder) foot
SAME_HEIGHT_M = 1e-3  # points this close to the lowest one make up the sole


@dataclass(frozen=True)
class FootPoint:
    """The foot of one limb in the zero pose: the body holding the lowest geom and its site."""

    body: int
    geom: int
    site_local: np.ndarray  # site position in the body frame (contact centre)
    radius_m: float
    flat: bool  # a sole (box/mesh/cylinder) rather than a round tip
    sole_normal_local: np.ndarray  # world up in the body frame, zero pose
    lowest_z_m: float  # zero pose, root at the origin


@dataclass(frozen=True)
class Limb:
    joints: tuple[int, ...]  # hinge joint ids, root to tip
    foot: FootPoint


@dataclass(frozen=True)
class FoundLeg:
    name: str
    joints: tuple[int, ...]
    foot: FootPoint
    anchor_local: np.ndarray  # first joint's anchor in the root frame


def zero_pose(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0:3] = 0.0
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    mujoco.mj_kinematics(model, data)
    return data


def geom_points(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> tuple[np.ndarray, float]:
    """World points bounding geom g from below, and the radius of its round tip (0 if flat)."""
    pos, mat = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
    size = model.geom_size[g]
    kind = model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return pos[None, :], float(size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        ends = np.array([pos + mat[:, 2] * size[1], pos - mat[:, 2] * size[1]])
        return ends, float(size[0])
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mid = model.geom_dataid[g]
        adr, n = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
        verts = model.mesh_vert[adr : adr + n]
        return pos + verts @ mat.T, 0.0
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        ang = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
        rim = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1) * size[0]
        up = np.array([0.0, 0.0, size[1]])
        local = np.concatenate([rim + up, rim - up])
        return pos + local @ mat.T, 0.0
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        # lowest point of an ellipsoid: centre − M·Mᵀ·ẑ / |Mᵀ·ẑ| with M = R·diag(size)
        m = mat * size
        v = m.T @ np.array([0.0, 0.0, 1.0])
        return (pos - m @ v / np.linalg.norm(v))[None, :], 0.0
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        return pos + (signs * size) @ mat.T, 0.0
    return pos[None, :], 0.0


def _collides(model: mujoco.MjModel, g: int) -> bool:
    return bool(model.geom_contype[g] or model.geom_conaffinity[g])


def _lowest(model: mujoco.MjModel, data: mujoco.MjData, bodies: list[int]) -> FootPoint | None:
    best: tuple[float, int, np.ndarray, float] | None = None
    for b in bodies:
        for g in range(model.body_geomadr[b], model.body_geomadr[b] + model.body_geomnum[b]):
            if not _collides(model, g):
                continue
            pts, radius = geom_points(model, data, g)
            z = pts[:, 2] - radius
            low = float(z.min())
            if best is None or low < best[0] - SAME_HEIGHT_M:
                sole = pts[z <= low + SAME_HEIGHT_M].mean(axis=0)
                best = (low, g, sole, radius)
    if best is None:
        return None
    low, g, sole, radius = best
    flat = radius == 0.0
    r = FLAT_FOOT_RADIUS_M if flat else radius
    centre_world = sole + np.array([0.0, 0.0, r]) if flat else sole
    body = int(model.geom_bodyid[g])
    rot = data.xmat[body].reshape(3, 3)
    local = rot.T @ (centre_world - data.xpos[body])
    return FootPoint(body, g, local, r, flat, rot.T @ np.array([0.0, 0.0, 1.0]), low)


def _children(model: mujoco.MjModel) -> dict[int, list[int]]:
    kids: dict[int, list[int]] = {b: [] for b in range(model.nbody)}
    for b in range(1, model.nbody):
        kids[int(model.body_parentid[b])].append(b)
    return kids


def _hinges(model: mujoco.MjModel, b: int) -> list[int]:
    return [
        j
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
    ]


def limbs(model: mujoco.MjModel, source: str) -> tuple[list[Limb], int]:
    """Every hinge chain from the root body to a tip, with its lowest point; (limbs, root body)."""
    for j in range(model.njnt):
        kind = model.jnt_type[j]
        if j > 0 and kind != mujoco.mjtJoint.mjJNT_HINGE:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
            raise ScaffoldError(
                source, f"joint {name}", "is a slide/ball joint; gaitsmith drives hinge joints only"
            )
    root = int(model.jnt_bodyid[0])
    data = zero_pose(model)
    kids = _children(model)

    def subtree(b: int) -> list[int]:
        out = [b]
        for c in kids[b]:
            out.extend(subtree(c))
        return out

    found: list[Limb] = []

    def walk(b: int, chain: tuple[int, ...]) -> None:
        chain = chain + tuple(_hinges(model, b))
        jointed_below = [c for c in kids[b] if any(_hinges(model, d) for d in subtree(c))]
        if not jointed_below:
            if chain:
                foot = _lowest(model, data, subtree(b))
                if foot is not None:
                    found.append(Limb(chain, foot))
            return
        if len(jointed_below) > 1 and chain:
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in chain]
            body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
            raise ScaffoldError(
                source,
                f"body {body}",
                f"joints {names} carry several limbs; gaitsmith's legs each hang from the "
                "root body (make those joints fixed, or the body they move the root)",
            )
        for c in jointed_below:
            walk(c, chain)

    for c in kids[root]:
        walk(c, ())
    return found, root


def _extent(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    pts = [
        geom_points(model, data, g)[0]
        for g in range(model.ngeom)
        if model.geom_bodyid[g] > 0 and _collides(model, g)
    ]
    if not pts:
        return 0.0
    allp = np.concatenate(pts)
    return float(np.max(allp.max(axis=0) - allp.min(axis=0)))


def _names(anchors: list[np.ndarray]) -> list[str]:
    centre = np.mean(anchors, axis=0)
    rel = [a - centre for a in anchors]
    n = len(rel)
    left = [i for i, p in enumerate(rel) if p[1] > 1e-3]
    right = [i for i, p in enumerate(rel) if p[1] < -1e-3]
    if n % 2 == 0 and len(left) == len(right) == n // 2:
        names = [""] * n
        for side, idx in (("left", left), ("right", right)):
            order = sorted(idx, key=lambda i: -rel[i][0])
            k = len(order)
            if k == 1:
                labels = [""]
            elif k == 2:
                labels = ["front_", "rear_"]
            elif k == 3:
                labels = ["front_", "middle_", "rear_"]
            else:
                labels = ["front_", *[f"middle{m}_" for m in range(1, k - 1)], "rear_"]
            for lab, i in zip(labels, order, strict=True):
                names[i] = f"{lab}{side}"
        return names
    az = [math.degrees(math.atan2(p[1], p[0])) % 360.0 for p in rel]
    names = [f"leg_{round(a) % 360:03d}" for a in az]
    if len(set(names)) != n:
        raise ScaffoldError("<model>", "<legs>", f"cannot name the legs apart (azimuths {az})")
    return names


def _order_key(name: str) -> tuple[int, int, str]:
    row = 0 if name.startswith("front") else 2 if name.startswith("rear") else 1
    side = 0 if name.endswith("left") else 1
    return (row, side, name)


def find_legs(model: mujoco.MjModel, source: str) -> tuple[list[FoundLeg], list[int]]:
    """The legs (named, ordered front to rear, left before right) and the held joint ids."""
    found, root = limbs(model, source)
    if not found:
        raise ScaffoldError(source, "<legs>", "no chain of hinge joints ends in a collidable geom")
    data = zero_pose(model)
    size = _extent(model, data)
    lowest = min(limb.foot.lowest_z_m for limb in found)
    legs = [limb for limb in found if limb.foot.lowest_z_m <= lowest + LEG_HEIGHT_TOLERANCE * size]
    if len(legs) < 2:
        raise ScaffoldError(
            source, "<legs>", "found fewer than two limbs reaching the ground in the zero pose"
        )
    rot = data.xmat[root].reshape(3, 3)
    anchors = [rot.T @ (data.xanchor[limb.joints[0]] - data.xpos[root]) for limb in legs]
    names = _names(anchors)
    named = [
        FoundLeg(n, limb.joints, limb.foot, a)
        for n, limb, a in zip(names, legs, anchors, strict=True)
    ]
    paired = not names[0].startswith("leg_")
    named.sort(key=(lambda f: _order_key(f.name)) if paired else (lambda f: f.name))
    in_legs = {j for leg in named for j in leg.joints}
    held = [
        j
        for j in range(model.njnt)
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE and j not in in_legs
    ]
    return named, held

"""Hybrid bodies between two robots of one topology (Murphy, Carr & O'Neill 2008, §3: the
horse–dog hybrids, "each discrete hybrid model is a linear interpolation between the horse and
dog").

`hybrid_robot(source, target, feet, alpha, folder)` writes a robot folder whose MJCF is the
source's tree with every matched number moved a fraction `alpha` towards the target: body
positions, geom sizes/positions/fromto, site positions, and the compiled inertials (mass,
centre of mass, inertia tensor). The servo map (robot.toml) stays the source's, so the joint
and foot names and order are the source's at every alpha; the target itself is planned with its
own files at the end of the series.

Bodies are matched by structure, not by name: the free-floating root with the root, and along
each leg (source foot i ↔ target foot ``feet[i]``, the role match of `planner.retarget`) the
bodies from the foot up to the root, by depth; joints along matched legs. Before blending, the
target is re-expressed in the source's joint conventions (`_rezero`), so the two bodies blend
in their nominal stance rather than in unrelated zero poses. Anything that does not match one
to one (body counts, chain lengths, joints per leg or their axes, foot sites) raises
`HybridBodyError` naming it. Geoms blend when a body's geoms match one to one and stay the
source's otherwise: the planner reads none of them (the inertials are written explicitly).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

import robots
from planner.errors import PlannerError
from robots import Robot
from robots.files import atomic_write_text
from robots.rotation import inertia_tensor, quat_to_mat

_PARALLEL_COS = 0.999  # joint axes this close are the same axis (or its opposite)
_SAME_QUAT_COS = 0.999  # |q_a·q_b| of two body frames that are the same rotation
_LEG_LENGTH_SLACK = 0.1  # a hybrid's leg may be this fraction outside [L_source, L_target]


class HybridBodyError(PlannerError, ValueError):
    """The two MJCFs do not share a tree that can be interpolated."""


@dataclass(frozen=True)
class BodyPairs:
    """Source body name → target body name, for every body of the source tree but the world;
    source joint → (target joint, ±1: their local axes parallel or opposed)."""

    pairs: tuple[tuple[str, str], ...]
    joints: tuple[tuple[str, str, float], ...]


def _root_body(model: mujoco.MjModel) -> int:
    return int(model.jnt_bodyid[0])  # robots.load checked joint 0 is the free joint


def _chain(model: mujoco.MjModel, site: str, root: int) -> list[int]:
    """Body ids from the foot site's body up to (excluding) the root body."""
    body = int(model.site_bodyid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)])
    out: list[int] = []
    while body not in (root, 0):
        out.append(body)
        body = int(model.body_parentid[body])
    return out


def _name(model: mujoco.MjModel, body: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body#{body}"


def match_bodies(source: Robot, target: Robot, feet: Sequence[int]) -> BodyPairs:
    """Pair every source body with a target body (root with root, leg chains by depth)."""
    ms = mujoco.MjModel.from_xml_path(str(source.mjcf_path))
    mt = mujoco.MjModel.from_xml_path(str(target.mjcf_path))
    if ms.nbody != mt.nbody:
        raise HybridBodyError(
            f"{source.name} has {ms.nbody - 1} bodies, {target.name} {mt.nbody - 1}: no hybrid "
            "series between different trees"
        )
    rs, rt = _root_body(ms), _root_body(mt)
    pairs: dict[int, int] = {rs: rt}
    joints: list[tuple[str, str, float]] = []
    for i, leg in enumerate(source.legs):
        other = target.legs[feet[i]]
        cs, ct = _chain(ms, leg.foot_site, rs), _chain(mt, other.foot_site, rt)
        if len(cs) != len(ct):
            raise HybridBodyError(
                f"leg {leg.name} of {source.name} has {len(cs)} bodies, its match {other.name} "
                f"of {target.name} {len(ct)}"
            )
        if len(leg.joints) != len(other.joints):
            raise HybridBodyError(
                f"leg {leg.name} of {source.name} has {len(leg.joints)} joints, its match "
                f"{other.name} of {target.name} {len(other.joints)}"
            )
        for js, jt in zip(leg.joints, other.joints, strict=True):
            a = ms.jnt_axis[mujoco.mj_name2id(ms, mujoco.mjtObj.mjOBJ_JOINT, js)]
            b = mt.jnt_axis[mujoco.mj_name2id(mt, mujoco.mjtObj.mjOBJ_JOINT, jt)]
            cos = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))
            if abs(cos) < _PARALLEL_COS:
                raise HybridBodyError(
                    f"joint {js} of {source.name} and {jt} of {target.name} turn about "
                    "different axes: no linear blend between them"
                )
            joints.append((js, jt, 1.0 if cos > 0 else -1.0))
        for bs, bt in zip(cs, ct, strict=True):
            if pairs.setdefault(bs, bt) != bt:
                raise HybridBodyError(
                    f"body {_name(ms, bs)} of {source.name} matches two bodies of {target.name}"
                )
    unmatched = [_name(ms, b) for b in range(1, ms.nbody) if b not in pairs]
    if unmatched:
        raise HybridBodyError(
            f"bodies {unmatched} of {source.name} are on no leg chain: cannot match them"
        )
    if len(set(pairs.values())) != len(pairs):
        raise HybridBodyError(f"two bodies of {source.name} match one body of {target.name}")
    return BodyPairs(
        tuple((_name(ms, s), _name(mt, t)) for s, t in sorted(pairs.items())), tuple(joints)
    )


def _lerp(a: np.ndarray, b: np.ndarray, alpha: float) -> np.ndarray:
    return (1.0 - alpha) * np.asarray(a, dtype=float) + alpha * np.asarray(b, dtype=float)


def compiled_spec(robot: Robot, error: type[PlannerError] = HybridBodyError) -> mujoco.MjSpec:
    """The robot's MJCF as MuJoCo writes it back (geoms as pos/quat/size, no fromto), so two
    files that say the same thing in different words interpolate alike. A file MuJoCo cannot
    write back raises `error`."""
    try:
        spec = mujoco.MjSpec.from_file(str(robot.mjcf_path))
        spec.compile()
        return mujoco.MjSpec.from_string(spec.to_xml())
    except Exception as exc:  # mujoco raises ValueError with the parser's message
        raise error(
            f"{robot.mjcf_path}: cannot rewrite it ({exc}); MJCFs with mesh files are not "
            "rewritten"
        ) from None


def make_inertials_explicit(spec: mujoco.MjSpec) -> None:
    """Write every body's compiled inertial (mass, centre of mass, principal inertia and axes)
    into `spec` and stop MuJoCo from recomputing them from the geoms, in place: a spec whose
    geometry is edited then keeps exactly the inertials written into it."""
    model = spec.compile()
    for body in spec.bodies[1:]:
        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body.name)
        body.explicitinertial = True
        body.mass = float(model.body_mass[i])
        body.ipos = model.body_ipos[i].copy()
        body.iquat = model.body_iquat[i].copy()
        body.inertia = model.body_inertia[i].copy()
        body.fullinertia = np.full(6, np.nan)
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE


def write_robot_folder(
    spec: mujoco.MjSpec,
    toml_text: str,
    folder: Path,
    what: str,
    error: type[PlannerError] = HybridBodyError,
) -> Robot:
    """Write `spec` as `folder`/robot.xml and `toml_text` as robot.toml (each atomically) and
    load the folder; a spec MuJoCo cannot write or a folder that does not load raises `error`
    with `what` (the body being written) in front of the reason."""
    folder.mkdir(parents=True, exist_ok=True)
    try:
        xml = spec.to_xml()
    except Exception as exc:  # mujoco raises ValueError with the compiler's message
        raise error(f"{what}: {exc}") from None
    atomic_write_text(folder / "robot.xml", xml)
    atomic_write_text(folder / "robot.toml", toml_text)
    try:
        return robots.load(folder)
    except robots.RobotsError as exc:
        raise error(f"{what}: {exc}") from None


def _nlerp(a: np.ndarray, b: np.ndarray, alpha: float) -> np.ndarray:
    """Unit quaternion between a and b (normalised lerp on the short arc)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    q = _lerp(a, b if float(np.dot(a, b)) >= 0 else -b, alpha)
    return q / np.linalg.norm(q)


def _rotation(axis: np.ndarray, angle_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """(quaternion, 3×3 matrix) of a rotation by `angle_rad` about `axis`."""
    quat = np.zeros(4)
    mujoco.mju_axisAngle2Quat(quat, np.asarray(axis, dtype=float), angle_rad)
    return quat, quat_to_mat(quat)


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    return out


def _rezero(spec: mujoco.MjSpec, source: Robot, target: Robot, pairs: BodyPairs) -> None:
    """Express the target in the source's joint conventions, in place.

    Target joint jt (sign σ against source joint js) at angle q_t is the source-convention
    angle q = σ·q_t − δ with δ = σ·q̄_t − q̄_s, so both stances read q̄_s. Rotating everything
    the joint's body carries by δ about the joint (and flipping its axis by σ) keeps the body
    exactly the same in space; afterwards the two trees blend in the stance pose, not in their
    unrelated zero poses (e.g. one tibia modelled along −z, the other along +x).
    """
    for js, jt, sign in pairs.joints:
        joint = spec.joint(jt)
        delta = sign * target.joint(jt).stance_rad - source.joint(js).stance_rad
        axis = sign * np.asarray(joint.axis, dtype=float)
        joint.axis = axis
        lo, hi = sorted(sign * float(r) for r in joint.range)
        joint.range = np.array([lo - delta, hi - delta])
        if abs(delta) < 1e-12:
            continue
        body = joint.parent
        if sum(1 for _ in body.joints) != 1:
            raise HybridBodyError(
                f"body {body.name} of {target.name} carries several joints: cannot re-zero {jt}"
            )
        quat, rot = _rotation(axis, delta)
        anchor = np.asarray(joint.pos, dtype=float)
        for item in (*body.bodies, *body.geoms, *body.sites):
            item.pos = anchor + rot @ (np.asarray(item.pos, dtype=float) - anchor)
            item.quat = _quat_mul(quat, item.quat)
        if body.explicitinertial:
            body.ipos = anchor + rot @ (np.asarray(body.ipos, dtype=float) - anchor)
            body.iquat = _quat_mul(quat, body.iquat)


def hybrid_spec(source: Robot, target: Robot, pairs: BodyPairs, alpha: float) -> mujoco.MjSpec:
    """The source MJCF moved `alpha` ∈ [0, 1] of the way to the target (see the module doc),
    both in the source's joint conventions (`_rezero`)."""
    if not 0.0 <= alpha <= 1.0:
        raise HybridBodyError(f"hybrid fraction must be in [0, 1], got {alpha}")
    spec, other = compiled_spec(source), compiled_spec(target)
    for sp in (spec, other):  # inertials explicit (compiled), so the rotation moves them too
        make_inertials_explicit(sp)
    _rezero(other, source, target, pairs)
    foot_sites = {leg.foot_site for leg in source.legs}
    joint_map = {js: jt for js, jt, _ in pairs.joints}
    for name_s, name_t in pairs.pairs:
        bs, bt = spec.body(name_s), other.body(name_t)
        bs.pos = _lerp(bs.pos, bt.pos, alpha)
        bs.quat = _nlerp(bs.quat, bt.quat, alpha)
        bs.mass = float(_lerp(bs.mass, bt.mass, alpha))
        bs.ipos = _lerp(bs.ipos, bt.ipos, alpha)
        # the inertia tensors (about each body's centre of mass, in its frame) blended, not
        # their principal moments and axes: two bodies' principal frames pair up arbitrarily,
        # and a quaternion between them made a left–right symmetric pair's blend asymmetric
        # (quad12 → spotmicro at α = 1/3: the torso's axes tilted about x, products of inertia
        # the mirror image does not have)
        tensor = _lerp(inertia_tensor(bs.iquat, bs.inertia),
                       inertia_tensor(bt.iquat, bt.inertia), alpha)
        bs.inertia, bs.iquat = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
        bs.fullinertia = tensor[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]
        gs, gt = list(bs.geoms), list(bt.geoms)
        if len(gs) == len(gt) and all(a.type == b.type for a, b in zip(gs, gt, strict=True)):
            for a, b in zip(gs, gt, strict=True):
                a.size = _lerp(a.size, b.size, alpha)
                a.pos = _lerp(a.pos, b.pos, alpha)
                a.quat = _nlerp(a.quat, b.quat, alpha)
        # else: the source's geoms stay. The inertials are explicit and the planner reads no
        # geom (feet are sites + foot_radius_m), so they only draw the hybrid.
        for ja in bs.joints:
            if ja.name in joint_map:
                ja.range = _lerp(ja.range, other.joint(joint_map[ja.name]).range, alpha)
        ss, st = list(bs.sites), list(bt.sites)
        if len(ss) != len(st) and not any(a.name in foot_sites for a in ss):
            continue  # sites carry no dynamics: an extra IMU site stays where the source has it
        if len(ss) != len(st):
            raise HybridBodyError(
                f"body {name_s} of {source.name} has {len(ss)} sites, {name_t} of "
                f"{target.name} {len(st)}"
            )
        for a, b in zip(ss, st, strict=True):
            a.pos = _lerp(a.pos, b.pos, alpha)
            a.quat = _nlerp(a.quat, b.quat, alpha)
    return spec


def hybrid_robot(
    source: Robot, target: Robot, pairs: BodyPairs, alpha: float, folder: Path
) -> Robot:
    """Write the hybrid's robot.xml (interpolated tree) and robot.toml (the source's servo map)
    into `folder` and load it."""
    spec = hybrid_spec(source, target, pairs, alpha)
    body = write_robot_folder(spec, _without_limits(source), folder,
                              f"hybrid {alpha:.2f} of {source.name}/{target.name}")
    lo, hi = sorted((source.leg_length_m, target.leg_length_m))
    slack = _LEG_LENGTH_SLACK * hi
    if not lo - slack <= body.leg_length_m <= hi + slack:
        raise HybridBodyError(
            f"hybrid {alpha:.2f} of {source.name}/{target.name} has legs of "
            f"{body.leg_length_m:.3f} m, outside [{lo:.3f}, {hi:.3f}] m: the two bodies' "
            "zero poses differ too much for a linear blend"
        )
    return body


def _without_limits(source: Robot) -> str:
    """The source's robot.toml without `limits_deg` (a hybrid's limits are its MJCF ranges,
    blended like the geometry); stances stay the source's (`_rezero`)."""
    text = source.toml_path.read_text(encoding="utf-8")
    return re.sub(r"(?m)^\s*limits_deg\s*=.*\n?", "", text)

"""Hybrid bodies between two robots of one topology (Murphy, Carr & O'Neill 2008, §3: the
horse–dog hybrids, "each discrete hybrid model is a linear interpolation between the horse and
dog").

`hybrid_robot(source, target, feet, alpha, folder)` writes a robot folder whose MJCF is the
source's tree with every matched number moved a fraction `alpha` towards the target: body
positions, geom sizes/positions/fromto, site positions, and the compiled inertials (mass,
centre of mass, principal inertia). The servo map (robot.toml) stays the source's, so the joint
and foot names and order are the source's at every alpha; the target itself is planned with its
own files at the end of the series.

Bodies are matched by structure, not by name: the free-floating root with the root, and along
each leg (source foot i ↔ target foot ``feet[i]``, the role match of `planner.retarget`) the
bodies from the foot up to the root, by depth. Anything that does not match one to one (chain
lengths, geom counts or types, site counts, mesh geoms) raises `HybridBodyError` naming it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

import robots
from planner.errors import PlannerError
from robots import Robot
from robots.files import atomic_write_text


class HybridBodyError(PlannerError, ValueError):
    """The two MJCFs do not share a tree that can be interpolated."""


@dataclass(frozen=True)
class BodyPairs:
    """Source body name → target body name, for every body of the source tree but the world."""

    pairs: tuple[tuple[str, str], ...]


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
    for i, leg in enumerate(source.legs):
        other = target.legs[feet[i]]
        cs, ct = _chain(ms, leg.foot_site, rs), _chain(mt, other.foot_site, rt)
        if len(cs) != len(ct):
            raise HybridBodyError(
                f"leg {leg.name} of {source.name} has {len(cs)} bodies, its match {other.name} "
                f"of {target.name} {len(ct)}"
            )
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
    return BodyPairs(tuple((_name(ms, s), _name(mt, t)) for s, t in sorted(pairs.items())))


def _lerp(a: np.ndarray, b: np.ndarray, alpha: float) -> np.ndarray:
    return (1.0 - alpha) * np.asarray(a, dtype=float) + alpha * np.asarray(b, dtype=float)


def _compiled_spec(robot: Robot) -> mujoco.MjSpec:
    """The robot's MJCF as MuJoCo writes it back (geoms as pos/quat/size, no fromto), so two
    files that say the same thing in different words interpolate alike."""
    try:
        spec = mujoco.MjSpec.from_file(str(robot.mjcf_path))
        spec.compile()
        return mujoco.MjSpec.from_string(spec.to_xml())
    except Exception as exc:  # mujoco raises ValueError with the parser's message
        raise HybridBodyError(
            f"{robot.mjcf_path}: cannot rewrite it for a hybrid series ({exc}); "
            "MJCFs with mesh files are not interpolated"
        ) from None


def hybrid_spec(source: Robot, target: Robot, pairs: BodyPairs, alpha: float) -> mujoco.MjSpec:
    """The source MJCF moved `alpha` ∈ [0, 1] of the way to the target (see the module doc)."""
    if not 0.0 <= alpha <= 1.0:
        raise HybridBodyError(f"hybrid fraction must be in [0, 1], got {alpha}")
    spec, other = _compiled_spec(source), _compiled_spec(target)
    ms = mujoco.MjModel.from_xml_path(str(source.mjcf_path))
    mt = mujoco.MjModel.from_xml_path(str(target.mjcf_path))
    foot_sites = {leg.foot_site for leg in source.legs}
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    for name_s, name_t in pairs.pairs:
        bs, bt = spec.body(name_s), other.body(name_t)
        ids = mujoco.mj_name2id(ms, mujoco.mjtObj.mjOBJ_BODY, name_s)
        idt = mujoco.mj_name2id(mt, mujoco.mjtObj.mjOBJ_BODY, name_t)
        bs.pos = _lerp(bs.pos, bt.pos, alpha)
        # compiled inertials (whatever the files wrote: <inertial>, geoms, fullinertia)
        bs.explicitinertial = True
        bs.mass = float(_lerp(ms.body_mass[ids], mt.body_mass[idt], alpha))
        bs.ipos = _lerp(ms.body_ipos[ids], mt.body_ipos[idt], alpha)
        bs.iquat = ms.body_iquat[ids].copy()
        bs.inertia = _lerp(ms.body_inertia[ids], mt.body_inertia[idt], alpha)
        bs.fullinertia = np.full(6, np.nan)
        gs, gt = list(bs.geoms), list(bt.geoms)
        if len(gs) != len(gt):
            raise HybridBodyError(
                f"body {name_s} of {source.name} has {len(gs)} geoms, {name_t} of "
                f"{target.name} {len(gt)}"
            )
        for a, b in zip(gs, gt, strict=True):
            if a.type != b.type or a.type == mujoco.mjtGeom.mjGEOM_MESH:
                raise HybridBodyError(
                    f"geoms of body {name_s}/{name_t} differ in type or are meshes: "
                    "cannot interpolate them"
                )
            a.size = _lerp(a.size, b.size, alpha)
            if np.all(np.isfinite(a.fromto)) and np.all(np.isfinite(b.fromto)):
                a.fromto = _lerp(a.fromto, b.fromto, alpha)  # (pos and fromto are exclusive)
            else:
                a.pos = _lerp(a.pos, b.pos, alpha)
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
    return spec


def hybrid_robot(
    source: Robot, target: Robot, pairs: BodyPairs, alpha: float, folder: Path
) -> Robot:
    """Write the hybrid's robot.xml (interpolated tree) and robot.toml (the source's servo map)
    into `folder` and load it."""
    spec = hybrid_spec(source, target, pairs, alpha)
    folder.mkdir(parents=True, exist_ok=True)
    try:
        xml = spec.to_xml()
    except Exception as exc:  # mujoco raises ValueError with the compiler's message
        raise HybridBodyError(f"hybrid {alpha:.2f} of {source.name}/{target.name}: {exc}") from None
    atomic_write_text(folder / "robot.xml", xml)
    atomic_write_text(folder / "robot.toml", source.toml_path.read_text(encoding="utf-8"))
    return robots.load(folder)

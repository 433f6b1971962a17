"""The sole of a flat foot: a rectangle fixed to the foot body, lying on the ground in stance.

A leg declared ``foot = "flat"`` in robot.toml gets its sole from

- ``sole_size_m = [length, width]`` in its ``[legs.NAME]`` table: the sole is centred on the foot
  site, in the site's frame (x along the length, y across, z the outward normal pointing up
  from the ground into the foot); or else
- the one collidable ``box`` geom of the foot body: the sole is its bottom face (the −z face of
  the geom frame), half length = size[0], half width = size[1].

The sole frame's origin is the sole centre; in stance the planner keeps its z-axis vertical and
its centre on the ground. Pure numpy + MuJoCo (no CasADi): shared by the loader, planner and sim.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from robots.errors import RobotConfigError
from robots.rotation import quat_to_mat


def resolve_sole(model: Any, spec_leg: Any, leg: Any, toml_file: str, mjcf_file: str) -> Any:
    """`leg` (a `robots.Leg` with its foot body and geoms) completed with its sole geometry.

    `spec_leg` is the leg as robot.toml gave it (its `sole_half_extents_m`, if any).
    """
    import mujoco

    where = f"[legs.{leg.name}]"
    if spec_leg.sole_half_extents_m is not None:
        return replace(
            leg, foot_kind="flat", sole_half_extents_m=spec_leg.sole_half_extents_m, sole_geom=""
        )
    boxes = [
        g
        for g in leg.foot_geoms
        if int(model.geom_type[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g)])
        == int(mujoco.mjtGeom.mjGEOM_BOX)
    ]
    if len(boxes) != 1:
        found = f"box geoms {boxes}" if boxes else "no box geom"
        raise RobotConfigError(
            toml_file,
            f"{where}.foot",
            f"a flat foot needs one collidable box geom on body {leg.foot_body!r} in {mjcf_file} "
            f"(found {found}), or sole_size_m = [length, width] with the foot site at the sole "
            "centre",
        )
    gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, boxes[0])
    size = model.geom_size[gid]
    return replace(
        leg,
        foot_kind="flat",
        sole_half_extents_m=(float(size[0]), float(size[1])),
        sole_geom=boxes[0],
    )


def sole_frame_local(model: Any, leg: Any) -> tuple[np.ndarray, np.ndarray]:
    """(centre 3, rotation 3×3) of the sole frame in its foot body's frame."""
    import mujoco

    if leg.sole_geom:
        gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, leg.sole_geom)
        rot = quat_to_mat(model.geom_quat[gid])
        pos = np.array(model.geom_pos[gid], dtype=float)
        return pos - rot[:, 2] * float(model.geom_size[gid][2]), rot
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
    return np.array(model.site_pos[sid], dtype=float), quat_to_mat(model.site_quat[sid])


def sole_pose_world(model: Any, data: Any, leg: Any) -> tuple[np.ndarray, np.ndarray]:
    """(centre 3, rotation 3×3) of the sole in the world after `mj_kinematics`."""
    import mujoco

    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, leg.foot_body)
    centre, rot = sole_frame_local(model, leg)
    body_rot = np.array(data.xmat[body], dtype=float).reshape(3, 3)
    return np.array(data.xpos[body], dtype=float) + body_rot @ centre, body_rot @ rot


def sole_corners_local(leg: Any) -> np.ndarray:
    """4 × 3 sole corners in the sole frame: (±l/2, ±w/2, 0)."""
    hx, hy = leg.sole_half_extents_m
    return np.array([[hx, hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0], [hx, -hy, 0.0]])

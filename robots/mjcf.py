"""Model preparation: the user's MJCF, as they have it, turned into the model gaitsmith uses.

ONE place for it: `robots.load` prepares the model once and keeps the result on the `Robot`
(`Robot.mj_spec()` / `Robot.mj_model()`), and the planner, the simulator and the templates all
build from that, so they see the same bodies, joints, limits, damping and floor. Steps:

1. parse with `mujoco.MjSpec.from_file` (``<include>`` files resolve relative to the model file);
2. make asset folders absolute (meshdir, texturedir; files given relative to the model's folder),
   so the prepared XML compiles from any working directory and can be written anywhere;
3. remove the model's own actuators (and the sensors and keyframe controls that refer to them)
   with one notice — gaitsmith adds its servos itself;
4. give every unnamed body and geom a ``gs_``-prefixed name, so a foot body and its geoms can be
   referred to (contact sensors);
5. add a floor plane at z = 0, with a notice, when the world has no collidable geom (menagerie
   models keep their floor in scene.xml);
6. joint ranges: a servo joint needs limits — from the MJCF ``range`` or robot.toml's
   ``limits_deg``; the latter becomes the prepared model's range when the MJCF has none;
7. robot.toml's per-joint ``damping_nm_s_per_rad`` / ``armature_kg_m2`` replace the MJCF's
   (see the damping rule in `robots.robot`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robots.errors import RobotConfigError

FLOOR_NAME = "gs_floor"
MAX_MJCF_BYTES = 64 << 20  # 64 MiB of XML (meshes live in their own files)


@dataclass(frozen=True)
class JointPrep:
    """What robot.toml asks of one MJCF joint during preparation."""

    name: str
    limits_rad: tuple[float, float] | None
    damping_nm_s_per_rad: float | None = None
    armature_kg_m2: float | None = None


@dataclass(frozen=True)
class PreparedMjcf:
    """The prepared model as self-contained MJCF text (absolute asset paths) + its notices."""

    xml: str
    notices: tuple[str, ...]

    def spec(self) -> Any:
        """A fresh `mujoco.MjSpec` of the prepared model (callers may add to it)."""
        import mujoco

        return mujoco.MjSpec.from_string(self.xml)

    def model(self) -> Any:
        """The compiled `mujoco.MjModel`."""
        return self.spec().compile()


def prepare(mjcf_path: Path, joints: tuple[JointPrep, ...], toml_file: str) -> PreparedMjcf:
    """Prepare `mjcf_path` for gaitsmith (see the module docstring); RobotConfigError if unfit."""
    import mujoco

    mfile = str(mjcf_path)
    try:
        size = mjcf_path.stat().st_size
    except OSError as exc:
        raise RobotConfigError(mfile, "<file>", f"cannot read: {exc}") from None
    if size > MAX_MJCF_BYTES:
        raise RobotConfigError(mfile, "<file>", f"is {size} bytes; at most {MAX_MJCF_BYTES}")
    try:
        spec = mujoco.MjSpec.from_file(mfile)
    except Exception as exc:  # mujoco raises ValueError with the parser's message
        raise RobotConfigError(
            mfile, "<mjcf>", f"MuJoCo cannot parse it: {_one_line(exc)}"
        ) from None
    notices: list[str] = []
    _absolute_asset_dirs(spec, mjcf_path.parent)
    _remove_actuators(spec, mfile, notices)
    _name_anonymous(spec)
    try:
        model = spec.compile()
    except Exception as exc:
        raise RobotConfigError(
            mfile, "<mjcf>", f"MuJoCo cannot compile it: {_one_line(exc)}"
        ) from None
    _check_magnitudes(model, mfile)
    if not _has_floor(model):
        floor = spec.worldbody.add_geom()
        floor.name = FLOOR_NAME
        floor.type = mujoco.mjtGeom.mjGEOM_PLANE
        floor.size = (0.0, 0.0, 0.05)
        floor.contype, floor.conaffinity = 1, 1
        notices.append(
            f"{mfile}: no floor in the model (menagerie keeps it in scene.xml); "
            f"gaitsmith added a plane '{FLOOR_NAME}' at z = 0"
        )
    _joints(spec, model, joints, mfile, toml_file)
    try:
        xml = spec.to_xml()
        prepared = mujoco.MjSpec.from_string(xml).compile()
    except Exception as exc:
        raise RobotConfigError(
            mfile, "<mjcf>", f"the prepared model does not compile: {_one_line(exc)}"
        ) from None
    _check_magnitudes(prepared, mfile)
    return PreparedMjcf(xml=xml, notices=tuple(notices))


MAX_BODY_MASS_KG = 1e4
MAX_INERTIA_KG_M2 = 1e4
MAX_LENGTH_M = 1e4  # positions and geom sizes (a floor may be large, a robot is not)
MAX_RANGE_RAD = 4.0 * math.pi
MAX_DAMPING = 1e4  # N·m·s/rad, and armature kg·m²


def _check_magnitudes(model: Any, mfile: str) -> None:
    """Refuse absurd numbers MuJoCo accepts (mass 1e308, range ±inf, pos 1e308 …), by element."""
    import mujoco
    import numpy as np

    def name(kind: Any, i: int) -> str:
        return mujoco.mj_id2name(model, kind, i) or f"#{i}"

    body, geom, joint = (
        mujoco.mjtObj.mjOBJ_BODY,
        mujoco.mjtObj.mjOBJ_GEOM,
        mujoco.mjtObj.mjOBJ_JOINT,
    )
    checks = (
        (model.body_mass, MAX_BODY_MASS_KG, body, "body", "mass [kg]"),
        (model.body_inertia, MAX_INERTIA_KG_M2, body, "body", "inertia [kg·m²]"),
        (model.body_pos, MAX_LENGTH_M, body, "body", "pos [m]"),
        (model.body_ipos, MAX_LENGTH_M, body, "body", "inertial pos [m]"),
        (model.geom_size, MAX_LENGTH_M, geom, "geom", "size [m]"),
        (model.geom_pos, MAX_LENGTH_M, geom, "geom", "pos [m]"),
        (model.jnt_pos, MAX_LENGTH_M, joint, "joint", "pos [m]"),
        (
            model.jnt_range[1:] if model.njnt else model.jnt_range,
            MAX_RANGE_RAD,
            None,
            "joint",
            "range [rad]",
        ),
    )
    for values, bound, kind, label, what in checks:
        a = np.asarray(values, dtype=float).reshape(len(values), -1)
        bad = ~np.isfinite(a) | (np.abs(a) > bound)
        if np.any(bad):
            i = int(np.argwhere(bad)[0][0])
            row = a[i].tolist()
            if kind is None:  # joint ranges, freejoint (index 0) skipped
                i, kind = i + 1, joint
            raise RobotConfigError(
                mfile,
                f"{label} {name(kind, i)}",
                f"{what} {row} is not finite or beyond ±{bound:g}; fix the MJCF value",
            )
    for values, what in ((model.dof_damping, "damping"), (model.dof_armature, "armature")):
        a = np.asarray(values, dtype=float)
        bad = ~np.isfinite(a) | (np.abs(a) > MAX_DAMPING)
        if np.any(bad):
            jnt = int(model.dof_jntid[int(np.argwhere(bad)[0][0])])
            raise RobotConfigError(
                mfile,
                f"joint {name(joint, jnt)}",
                f"{what} is not finite or beyond {MAX_DAMPING:g}",
            )
    total = float(np.sum(model.body_mass))
    if not 0.0 < total <= MAX_BODY_MASS_KG:
        raise RobotConfigError(mfile, "<mass>", f"total mass {total:g} kg is implausible")


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:400]


def _absolute_asset_dirs(spec: Any, folder: Path) -> None:
    folder = folder.resolve()
    for attr in ("meshdir", "texturedir"):
        value = getattr(spec, attr) or ""
        setattr(spec, attr, str((folder / value).resolve()) + "/")
    # files named relative to the asset folder stay relative to it; absolute ones stay absolute


def _remove_actuators(spec: Any, mfile: str, notices: list[str]) -> None:
    import mujoco

    acts = list(spec.actuators)
    if not acts:
        return
    names = {a.name for a in acts if a.name}
    actuator_sensors = {
        mujoco.mjtSensor.mjSENS_ACTUATORPOS,
        mujoco.mjtSensor.mjSENS_ACTUATORVEL,
        mujoco.mjtSensor.mjSENS_ACTUATORFRC,
    }
    dropped_sensors = 0
    for s in list(spec.sensors):
        if s.type in actuator_sensors or (
            s.objtype == mujoco.mjtObj.mjOBJ_ACTUATOR and s.objname in names
        ):
            spec.delete(s)
            dropped_sensors += 1
    for a in acts:
        spec.delete(a)
    for key in spec.keys:
        key.ctrl = []
    extra = f" and {dropped_sensors} actuator sensor(s)" if dropped_sensors else ""
    notices.append(
        f"{mfile}: removed its {len(acts)} actuator(s){extra}; gaitsmith adds its own servo "
        "model on every servo joint"
    )


def _name_anonymous(spec: Any) -> None:
    taken = {b.name for b in spec.bodies} | {g.name for g in spec.geoms}
    for i, body in enumerate(spec.bodies):
        if i and not body.name:
            name = f"gs_body{i}"
            while name in taken:
                name += "_"
            body.name = name
            taken.add(name)
    for i, geom in enumerate(spec.geoms):
        if not geom.name:
            name = f"gs_geom{i}"
            while name in taken:
                name += "_"
            geom.name = name
            taken.add(name)


def _has_floor(model: Any) -> bool:
    return any(
        int(model.geom_bodyid[g]) == 0
        and (int(model.geom_contype[g]) != 0 or int(model.geom_conaffinity[g]) != 0)
        for g in range(model.ngeom)
    )


def _joints(
    spec: Any, model: Any, joints: tuple[JointPrep, ...], mfile: str, toml_file: str
) -> None:
    import mujoco

    degree = bool(spec.compiler.degree)
    for jp in joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, jp.name)
        if jid < 0:
            continue  # robots.robot reports it with the robot.toml field
        sj = spec.joint(jp.name)
        if not model.jnt_limited[jid]:
            if jp.limits_rad is None:
                raise RobotConfigError(
                    mfile,
                    f"joint {jp.name}",
                    'has no range (or an empty one, or limited="false"); a servo joint needs '
                    "limits: add "
                    f'range="lo hi" to the joint in the MJCF, or limits_deg = [lo, hi] to '
                    f"[joints.{jp.name}] in {toml_file}",
                )
            lo, hi = jp.limits_rad
            sj.range = (math.degrees(lo), math.degrees(hi)) if degree else (lo, hi)
            sj.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        if jp.damping_nm_s_per_rad is not None:
            damping = list(sj.damping) if hasattr(sj.damping, "__len__") else [sj.damping]
            damping = [jp.damping_nm_s_per_rad] + [0.0] * (len(damping) - 1)
            sj.damping = damping if len(damping) > 1 else damping[0]
        if jp.armature_kg_m2 is not None:
            sj.armature = jp.armature_kg_m2

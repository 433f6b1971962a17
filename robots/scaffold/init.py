"""`robots init`: a URDF or MJCF → a robot folder (robot.xml + commented robot.toml).

Decisions the model does not make for us (the servo model, ranges of continuous joints) come
from the caller's `Questions`; without answers the scaffold stops with a one-line error naming
what to pass. Everything else it decides is listed in robot.toml's header and in `notes`.
The folder is written to a temporary sibling, loaded back with `robots.load`, and only then
moved into place, so a failure never leaves a half-written folder.
"""

from __future__ import annotations

import math
import re
import shutil
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from robots.errors import RobotsError
from robots.rotation import quat_to_mat
from robots.scaffold.convert import load_spec, write_assets
from robots.scaffold.errors import ScaffoldError
from robots.scaffold.legs import FoundLeg, find_legs
from robots.scaffold.stance import GROUND_TOL_M, find_stance
from robots.scaffold.toml_text import JointEntry, LegEntry, robot_toml
from robots.servo import ServoModel, load_catalogue

REACH_MARGIN_RAD = math.radians(0.1)
SOLE_NORMAL_TOL_RAD = math.radians(5.0)  # box z-axis this close to up: its −z face is the sole

ServoQuestion = Callable[[list[str]], str | None]  # known models → chosen model (None: no answer)
LimitQuestion = Callable[[str], tuple[float, float] | None]  # joint → (lower, upper) degrees


@dataclass(frozen=True)
class Questions:
    """How to ask the user; None means nobody can be asked (non-interactive / --yes)."""

    servo: ServoQuestion | None = None
    limits_deg: LimitQuestion | None = None


@dataclass(frozen=True)
class InitResult:
    out_dir: Path
    name: str
    legs: tuple[tuple[str, tuple[str, ...]], ...]  # (leg, joints)
    held: tuple[str, ...]
    servo: str
    base_height_m: float
    notes: tuple[str, ...] = field(default_factory=tuple)


def _safe_name(text: str) -> str:
    name = re.sub(r"[^A-Za-z0-9_-]+", "_", text).strip("_")
    return name or "robot"


def _unique_name(model: mujoco.MjModel, kind: mujoco.mjtObj, count: int, name: str) -> str:
    taken = {mujoco.mj_id2name(model, kind, i) for i in range(count)}
    out, k = name, 1
    while out in taken:
        out, k = f"{name}_{k}", k + 1
    return out


def _box_sole(model: mujoco.MjModel, leg: FoundLeg) -> str | None:
    """The foot geom's name ("" if unnamed) when the loader can take a flat sole from it.

    `robots.sole.resolve_sole` reads a flat foot's sole as the bottom (−z) face of the one
    collidable box geom of the foot body, so that box must be the foot, the only collidable
    box there, and its z-axis the sole's upward normal. None otherwise (a mesh or cylinder
    sole, a box lying on its side): such a foot stays a point.
    """
    g = leg.foot.geom
    if int(model.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_BOX):
        return None
    first = int(model.body_geomadr[leg.foot.body])
    boxes = [
        k
        for k in range(first, first + int(model.body_geomnum[leg.foot.body]))
        if int(model.geom_type[k]) == int(mujoco.mjtGeom.mjGEOM_BOX)
        and (model.geom_contype[k] or model.geom_conaffinity[k])
    ]
    if boxes != [g]:
        return None
    up = leg.foot.sole_normal_local / np.linalg.norm(leg.foot.sole_normal_local)
    if float(quat_to_mat(model.geom_quat[g])[:, 2] @ up) < math.cos(SOLE_NORMAL_TOL_RAD):
        return None
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""


def _choose_servo(servo: str | None, questions: Questions, source: str) -> ServoModel:
    catalogue = load_catalogue()
    known = sorted(catalogue)
    if servo is None and questions.servo is not None:
        servo = questions.servo(known)
    if servo is None:
        raise ScaffoldError(
            source, "--servo", f"which servo drives the joints? pass --servo MODEL (one of {known})"
        )
    if servo not in catalogue:
        raise ScaffoldError(source, "--servo", f"unknown servo model {servo!r}; known: {known}")
    return catalogue[servo]


def _unlimited_ranges(
    model: mujoco.MjModel,
    given: Mapping[str, tuple[float, float]],
    questions: Questions,
    source: str,
) -> dict[str, tuple[float, float]]:
    """Ranges (degrees) for the hinge joints the model leaves unlimited (URDF `continuous`)."""
    missing = []
    out: dict[str, tuple[float, float]] = {}
    for j in range(1, model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        if model.jnt_limited[j] and name not in given:
            continue
        rng = given.get(name)
        if rng is None and questions.limits_deg is not None:
            rng = questions.limits_deg(name)
        if rng is None:
            missing.append(name)
            continue
        if not (math.isfinite(rng[0]) and math.isfinite(rng[1]) and rng[0] < rng[1]):
            raise ScaffoldError(source, f"--limit {name}", f"lower must be below upper, got {rng}")
        out[name] = rng
    if missing:
        raise ScaffoldError(
            source,
            f"joint {missing[0]}",
            f"has no limits (continuous); pass --limit {missing[0]}=LOWER,UPPER in degrees "
            f"(joints without limits: {missing})",
        )
    return out


def init_robot(
    model_path: Path,
    out_dir: Path,
    *,
    servo: str | None = None,
    name: str | None = None,
    limits_deg: Mapping[str, tuple[float, float]] | None = None,
    questions: Questions = Questions(),
) -> InitResult:
    """Scaffold a robot folder from a URDF/MJCF (see the module docstring)."""
    source = str(model_path)
    if out_dir.exists() and (not out_dir.is_dir() or any(out_dir.iterdir())):
        raise ScaffoldError(str(out_dir), "-o", "exists and is not empty; choose a new folder")
    conv = load_spec(model_path)
    spec, notes = conv.spec, conv.notes
    model = spec.compile()
    for free, (lo, hi) in _unlimited_ranges(model, limits_deg or {}, questions, source).items():
        joint = spec.joint(free)
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        joint.range = (math.radians(lo), math.radians(hi))
        notes.append(f"joint {free}: range [{lo:g}, {hi:g}]° as given (the model had none)")
    model = spec.compile()
    legs, held = find_legs(model, source)
    chosen = _choose_servo(servo, questions, source)
    jname = {j: mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)}

    zero = (chosen.position_min_tick + chosen.position_max_tick + 1) // 2
    reach = (  # what the servo reaches around its centre, less REACH_MARGIN (rounding)
        (chosen.position_min_tick - zero) / chosen.ticks_per_rad + REACH_MARGIN_RAD,
        (chosen.position_max_tick - zero) / chosen.ticks_per_rad - REACH_MARGIN_RAD,
    )
    limits: dict[int, tuple[float, float]] = {}
    narrowed: dict[int, tuple[float, float]] = {}
    for j in [*[k for leg in legs for k in leg.joints], *held]:
        lo, hi = (float(v) for v in model.jnt_range[j])
        lo2, hi2 = max(lo, reach[0]), min(hi, reach[1])
        if lo2 >= hi2:
            raise ScaffoldError(
                source, f"joint {jname[j]}", f"its range lies outside what {chosen.name} reaches"
            )
        if (lo2, hi2) != (lo, hi):
            narrowed[j] = (lo2, hi2)
        limits[j] = (lo2, hi2)
    held_rad = {j: min(max(0.0, limits[j][0]), limits[j][1]) for j in held}

    stance = find_stance(model, legs, limits, held_rad)
    if stance.max_foot_error_m > GROUND_TOL_M:
        raise ScaffoldError(
            source,
            "<stance>",
            f"found no pose inside the joint limits with every foot on the ground (worst foot "
            f"{stance.max_foot_error_m * 1e3:.1f} mm off); check the joint ranges",
        )
    if stance.lowest_body_clearance_m < 0.0:
        raise ScaffoldError(
            source,
            "<stance>",
            "in the best standing pose found the body is "
            f"{-stance.lowest_body_clearance_m * 1e3:.0f} mm into the ground; "
            "the legs are too short for the body or their ranges too narrow",
        )

    radii = sorted(leg.foot.radius_m for leg in legs)
    foot_radius = radii[len(radii) // 2]
    if radii[-1] - radii[0] > 1e-3:
        notes.append(f"feet differ in radius ({radii[0]:.4f}–{radii[-1]:.4f} m); used the median")
    soles = {leg.name: _box_sole(model, leg) for leg in legs if leg.foot.flat}
    declared = [name for name, geom in soles.items() if geom is not None]
    undeclared = [name for name, geom in soles.items() if geom is None]
    if declared:
        notes.append(
            f"flat feet ({', '.join(declared)}): foot = \"flat\", the sole is the bottom face "
            f"of the foot's box geom (planned lying on the ground in stance); foot site "
            f"{foot_radius * 1e3:.0f} mm above the sole"
        )
    if undeclared:
        notes.append(
            f"flat soles that are not one upright box geom ({', '.join(undeclared)}): planned "
            f"as point feet at a site {foot_radius * 1e3:.0f} mm above the sole; to plan them "
            'flat add foot = "flat" and sole_size_m = [length, width] to the leg, with its '
            "foot site moved to the sole centre"
        )
    site_names: dict[str, str] = {}
    for leg in legs:
        body = spec.body(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, leg.foot.body))
        site = body.add_site()
        site.name = _unique_name(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite, f"{leg.name}_foot")
        site_names[leg.name] = site.name
        site.pos = tuple(float(v) for v in leg.foot.site_local)
        site.size = (0.005, 0.005, 0.005)
        k = leg.foot.geom - int(model.body_geomadr[leg.foot.body])
        geom = body.geoms[k]
        if not geom.name:
            geom.name = _unique_name(
                model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom, f"{leg.name}_foot"
            )
        if soles.get(leg.name) is not None:
            soles[leg.name] = geom.name
    notes.append(
        f"found {len(legs)} legs ({', '.join(leg.name for leg in legs)}), named by where "
        "they leave the body (+x front, +y left)"
    )
    notes.append(
        f"stance: every foot on the ground, body level, base {stance.base_height_m:.3f} m up, "
        f"centre of mass {stance.com_offset_m * 1e3:.0f} mm from the feet's centroid"
    )
    if held:
        notes.append(
            f'{len(held)} joints not in a leg are held (role = "hold") at 0° or their '
            f"nearest limit: {', '.join(jname[j] for j in held)}"
        )
    for j, (lo, hi) in narrowed.items():
        notes.append(
            f"joint {jname[j]}: limits narrowed to [{math.degrees(lo):.1f}, "
            f"{math.degrees(hi):.1f}]° ({chosen.name} reaches only that around its centre)"
        )
    no_armature = [jname[j] for j in limits if model.dof_armature[model.jnt_dofadr[j]] == 0.0]
    if no_armature and chosen.armature_kg_m2 is not None:
        # the servo's identified rotor inertia (robots/servos.toml): without it the servos'
        # legs swing like weightless ones and a gait that walks in MuJoCo is out of the real
        # servo's reach (docs/results/servo_armature.md)
        for joint_name in no_armature:
            spec.joint(joint_name).armature = chosen.armature_kg_m2
        notes.append(
            f"{len(no_armature)} joints had no armature (reflected rotor inertia): set to "
            f"{chosen.name}'s identified {chosen.armature_kg_m2:g} kg·m² (robots/servos.toml)"
        )
    elif no_armature:
        notes.append(
            f"{len(no_armature)} joints have no armature (reflected rotor inertia) and no "
            f"identified figure is known for {chosen.name}: add the servo's armature in robot.xml "
            "(without it the legs swing faster in MuJoCo than the real servos can)"
        )
    servo_mass = chosen.mass_kg * len(limits)
    total = float(sum(model.body_mass))
    if servo_mass > total:
        notes.append(
            f"the model weighs {total:.3f} kg, less than its {len(limits)} servos "
            f"({servo_mass:.3f} kg): check the link masses"
        )
    notes.append("every direction = +1 and zero_offset_ticks = the servo's centre: calibrate")

    robot_name = _safe_name(name or spec.modelname or model_path.stem)
    bus = 1
    entries: list[JointEntry] = []
    for j in [*[k for leg in legs for k in leg.joints], *held]:
        entries.append(
            JointEntry(
                name=jname[j],
                servo=chosen.name,
                bus_id=bus,
                zero_offset_ticks=zero,
                stance_rad=stance.q_rad[j],
                hold=j in held,
                limits_rad=narrowed.get(j),
                comment="",
            )
        )
        bus += 1
    leg_entries = [
        LegEntry(
            leg.name,
            site_names[leg.name],
            tuple(jname[j] for j in leg.joints),
            sole_geom=soles.get(leg.name) or "",
        )
        for leg in legs
    ]
    description = (
        f"{len(legs)}-legged, {len(limits)} joints on {chosen.name}, from {model_path.name}"
    )
    spec.modelname = robot_name
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}-", dir=out_dir.parent))
    try:
        relative = write_assets(conv, tmp)
        xml = spec.to_xml()
        for absolute, rel in relative.items():
            xml = xml.replace(f'file="{absolute}"', f'file="{rel}"')
        (tmp / "robot.xml").write_text(xml, encoding="utf-8")
        text = robot_toml(
            name=robot_name,
            description=description,
            source=model_path.name,
            foot_radius_m=foot_radius,
            bus_baud=chosen.default_baud,
            joints=entries,
            legs=leg_entries,
            notes=notes,
        )
        (tmp / "robot.toml").write_text(text, encoding="utf-8")
        from robots.robot import load

        try:
            load(tmp)
        except RobotsError as exc:
            raise ScaffoldError(
                source, "<robot folder>", f"the scaffold does not load back: {exc}"
            ) from None
        if out_dir.exists():
            out_dir.rmdir()
        tmp.rename(out_dir)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
    return InitResult(
        out_dir=out_dir,
        name=robot_name,
        legs=tuple((e.name, e.joints) for e in leg_entries),
        held=tuple(jname[j] for j in held),
        servo=chosen.name,
        base_height_m=stance.base_height_m,
        notes=tuple(notes),
    )

"""URDF or MJCF → an MjSpec gaitsmith can use: free root body, a floor, no actuators, servo physics.

URDF goes through MuJoCo's own parser (`mujoco.MjSpec.from_string`). MuJoCo welds a URDF's root
link to the world, so a floating joint from a new `gs_world` link to the root link is added
first; MuJoCo turns it into the free joint. Everything changed is recorded as a note, so
`robots init` can say what it did.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from robots.scaffold.errors import ScaffoldError

FLOOR_NAME = "floor"


@dataclass
class Converted:
    """The prepared spec, the file it came from and what was changed (human-readable notes)."""

    spec: mujoco.MjSpec
    source: Path
    notes: list[str] = field(default_factory=list)


def _urdf_text(path: Path) -> str:
    """The URDF with a floating root joint and its mesh paths made absolute."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ScaffoldError(str(path), "<urdf>", f"not readable XML: {exc}") from None
    if root.tag != "robot":
        raise ScaffoldError(str(path), "<robot>", f"root element is <{root.tag}>, not <robot>")
    links = [link.get("name", "") for link in root.findall("link")]
    children = {c.get("link") for j in root.findall("joint") for c in j.findall("child")}
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise ScaffoldError(
            str(path), "<link>", f"needs exactly one root link (not a joint's child), found {roots}"
        )
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        rel = name.split("://", 1)[1].split("/", 1)[-1] if "://" in name else name
        candidates = [path.parent / rel, path.parent / Path(rel).name]
        found = next((c for c in candidates if c.is_file()), None)
        if found is None:
            raise ScaffoldError(
                str(path), f"<mesh filename={name!r}>", "file not found next to the URDF"
            )
        mesh.set("filename", str(found.resolve()))
    ET.SubElement(root, "link", name="gs_world")
    joint = ET.SubElement(root, "joint", name="gs_root", type="floating")
    ET.SubElement(joint, "parent", link="gs_world")
    ET.SubElement(joint, "child", link=roots[0])
    ext = ET.SubElement(root, "mujoco")
    ET.SubElement(ext, "compiler", strippath="false", discardvisual="true", fusestatic="true")
    return ET.tostring(root, encoding="unicode")


def load_spec(path: Path) -> Converted:
    """Parse a URDF (.urdf) or MJCF (.xml) into a spec with a free root body."""
    if not path.is_file():
        raise ScaffoldError(str(path), "<file>", "no such file")
    suffix = path.suffix.lower()
    try:
        if suffix == ".urdf":
            text = _urdf_text(path)
            spec = mujoco.MjSpec.from_string(text)
            conv = Converted(spec, path, ["converted the URDF with MuJoCo's URDF parser"])
        elif suffix == ".xml":
            spec = mujoco.MjSpec.from_file(str(path))
            conv = Converted(spec, path)
        else:
            raise ScaffoldError(str(path), "<file>", "give a .urdf or an MJCF .xml file")
        spec.compile()
    except ScaffoldError:
        raise
    except Exception as exc:  # mujoco raises ValueError with its parser's message
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ScaffoldError(str(path), "<model>", f"MuJoCo cannot load it: {msg}") from None
    _free_root(conv)
    _strip_actuation(conv)
    _ensure_floor(conv)
    if conv.spec.option.integrator != mujoco.mjtIntegrator.mjINT_IMPLICITFAST:
        conv.spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        conv.notes.append("integrator set to implicitfast (joint damping integrated implicitly)")
    if suffix == ".xml":
        _collect_assets(conv)
    return conv


def _free_root(conv: Converted) -> None:
    spec, src = conv.spec, str(conv.source)
    tops = [b for b in spec.worldbody.bodies]
    if len(tops) != 1:
        names = [b.name for b in tops]
        raise ScaffoldError(src, "<worldbody>", f"needs exactly one robot body, found {names}")
    top = tops[0]
    if not top.name:
        top.name = "base"
    free = [j for j in top.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
    if not free:
        if list(top.joints):
            raise ScaffoldError(
                src, f"body {top.name}", "the root body has joints but no free joint"
            )
        top.add_freejoint(name="root")
        conv.notes.append(f"added a free joint to the root body {top.name!r}")


def _strip_actuation(conv: Converted) -> None:
    spec = conv.spec
    if spec.actuators:
        conv.notes.append(
            f"removed the model's {len(spec.actuators)} actuators: gaitsmith adds its servo model"
        )
        for a in list(spec.actuators):
            spec.delete(a)
    if spec.sensors:
        conv.notes.append(f"removed {len(spec.sensors)} sensors (gaitsmith adds its own)")
        for s in list(spec.sensors):
            spec.delete(s)
    if spec.keys:
        conv.notes.append(f"removed {len(spec.keys)} keyframes (their qpos no longer fits)")
        for k in list(spec.keys):
            spec.delete(k)
    capped = [
        j.name
        for j in spec.joints
        if j.actfrclimited == mujoco.mjtLimited.mjLIMITED_TRUE
        or (
            j.actfrclimited == mujoco.mjtLimited.mjLIMITED_AUTO
            and j.actfrcrange[0] < j.actfrcrange[1]
        )
    ]
    for j in spec.joints:
        j.actfrclimited = mujoco.mjtLimited.mjLIMITED_AUTO
        j.actfrcrange = (0.0, 0.0)
    if capped:
        conv.notes.append(
            f"dropped the effort limits of {len(capped)} joints (the servo model sets the torque)"
        )


def _ensure_floor(conv: Converted) -> None:
    spec = conv.spec
    if any(g.type == mujoco.mjtGeom.mjGEOM_PLANE for g in spec.worldbody.geoms):
        return
    floor = spec.worldbody.add_geom()
    floor.name = FLOOR_NAME
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = (0.0, 0.0, 0.05)
    floor.contype, floor.conaffinity, floor.condim = 1, 1, 3
    floor.friction = (0.9, 0.005, 0.0001)
    floor.rgba = (0.3, 0.33, 0.37, 1.0)
    light = spec.worldbody.add_light()
    light.pos = (0.0, 0.0, 3.0)
    light.dir = (0.0, 0.0, -1.0)
    conv.notes.append("added a floor (plane, µ = 0.9) and a light")


def _collect_assets(conv: Converted) -> None:
    spec = conv.spec
    base = conv.source.parent
    for kind, items, sub in (
        ("mesh", spec.meshes, spec.compiler.meshdir),
        ("texture", spec.textures, spec.compiler.texturedir),
    ):
        for item in items:
            if not item.file:
                continue
            p = Path(item.file)
            full = p if p.is_absolute() else base / (sub or "") / p
            if not full.is_file():
                raise ScaffoldError(
                    str(conv.source), f"{kind} {item.name or item.file}", "file not found"
                )
            item.file = str(full.resolve())
    spec.compiler.meshdir = ""
    spec.compiler.texturedir = ""


def write_assets(conv: Converted, out_dir: Path) -> dict[str, str]:
    """Copy meshes/textures into out_dir/assets; {absolute source path: path relative to out_dir}.

    The spec keeps its absolute paths (it must still compile); the caller rewrites the written
    XML's ``file=`` attributes with the returned map.
    """
    relative: dict[str, str] = {}
    for item in [*conv.spec.meshes, *conv.spec.textures]:
        if not item.file or item.file in relative:
            continue
        src = Path(item.file)
        name, k = src.name, 1
        while f"assets/{name}" in relative.values():
            name, k = f"{src.stem}_{k}{src.suffix}", k + 1
        (out_dir / "assets").mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, out_dir / "assets" / name)
        relative[item.file] = f"assets/{name}"
    if relative:
        conv.notes.append(f"copied {len(relative)} mesh/texture files to assets/")
    return relative

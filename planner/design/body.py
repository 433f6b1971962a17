"""The design space of `gaitsmith design`: leg-segment length scales and a servo model per joint
group (Wampler & Popović 2009 §3.6 "Morphological terms", re-read for servos).

W&P give every limb a length and a radius and rescale "the mass of the bone proportionally so
that it maintains a constant density". Here a *link group* (`LinkGroup`) is a set of leg-chain
bodies that share one length scale s; mirrored legs share a group (the morphology keeps the
left/right symmetry, W&P §6). A body's *segment* runs from its origin (its joint) to the next
joint of the leg, or to the foot site for the last body; scaling it by s stretches everything
the body carries along that segment's unit direction u by the map S = I + (s − 1)·u·uᵀ (child
body, geoms, sites, its joint's anchor), so the next segment starts s times farther away.

Mass split (documented, because an MJCF gives one mass per body): the servo that turns joint j
sits in the joint's *parent* body at the joint's anchor (the usual build: a servo's case is
bolted to the link above, its horn turns the link below) and is a point mass of its catalogue
`mass_kg`; if that would leave the parent less than `MIN_STRUCTURE_FRACTION` of its mass as
structure, the servo counts in the joint's own body instead (at the same anchor). Whatever is
left of a body's compiled mass is its *structure*: mass, centre of mass and inertia are the
body's minus the servos' (parallel-axis theorem; where the remainder would not be a physical
inertia the servos sit at the body's centre of mass instead, `structure_inertia`). This assumes
what gaitsmith's own robots and `robots init` say: the masses in robot.xml include the servos.

Rescaling at constant density (W&P §3.6, length only — the cross section is kept): a body
stretched by S along u keeps its density, so its structure mass becomes s·m, its centre of mass
S·c and its second moment of mass about the centre Σ = ∫ρ·r·rᵀ becomes s·S·Σ·Sᵀ (the volume
grows by det S = s); the inertia is I = tr(Σ)·1 − Σ. The servos keep their catalogue mass
whatever the scale, and a servo swap replaces the old servo's point mass by the new one's. The
inertials are written explicitly into the MJCF (the planner and MuJoCo read them, not geoms).
Front and hind legs scaled differently would leave the original stance angles standing the body
on its shorter legs, tilted: the designed robot.toml gets a level stance (`level_stance_rad`).

Servo groups (`ServoGroup`): the leg joints at the same depth of every leg that use the same
servo model today (hip roll, hip pitch, knee of a quadruped). Their candidate models are sorted
by stall torque; the search encodes the choice as one continuous variable per group, rounded to
the nearest candidate index (W&P handle discrete choices the same way: CMA-ES samples a real
number, the projection snaps it), so neighbouring values are neighbouring strengths. The
default candidates are the group's own model and its nearest weaker and nearest stronger
neighbours of the same vendor and protocol in the catalogue (the same bus, the same tooling).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from planner.errors import PlannerError
from planner.hybrid_body import (
    compiled_spec,
    make_inertials_explicit,
    write_robot_folder,
)
from planner.templates import mirror_permutation
from robots import Robot
from robots.rotation import inertia_tensor, quat_to_mat
from robots.servo import ServoModel, servo_catalogue
from robots.toml_schema import read_toml

#: Bounds of a link group's length scale (the issue's 0.6–1.6).
SCALE_BOUNDS = (0.6, 1.6)
#: A body keeps at least this fraction of its mass as structure when it carries servos.
MIN_STRUCTURE_FRACTION = 0.1
#: Segments shorter than this are not link groups (coincident joints, e.g. a 2-DOF hip).
MIN_SEGMENT_M = 1e-4
#: A geom axis within this |cos| of a segment direction stretches with it.
_ALIGNED_COS = 0.99


class DesignError(PlannerError, ValueError):
    """The body cannot be designed as asked (bad --vary/--servos, a body the split cannot
    handle, a robot.toml this module cannot rewrite)."""


@dataclass(frozen=True)
class Segment:
    """One leg-chain body: its leg, depth from the root (0 = attached to the root) and the
    segment from its origin to the next joint (or the foot), in the body's frame."""

    body: str
    leg: str
    depth: int
    axis: tuple[float, float, float]  # unit direction of the segment
    length_m: float


@dataclass(frozen=True)
class LinkGroup:
    """Bodies that share one length scale."""

    name: str
    bodies: tuple[str, ...]
    length_m: float  # mean original segment length of the bodies


@dataclass(frozen=True)
class ServoGroup:
    """Joints that take one servo model; `candidates` sorted by stall torque."""

    name: str
    joints: tuple[str, ...]
    own: str
    candidates: tuple[str, ...]


@dataclass(frozen=True)
class BodyDesign:
    """One point of the design space: a scale per link group, a model per servo group."""

    scales: tuple[float, ...]
    servos: tuple[str, ...]


@dataclass(frozen=True)
class DesignSpace:
    """The variables of a design search for one robot and their encoding for CMA-ES:
    ``x = [s_1 … s_G, u_1 … u_K]``, s a length scale in `scale_bounds`, u a candidate index in
    [−0.5, n − 0.5] rounded to the nearest integer (module docstring)."""

    link_groups: tuple[LinkGroup, ...]
    servo_groups: tuple[ServoGroup, ...]
    segments: tuple[Segment, ...]
    servo_models: tuple[ServoModel, ...]  # every model a group may take (and the robot's own)
    scale_bounds: tuple[float, float] = SCALE_BOUNDS

    @property
    def dim(self) -> int:
        return len(self.link_groups) + len(self.servo_groups)

    def model(self, name: str) -> ServoModel:
        for m in self.servo_models:
            if m.name == name:
                return m
        raise KeyError(name)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        g = len(self.link_groups)
        lo = np.r_[np.full(g, self.scale_bounds[0]), [-0.5] * len(self.servo_groups)]
        hi = np.r_[np.full(g, self.scale_bounds[1]),
                   [len(sg.candidates) - 0.5 for sg in self.servo_groups]]
        return lo.astype(float), hi.astype(float)

    def encode(self, design: BodyDesign) -> np.ndarray:
        idx = [float(sg.candidates.index(name))
               for sg, name in zip(self.servo_groups, design.servos, strict=True)]
        return np.r_[np.asarray(design.scales, dtype=float), idx]

    def original(self) -> BodyDesign:
        """Every scale 1, every group its own servo (if among its candidates, else the
        candidate closest in stall torque)."""
        servos = []
        for sg in self.servo_groups:
            if sg.own in sg.candidates:
                servos.append(sg.own)
                continue
            own = self.model(sg.own).stall_torque_nm
            servos.append(min(sg.candidates,
                              key=lambda n: abs(self.model(n).stall_torque_nm - own)))
        return BodyDesign((1.0,) * len(self.link_groups), tuple(servos))

    def decode(self, x: np.ndarray) -> BodyDesign:
        x = np.clip(np.asarray(x, dtype=float), *self.bounds())
        g = len(self.link_groups)
        servos = tuple(sg.candidates[int(np.clip(round(float(u)), 0, len(sg.candidates) - 1))]
                       for sg, u in zip(self.servo_groups, x[g:], strict=True))
        return BodyDesign(tuple(float(s) for s in x[:g]), servos)

    def snap(self, x: np.ndarray) -> np.ndarray:
        """The projection of the discrete part: each servo variable on its candidate index."""
        return self.encode(self.decode(x))

    def supply_range_v(self, design: BodyDesign) -> tuple[float, float]:
        """Supply voltages every servo of `design` accepts (lo > hi: no common supply)."""
        models = [self.model(n) for n in design.servos]
        return max(m.voltage_min_v for m in models), min(m.voltage_max_v for m in models)

    def scale_of(self, design: BodyDesign) -> dict[str, float]:
        """Body name → its length scale (bodies in no group: absent)."""
        return {body: s for grp, s in zip(self.link_groups, design.scales, strict=True)
                for body in grp.bodies}

    def servo_of(self, design: BodyDesign) -> dict[str, str]:
        """Joint name → its servo model (joints in no group: absent, they keep theirs)."""
        return {j: name for sg, name in zip(self.servo_groups, design.servos, strict=True)
                for j in sg.joints}


# ---------------------------------------------------------------------------------------------
# the kinematic tree


def _compiled(robot: Robot) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    spec = compiled_spec(robot, DesignError)
    return spec, spec.compile()


def _body_name(model: mujoco.MjModel, body: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body#{body}"


def leg_segments(robot: Robot) -> tuple[Segment, ...]:
    """Every body on a leg chain (root excluded), root to foot, with its segment."""
    _, model = _compiled(robot)
    root = int(model.jnt_bodyid[0])
    out: list[Segment] = []
    for leg in robot.legs:
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
        chain: list[int] = []
        body = int(model.site_bodyid[site])
        while body not in (root, 0):
            chain.append(body)
            body = int(model.body_parentid[body])
        chain.reverse()
        for depth, b in enumerate(chain):
            vec = (model.body_pos[chain[depth + 1]] if depth + 1 < len(chain)
                   else model.site_pos[site])
            length = float(np.linalg.norm(vec))
            axis = tuple(float(v) for v in (vec / length if length > 0 else np.zeros(3)))
            out.append(Segment(_body_name(model, b), leg.name, depth, axis,  # type: ignore[arg-type]
                               length))
    return tuple(out)


def _mirror_of_leg(robot: Robot) -> dict[str, str]:
    perm = mirror_permutation(robot)
    names = robot.foot_names
    if perm is None:
        return {n: n for n in names}
    return {names[i]: names[min(i, perm[i])] for i in range(len(names))}


def default_link_groups(robot: Robot, segments: Sequence[Segment]) -> tuple[LinkGroup, ...]:
    """One group per leg segment, a leg and its mirror image (y → −y) sharing it."""
    rep = _mirror_of_leg(robot)
    keys: dict[tuple[str, int], list[Segment]] = {}
    for seg in segments:
        if seg.length_m >= MIN_SEGMENT_M:
            keys.setdefault((rep[seg.leg], seg.depth), []).append(seg)
    return tuple(
        LinkGroup("+".join(s.body for s in segs), tuple(s.body for s in segs),
                  float(np.mean([s.length_m for s in segs])))
        for segs in keys.values()
    )


def link_groups_named(robot: Robot, segments: Sequence[Segment], tokens: Sequence[str],
                      option: str = "--vary") -> tuple[LinkGroup, ...]:
    """One group per token: the leg bodies whose name is the token or contains it (``thigh``
    → every thigh). A token that matches no leg body, or a body matched twice, is an error."""
    usable = [s for s in segments if s.length_m >= MIN_SEGMENT_M]
    taken: dict[str, str] = {}
    groups: list[LinkGroup] = []
    for raw in tokens:
        token = raw.strip()
        if not token:
            raise DesignError(f"{option}: empty link name in the list")
        exact = [s for s in usable if s.body == token]
        segs = exact or [s for s in usable if token in s.body]
        if not segs:
            names = ", ".join(s.body for s in usable)
            raise DesignError(f"{option}: {token!r} matches no leg segment of {robot.name}; "
                              f"its leg bodies are {names}")
        for s in segs:
            if s.body in taken:
                raise DesignError(f"{option}: body {s.body} is matched by both {taken[s.body]!r} "
                                  f"and {token!r}; give each body one group")
            taken[s.body] = token
        groups.append(LinkGroup(token, tuple(s.body for s in segs),
                                float(np.mean([s.length_m for s in segs]))))
    return tuple(groups)


def _suffix_name(names: Sequence[str], depth: int) -> str:
    first = names[0]
    k = 0
    while k < len(first) and all(len(n) > k and n[-1 - k] == first[-1 - k] for n in names):
        k += 1
    suffix = first[len(first) - k:].lstrip("_-. ") if len(names) > 1 else first
    return suffix or f"joint{depth}"


def catalogue_neighbours(own: ServoModel, catalogue: Mapping[str, ServoModel]) -> tuple[str, ...]:
    """`own` and the nearest weaker and nearest stronger model of the same vendor and protocol,
    by stall torque (the default candidates)."""
    same = [m for m in catalogue.values()
            if m.vendor == own.vendor and m.protocol == own.protocol and m.name != own.name]
    weaker = [m for m in same if m.stall_torque_nm < own.stall_torque_nm]
    stronger = [m for m in same if m.stall_torque_nm > own.stall_torque_nm]
    picked = [own]
    if weaker:
        picked.append(max(weaker, key=lambda m: (m.stall_torque_nm, -m.mass_kg)))
    if stronger:
        picked.append(min(stronger, key=lambda m: (m.stall_torque_nm, m.mass_kg)))
    return tuple(m.name for m in sorted(picked, key=lambda m: m.stall_torque_nm))


def design_space(robot: Robot, vary: Sequence[str] | None = None,
                 servos: Sequence[str] | None = None,
                 scale_bounds: tuple[float, float] = SCALE_BOUNDS) -> DesignSpace:
    """The design space of `robot`: `vary` link names (None: the leg segments, mirrored legs
    sharing a scale), `servos` the candidate models of every joint group (None: each group's
    own model and its catalogue neighbours)."""
    lo, hi = scale_bounds
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= 1.0 <= hi):
        raise DesignError(f"scale bounds must satisfy 0 < lo ≤ 1 ≤ hi, got [{lo:g}, {hi:g}]")
    segments = leg_segments(robot)
    groups = (default_link_groups(robot, segments) if vary is None
              else link_groups_named(robot, segments, vary))
    catalogue = dict(servo_catalogue(robot.servo_catalogue_path))
    for j in robot.joints:
        catalogue.setdefault(j.servo.name, j.servo)
    if servos is not None:
        unknown = [n for n in servos if n not in catalogue]
        if unknown:
            raise DesignError(f"--servos: unknown servo model {unknown[0]!r}; known: "
                              f"{', '.join(sorted(catalogue))}")
        if not servos:
            raise DesignError("--servos: give at least one servo model")
        protocols = {catalogue[n].protocol for n in servos}
        if len(protocols) > 1:
            raise DesignError(f"--servos: the models speak {', '.join(sorted(protocols))}; "
                              "one bus needs one protocol, list models of one protocol")
    by_key: dict[tuple[int, str], list[str]] = {}
    for leg in robot.legs:
        for depth, jname in enumerate(leg.joints):
            joint = robot.joint(jname)
            if not joint.held:
                by_key.setdefault((depth, joint.servo.name), []).append(jname)
    servo_groups = []
    used: set[str] = set()
    for (depth, own), joints in by_key.items():
        if servos is None:
            cands = catalogue_neighbours(catalogue[own], catalogue)
        else:
            cands = tuple(sorted(dict.fromkeys(servos),
                                 key=lambda n: (catalogue[n].stall_torque_nm, n)))
        used.update(cands)
        used.add(own)
        servo_groups.append(ServoGroup(_suffix_name(joints, depth), tuple(joints), own, cands))
    names = [g.name for g in servo_groups]
    servo_groups = [ServoGroup(g.name if names.count(g.name) == 1 else f"{g.name}:{g.own}",
                               g.joints, g.own, g.candidates) for g in servo_groups]
    if not groups and not servo_groups:
        raise DesignError(f"{robot.name} has no leg segment and no servo to design")
    return DesignSpace(groups, tuple(servo_groups), segments,
                       tuple(catalogue[n] for n in sorted(used)), (float(lo), float(hi)))


# ---------------------------------------------------------------------------------------------
# mass split and rescaling


@dataclass(frozen=True)
class ServoMass:
    """The point mass of joint `joint`'s servo in body `body`, at `anchor` (body frame)."""

    joint: str
    body: str
    anchor: tuple[float, float, float]
    mass_kg: float


@dataclass(frozen=True)
class Structure:
    """A body's mass without its servos: mass, centre of mass and inertia about it (body frame)."""

    mass_kg: float
    com_m: np.ndarray
    inertia_kg_m2: np.ndarray  # 3 × 3 about com_m


def _point_inertia(mass: float, r: np.ndarray) -> np.ndarray:
    """Inertia of a point mass at r about the origin (parallel-axis term)."""
    return mass * (float(r @ r) * np.eye(3) - np.outer(r, r))


def _valid_inertia(inertia: np.ndarray) -> bool:
    ev = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    a, b, c = sorted(ev)
    return bool(a > 0 and a + b >= c * (1 - 1e-9))


def _body_inertia(model: mujoco.MjModel, b: int) -> np.ndarray:
    return inertia_tensor(model.body_iquat[b], model.body_inertia[b])


def servo_masses(robot: Robot, model: mujoco.MjModel) -> tuple[ServoMass, ...]:
    """Where each joint's servo mass sits (module docstring: the parent body, else the joint's
    own body); raises DesignError when neither body is heavy enough to hold it."""
    placed: list[ServoMass] = []
    load: dict[int, float] = {}
    for joint in robot.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
        child = int(model.jnt_bodyid[jid])
        parent = int(model.body_parentid[child])
        in_parent = model.body_pos[child] + quat_to_mat(model.body_quat[child]) @ model.jnt_pos[jid]
        mass = joint.servo.mass_kg
        for body, anchor in ((parent, in_parent), (child, model.jnt_pos[jid])):
            if body == 0:
                continue
            room = (1 - MIN_STRUCTURE_FRACTION) * float(model.body_mass[body]) - load.get(body, 0)
            if mass <= room:
                load[body] = load.get(body, 0.0) + mass
                placed.append(ServoMass(joint.name, _body_name(model, body),
                                        tuple(float(v) for v in anchor),  # type: ignore[arg-type]
                                        mass))
                break
        else:
            raise DesignError(
                f"{robot.mjcf_path}: neither body {_body_name(model, parent)} "
                f"({model.body_mass[parent]:.3f} kg) nor {_body_name(model, child)} "
                f"({model.body_mass[child]:.3f} kg) is heavy enough to hold the "
                f"{joint.servo.name} ({mass * 1000:.0f} g) of joint {joint.name}; the design "
                "command needs masses that include the servos"
            )
    return tuple(placed)


def structure_inertia(model: mujoco.MjModel, b: int, servos: Sequence[ServoMass]
                      ) -> tuple[Structure, tuple[ServoMass, ...]]:
    """Body `b`'s mass minus its servos' point masses (module docstring), and the servos as
    placed. If point masses at the joint anchors would leave a structure whose inertia is not
    physical (the file's mass is not where the anchors are: e.g. a thigh lighter than its knee
    servo swung at full length), the servos are placed at the body's centre of mass instead and
    the structure keeps the body's whole inertia — the unchanged design then reproduces the
    file's inertials exactly either way."""
    mass = float(model.body_mass[b])
    com = np.asarray(model.body_ipos[b], dtype=float)
    inertia_com = _body_inertia(model, b)
    ms = sum(s.mass_kg for s in servos)
    m_st = mass - ms
    if not servos:
        return Structure(mass, com.copy(), inertia_com), ()
    c_st = (mass * com - sum(s.mass_kg * np.asarray(s.anchor) for s in servos)) / m_st
    about_origin = inertia_com + _point_inertia(mass, com)
    about_origin = about_origin - sum(_point_inertia(s.mass_kg, np.asarray(s.anchor))
                                      for s in servos)
    i_st = about_origin - _point_inertia(m_st, c_st)
    if _valid_inertia(i_st):
        return Structure(m_st, c_st, i_st), tuple(servos)
    at_com = tuple(ServoMass(s.joint, s.body, tuple(float(v) for v in com),  # type: ignore[arg-type]
                             s.mass_kg) for s in servos)
    return Structure(m_st, com.copy(), inertia_com), at_com


def stretch(axis: Sequence[float] | np.ndarray, scale: float) -> np.ndarray:
    """S = I + (s − 1)·u·uᵀ: lengths along u times s, across u unchanged."""
    u = np.asarray(axis, dtype=float)
    return np.eye(3) + (scale - 1.0) * np.outer(u, u)


def stretched_structure(st: Structure, axis: Sequence[float] | np.ndarray,
                        scale: float) -> Structure:
    """The structure stretched by `scale` along `axis` at constant density (module docstring:
    m' = s·m, c' = S·c, Σ' = s·S·Σ·Sᵀ, I = tr(Σ)·1 − Σ)."""
    s_mat = stretch(axis, scale)
    sigma = 0.5 * np.trace(st.inertia_kg_m2) * np.eye(3) - st.inertia_kg_m2
    sigma2 = scale * s_mat @ sigma @ s_mat.T
    return Structure(scale * st.mass_kg, s_mat @ st.com_m,
                     np.trace(sigma2) * np.eye(3) - sigma2)


def _set_inertial(body: mujoco.MjsBody, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
    vals, vecs = np.linalg.eigh(0.5 * (inertia + inertia.T))
    if np.linalg.det(vecs) < 0:
        vecs[:, 0] = -vecs[:, 0]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(vecs).ravel())
    body.explicitinertial = True
    body.mass = float(mass)
    body.ipos = np.asarray(com, dtype=float)
    body.iquat = quat
    body.inertia = np.maximum(vals, 1e-12)
    body.fullinertia = np.full(6, np.nan)


def _stretch_geom(geom: mujoco.MjsGeom, s_mat: np.ndarray, axis: np.ndarray,
                  scale: float) -> None:
    geom.pos = s_mat @ np.asarray(geom.pos, dtype=float)
    local = quat_to_mat(geom.quat)
    size = np.asarray(geom.size, dtype=float).copy()
    if geom.type in (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER):
        if abs(float(local[:, 2] @ axis)) > _ALIGNED_COS:
            size[1] *= scale
    elif geom.type in (mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_ELLIPSOID):
        for i in range(3):
            if abs(float(local[:, i] @ axis)) > _ALIGNED_COS:
                size[i] *= scale
    geom.size = size  # spheres, meshes and other geoms move with the body and keep their size


def design_spec(robot: Robot, space: DesignSpace, design: BodyDesign) -> mujoco.MjSpec:
    """`robot`'s MJCF with `design` applied: segments stretched, inertials rescaled at constant
    density with the servos' catalogue masses (module docstring)."""
    spec, model = _compiled(robot)
    make_inertials_explicit(spec)
    scales = space.scale_of(design)
    swap = space.servo_of(design)
    axis_of = {seg.body: np.asarray(seg.axis) for seg in space.segments}
    placed = servo_masses(robot, model)
    for b in range(1, model.nbody):
        name = _body_name(model, b)
        st, mine = structure_inertia(model, b, [s for s in placed if s.body == name])
        scale = scales.get(name, 1.0)
        s_mat = np.eye(3)
        body = spec.body(name)
        if scale != 1.0:
            axis = axis_of[name]
            s_mat = stretch(axis, scale)
            st = stretched_structure(st, axis, scale)
            for child in body.bodies:
                child.pos = s_mat @ np.asarray(child.pos, dtype=float)
            for geom in body.geoms:
                _stretch_geom(geom, s_mat, axis, scale)
            for site in body.sites:
                site.pos = s_mat @ np.asarray(site.pos, dtype=float)
            for joint in body.joints:
                joint.pos = s_mat @ np.asarray(joint.pos, dtype=float)
        masses = [(space.model(swap[s.joint]).mass_kg if s.joint in swap else s.mass_kg,
                   s_mat @ np.asarray(s.anchor)) for s in mine]
        total = st.mass_kg + sum(m for m, _ in masses)
        com = (st.mass_kg * st.com_m + sum(m * p for m, p in masses)) / total
        about_origin = st.inertia_kg_m2 + _point_inertia(st.mass_kg, st.com_m)
        about_origin = about_origin + sum(_point_inertia(m, p) for m, p in masses)
        _set_inertial(body, total, com, about_origin - _point_inertia(total, com))
    return spec


#: Stance residual weights: feet on one level (W_LEVEL), feet where the original stance angles put
#: them on the new body (W_FOOTPRINT), angles near the original stance (W_ANGLE, per joint range).
W_LEVEL, W_FOOTPRINT, W_ANGLE = 30.0, 1.0, 0.3
#: The stance keeps this fraction of each joint's range inside its limits.
STANCE_LIMIT_MARGIN = 0.05


def level_stance_rad(robot: Robot, model: mujoco.MjModel) -> dict[str, float]:
    """Leg joint angles that stand the designed body (`model`, the design's compiled MJCF) level
    with every foot on the ground: the original stance angles would not once front and hind legs
    are scaled differently (the body tips onto its shorter legs). Least squares (scipy, bounded)
    from the original stance: all foot sites at one height below the level base, each foot where
    the original angles put it horizontally on the new body, angles close to the original ones.
    An unchanged body returns the original stance (all residuals are zero there)."""
    from scipy.optimize import least_squares

    leg_joints = [j for leg in robot.legs for j in leg.joints if not robot.joint(j).held]
    jids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in leg_joints]
    adr = np.array([model.jnt_qposadr[j] for j in jids])
    sites = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
             for leg in robot.legs]
    lo, hi = model.jnt_range[jids, 0].copy(), model.jnt_range[jids, 1].copy()
    for k, j in enumerate(leg_joints):
        joint = robot.joint(j)
        lo[k], hi[k] = max(lo[k], joint.lower_rad), min(hi[k], joint.upper_rad)
    span = np.maximum(hi - lo, 1e-6)
    lo_b, hi_b = lo + STANCE_LIMIT_MARGIN * span, hi - STANCE_LIMIT_MARGIN * span
    q0 = np.array([robot.joint(j).stance_rad for j in leg_joints])
    data = mujoco.MjData(model)

    def feet(q: np.ndarray) -> np.ndarray:
        data.qpos[:] = model.qpos0
        data.qpos[0:3] = 0.0
        data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        for joint in robot.joints:
            if joint.held:
                data.qpos[model.jnt_qposadr[mujoco.mj_name2id(
                    model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)]] = joint.stance_rad
        data.qpos[adr] = q
        mujoco.mj_kinematics(model, data)
        return np.array([data.site_xpos[s] for s in sites])

    start = feet(q0)
    length = max(float(np.mean(-start[:, 2])), 1e-3)
    target_xy = start[:, :2].copy()

    def residuals(x: np.ndarray) -> np.ndarray:
        pos = feet(x[:-1])
        return np.concatenate([W_LEVEL * (pos[:, 2] + x[-1]) / length,
                               W_FOOTPRINT * (pos[:, :2] - target_xy).ravel() / length,
                               W_ANGLE * (x[:-1] - q0) / span])

    x0 = np.r_[np.clip(q0, lo_b, hi_b), float(np.mean(-start[:, 2]))]
    if np.allclose(start[:, 2], start[0, 2], atol=1e-9) and np.allclose(x0[:-1], q0):
        return dict(zip(leg_joints, q0.tolist(), strict=True))
    sol = least_squares(residuals, x0, bounds=(np.r_[lo_b, 0.0], np.r_[hi_b, 10 * length]),
                        x_scale="jac")
    return dict(zip(leg_joints, sol.x[:-1].tolist(), strict=True))


# ---------------------------------------------------------------------------------------------
# robot.toml


_HEADER = re.compile(r"^\s*\[\s*(?P<table>[^\]]+?)\s*\]\s*(#.*)?$")


def _table_name(raw: str) -> str:
    return ".".join(part.strip().strip('"').strip("'") for part in raw.split("."))


def _remap_ticks(ticks: int, old: ServoModel, new: ServoModel) -> int:
    """The zero offset at the same fraction of the new servo's goal range as the old one's
    (a swapped servo needs calibrating anyway: `robots init/check` say so)."""
    span = old.position_max_tick - old.position_min_tick
    frac = (ticks - old.position_min_tick) / span if span > 0 else 0.5
    lo, hi = new.position_min_tick, new.position_max_tick
    return round(lo + frac * (hi - lo))


def design_toml(robot: Robot, space: DesignSpace, design: BodyDesign, name: str,
                note: str = "", stance_rad: Mapping[str, float] | None = None) -> str:
    """`robot`'s robot.toml with `name`, the servos of `design` (zero offsets remapped), the
    stance angles `stance_rad` (joint → angle; others kept) and a header comment `note`; the
    rest of the file (comments included) is kept line for line."""
    stance_rad = dict(stance_rad or {})
    text = robot.toml_path.read_text(encoding="utf-8")
    file = str(robot.toml_path)
    data = read_toml(text, file)
    swap = space.servo_of(design)
    out: list[str] = []
    table = ""
    done: set[str] = set()
    for line in text.splitlines():
        head = _HEADER.match(line)
        if head and not line.lstrip().startswith("[["):
            table = _table_name(head.group("table"))
            out.append(line)
            continue
        if table == "robot" and re.match(r"^\s*name\s*=", line):
            line = re.sub(r'^(\s*name\s*=\s*)(".*?"|\'.*?\')', lambda m: f'{m.group(1)}"{name}"',
                          line)
            done.add("[robot].name")
        joint = table[len("joints."):] if table.startswith("joints.") else ""
        stance_line = re.match(r"^(\s*stance_deg\s*=\s*)[-+0-9_.eE]+", line)
        if joint in stance_rad and stance_line:
            line = (f"{stance_line.group(1)}{math.degrees(stance_rad[joint]):.3f}"
                    + line[stance_line.end():])
            done.add(f"{joint}.stance_deg")
        if joint in swap:
            new = space.model(swap[joint])
            old = robot.joint(joint).servo
            servo_line = re.match(r'^(\s*servo\s*=\s*)(".*?"|\'.*?\')', line)
            ticks_line = re.match(r"^(\s*zero_offset_ticks\s*=\s*)[-+0-9_]+", line)
            if servo_line:
                line = f'{servo_line.group(1)}"{new.name}"' + line[servo_line.end():]
                done.add(f"{joint}.servo")
            elif ticks_line:
                ticks = _remap_ticks(int(data["joints"][joint]["zero_offset_ticks"]), old, new)
                line = f"{ticks_line.group(1)}{ticks}" + line[ticks_line.end():]
                done.add(f"{joint}.zero_offset_ticks")
        out.append(line)
    missing = [f"{j}.{key}" for j in swap for key in ("servo", "zero_offset_ticks")
               if f"{j}.{key}" not in done]
    missing += [f"{j}.stance_deg" for j in stance_rad if f"{j}.stance_deg" not in done]
    if "[robot].name" not in done:
        missing.append("[robot].name")
    if missing:
        raise DesignError(f"{file}: cannot rewrite {missing[0]} (write every joint as a "
                          "[joints.NAME] table with one key per line)")
    header = "".join(f"# {line}\n" for line in note.splitlines())
    return header + "\n".join(out) + "\n"


def write_design(robot: Robot, space: DesignSpace, design: BodyDesign, folder: Path, name: str,
                 note: str = "") -> Robot:
    """Write the designed robot folder (robot.xml + robot.toml, level stance) and load it."""
    spec = design_spec(robot, space, design)
    try:
        model = spec.compile()
    except ValueError as exc:  # mujoco's compiler message
        raise DesignError(f"design {describe(space, design)} of {robot.name}: {exc}") from None
    stance = level_stance_rad(robot, model)
    return write_robot_folder(spec, design_toml(robot, space, design, name, note, stance), folder,
                              f"design {describe(space, design)} of {robot.name}", DesignError)


def describe(space: DesignSpace, design: BodyDesign) -> str:
    """One line: each link group's scale and each servo group's model."""
    parts = [f"{g.name}×{s:.3f}" for g, s in zip(space.link_groups, design.scales, strict=True)]
    parts += [f"{g.name}={n}" for g, n in zip(space.servo_groups, design.servos, strict=True)]
    return ", ".join(parts)

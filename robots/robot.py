"""The Robot: one legged build, loaded from its MJCF (`robot.xml`) and servo map (`robot.toml`).

Everything the planner, simulator and player know about a robot comes from these two files; see
`load`. MuJoCo is imported lazily (only to parse the MJCF), so `hardware` stays light.
"""

from __future__ import annotations

import hashlib
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robots.errors import RobotConfigError
from robots.servo import ServoModel, load_catalogue

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

BUILTIN_DIR = Path(__file__).parent


@dataclass(frozen=True)
class Joint:
    """One servo-driven hinge joint. Angles in radians, MJCF convention."""

    name: str
    axis: tuple[float, float, float]
    lower_rad: float
    upper_rad: float
    servo: ServoModel
    bus_id: int
    direction: int
    zero_offset_ticks: int
    stance_rad: float

    def angle_to_ticks(self, angle_rad: float) -> float:
        """Servo goal position for a joint angle (no limit check; see hardware.calibration)."""
        return self.zero_offset_ticks + self.direction * angle_rad * self.servo.ticks_per_rad


@dataclass(frozen=True)
class Leg:
    """A leg: its foot site (contact point, at the centre of the foot sphere) and joint chain."""

    name: str
    foot_site: str
    joints: tuple[str, ...]


@dataclass(frozen=True)
class Robot:
    """A legged robot build. `fingerprint` hashes robot.xml + robot.toml."""

    name: str
    description: str
    root_dir: Path
    mjcf_path: Path
    toml_path: Path
    fingerprint: str
    joints: tuple[Joint, ...]
    legs: tuple[Leg, ...]
    mass_kg: float
    foot_radius_m: float
    bus_baud: int
    stance_base_height_m: float
    leg_length_m: float

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def foot_names(self) -> tuple[str, ...]:
        return tuple(leg.name for leg in self.legs)

    @property
    def nominal_stance_rad(self) -> tuple[float, ...]:
        return tuple(j.stance_rad for j in self.joints)

    @property
    def servo_protocol(self) -> str:
        return self.joints[0].servo.protocol

    @property
    def dof(self) -> int:
        return len(self.joints)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)


# ---------------------------------------------------------------------------------------------
# robot.toml parsing


_ROBOT_KEYS = {"name", "description", "foot_radius_m", "bus_baud"}
_JOINT_KEYS = {"servo", "bus_id", "direction", "zero_offset_ticks", "stance_deg", "limits_deg"}
_LEG_KEYS = {"foot_site", "joints"}


@dataclass(frozen=True)
class _JointSpec:
    name: str
    servo: ServoModel
    bus_id: int
    direction: int
    zero_offset_ticks: int
    stance_rad: float
    limits_rad: tuple[float, float] | None


@dataclass(frozen=True)
class RobotSpec:
    """robot.toml as validated data, before it is checked against the MJCF."""

    name: str
    description: str
    foot_radius_m: float
    bus_baud: int
    joints: tuple[_JointSpec, ...]
    legs: tuple[Leg, ...]


def _table(file: str, data: dict[str, Any], key: str) -> dict[str, Any]:
    value = data.get(key)
    if not isinstance(value, dict) or not value:
        raise RobotConfigError(file, f"[{key}]", "missing or empty table")
    return value


def _check_keys(file: str, where: str, table: dict[str, Any], allowed: set[str]) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise RobotConfigError(
            file, f"{where}.{unknown[0]}", f"unknown field; allowed: {sorted(allowed)}"
        )


def _number(file: str, where: str, value: Any, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RobotConfigError(file, where, f"must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise RobotConfigError(file, where, f"must be positive, got {value!r}")
    return float(value)


def _integer(file: str, where: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise RobotConfigError(file, where, f"must be an integer in [{lo}, {hi}], got {value!r}")
    return value


def _parse_joint(file: str, name: str, table: Any) -> _JointSpec:
    where = f"[joints.{name}]"
    if not isinstance(table, dict):
        raise RobotConfigError(file, where, "must be a table")
    _check_keys(file, where, table, _JOINT_KEYS)
    for key in ("servo", "bus_id", "direction", "zero_offset_ticks", "stance_deg"):
        if key not in table:
            raise RobotConfigError(file, f"{where}.{key}", "missing")
    catalogue = load_catalogue()
    if not isinstance(table["servo"], str) or table["servo"] not in catalogue:
        raise RobotConfigError(
            file,
            f"{where}.servo",
            f"unknown servo model {table['servo']!r}; known: {sorted(catalogue)}",
        )
    servo = catalogue[table["servo"]]
    direction = table["direction"]
    if direction not in (1, -1) or isinstance(direction, bool):
        raise RobotConfigError(file, f"{where}.direction", f"must be 1 or -1, got {direction!r}")
    limits = table.get("limits_deg")
    limits_rad = None
    if limits is not None:
        if not isinstance(limits, list) or len(limits) != 2:
            raise RobotConfigError(file, f"{where}.limits_deg", "must be [lower, upper] in degrees")
        lo = _number(file, f"{where}.limits_deg[0]", limits[0])
        hi = _number(file, f"{where}.limits_deg[1]", limits[1])
        if not lo < hi:
            raise RobotConfigError(file, f"{where}.limits_deg", "lower must be below upper")
        limits_rad = (math.radians(lo), math.radians(hi))
    return _JointSpec(
        name=name,
        servo=servo,
        bus_id=_integer(file, f"{where}.bus_id", table["bus_id"], 0, 252),
        direction=int(direction),
        zero_offset_ticks=_integer(
            file,
            f"{where}.zero_offset_ticks",
            table["zero_offset_ticks"],
            servo.position_min_tick,
            servo.position_max_tick,
        ),
        stance_rad=math.radians(_number(file, f"{where}.stance_deg", table["stance_deg"])),
        limits_rad=limits_rad,
    )


def parse_robot_toml(text: str, file: str) -> RobotSpec:
    """Validate robot.toml's text; raises RobotConfigError naming the field at fault."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RobotConfigError(file, "<toml>", f"not valid TOML: {exc}") from None
    _check_keys(file, "<top>", data, {"robot", "joints", "legs"})
    head = _table(file, data, "robot")
    _check_keys(file, "[robot]", head, _ROBOT_KEYS)
    name = head.get("name")
    if not isinstance(name, str) or not name.strip():
        raise RobotConfigError(file, "[robot].name", "missing or empty")
    description = head.get("description", "")
    if not isinstance(description, str):
        raise RobotConfigError(file, "[robot].description", "must be a string")
    foot_radius = _number(file, "[robot].foot_radius_m", head.get("foot_radius_m"), positive=True)
    joints = tuple(_parse_joint(file, n, t) for n, t in _table(file, data, "joints").items())
    first = joints[0].servo
    lowest_baud = 0 if first.default_baud == 0 else 1  # 0: PWM servos, no serial bus
    baud = _integer(
        file, "[robot].bus_baud", head.get("bus_baud", first.default_baud), lowest_baud, 10**7
    )
    seen: dict[int, str] = {}
    for j in joints:
        if j.bus_id in seen:
            raise RobotConfigError(
                file,
                f"[joints.{j.name}].bus_id",
                f"duplicate bus id {j.bus_id} (also {seen[j.bus_id]})",
            )
        seen[j.bus_id] = j.name
        if j.servo.protocol != first.protocol:
            raise RobotConfigError(
                file,
                f"[joints.{j.name}].servo",
                f"protocol {j.servo.protocol} differs from {first.protocol}; one bus, one protocol",
            )
    legs: list[Leg] = []
    used: dict[str, str] = {}
    for leg_name, table in _table(file, data, "legs").items():
        where = f"[legs.{leg_name}]"
        if not isinstance(table, dict):
            raise RobotConfigError(file, where, "must be a table")
        _check_keys(file, where, table, _LEG_KEYS)
        site = table.get("foot_site")
        if not isinstance(site, str) or not site:
            raise RobotConfigError(file, f"{where}.foot_site", "missing or not a string")
        chain = table.get("joints")
        if not isinstance(chain, list) or not chain or not all(isinstance(c, str) for c in chain):
            raise RobotConfigError(
                file, f"{where}.joints", "must be a non-empty list of joint names"
            )
        for c in chain:
            if c not in {j.name for j in joints}:
                raise RobotConfigError(
                    file, f"{where}.joints", f"joint {c!r} has no [joints.{c}] table"
                )
            if c in used:
                raise RobotConfigError(
                    file, f"{where}.joints", f"joint {c!r} is already in leg {used[c]}"
                )
            used[c] = leg_name
        legs.append(Leg(leg_name, site, tuple(chain)))
    return RobotSpec(name.strip(), description, foot_radius, baud, joints, tuple(legs))


# ---------------------------------------------------------------------------------------------
# MJCF cross-check and derived quantities


def _resolve_dir(name_or_path: str | Path) -> Path:
    path = Path(name_or_path)
    if path.is_dir():
        return path
    if path.name in ("robot.toml", "robot.xml") and path.parent.is_dir():
        return path.parent
    builtin = BUILTIN_DIR / str(name_or_path)
    if isinstance(name_or_path, str) and "/" not in name_or_path and builtin.is_dir():
        return builtin
    raise RobotConfigError(
        str(name_or_path),
        "<robot>",
        f"no such robot folder; built-in robots: {', '.join(builtin_names())}, "
        "or give a folder holding robot.xml + robot.toml",
    )


def builtin_names() -> tuple[str, ...]:
    return tuple(sorted(p.parent.name for p in BUILTIN_DIR.glob("*/robot.toml")))


def load(name_or_path: str | Path) -> Robot:
    """Load a built-in robot by name ("quad12") or a user's folder with robot.xml + robot.toml."""
    root = _resolve_dir(name_or_path)
    toml_path, mjcf_path = root / "robot.toml", root / "robot.xml"
    for p in (toml_path, mjcf_path):
        if not p.is_file():
            raise RobotConfigError(
                str(p), "<file>", "missing; a robot folder needs robot.xml and robot.toml"
            )
    toml_bytes, mjcf_bytes = toml_path.read_bytes(), mjcf_path.read_bytes()
    try:
        toml_text = toml_bytes.decode("utf-8")
    except UnicodeDecodeError:
        raise RobotConfigError(str(toml_path), "<file>", "not UTF-8 text") from None
    spec = parse_robot_toml(toml_text, str(toml_path))
    fingerprint = hashlib.sha256(
        hashlib.sha256(mjcf_bytes).digest() + hashlib.sha256(toml_bytes).digest()
    ).hexdigest()[:16]
    return _build(spec, root, mjcf_path, toml_path, fingerprint)


def _build(
    spec: RobotSpec, root: Path, mjcf_path: Path, toml_path: Path, fingerprint: str
) -> Robot:
    import mujoco  # lazy: only robot loading needs MJCF parsing

    tfile, mfile = str(toml_path), str(mjcf_path)
    try:
        model = mujoco.MjModel.from_xml_path(mfile)
    except Exception as exc:  # mujoco raises ValueError with the parser's message
        raise RobotConfigError(mfile, "<mjcf>", f"MuJoCo cannot load it: {exc}") from None
    if model.njnt == 0 or model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise RobotConfigError(mfile, "<freejoint>", "the robot's root body needs a <freejoint/>")
    joints: list[Joint] = []
    for js in spec.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, js.name)
        where = f"[joints.{js.name}]"
        if jid < 0:
            raise RobotConfigError(tfile, where, f"joint {js.name!r} is not in {mfile}")
        if model.jnt_type[jid] != mujoco.mjtJoint.mjJNT_HINGE:
            raise RobotConfigError(mfile, f"joint {js.name}", "must be a hinge joint")
        if not model.jnt_limited[jid]:
            raise RobotConfigError(mfile, f"joint {js.name}", "needs a range (joint limits)")
        lo, hi = (float(x) for x in model.jnt_range[jid])
        if js.limits_rad is not None:
            if js.limits_rad[0] < lo - 1e-9 or js.limits_rad[1] > hi + 1e-9:
                raise RobotConfigError(
                    tfile, f"{where}.limits_deg", "must lie inside the MJCF range"
                )
            lo, hi = js.limits_rad
        for q in (lo, hi):
            tick = js.zero_offset_ticks + js.direction * q * js.servo.ticks_per_rad
            if not js.servo.position_min_tick <= tick <= js.servo.position_max_tick:
                raise RobotConfigError(
                    tfile,
                    where,
                    f"limit {math.degrees(q):.1f}° maps to tick {tick:.0f}, outside the "
                    f"{js.servo.name} range "
                    f"{js.servo.position_min_tick}..{js.servo.position_max_tick}; "
                    "narrow the joint range or change zero_offset_ticks",
                )
        if not lo <= js.stance_rad <= hi:
            raise RobotConfigError(tfile, f"{where}.stance_deg", "outside the joint limits")
        ax = model.jnt_axis[jid]
        axis = (float(ax[0]), float(ax[1]), float(ax[2]))
        joints.append(
            Joint(
                js.name,
                axis,
                lo,
                hi,
                js.servo,
                js.bus_id,
                js.direction,
                js.zero_offset_ticks,
                js.stance_rad,
            )
        )
    hinge_ids = [i for i in range(model.njnt) if model.jnt_type[i] == mujoco.mjtJoint.mjJNT_HINGE]
    mapped = {j.name for j in joints}
    for i in hinge_ids:
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, i)
        if name not in mapped:
            raise RobotConfigError(
                tfile, f"[joints.{name}]", f"MJCF joint {name!r} has no servo mapping"
            )

    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0:3] = 0.0
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    for j in joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        data.qpos[model.jnt_qposadr[jid]] = j.stance_rad
    mujoco.mj_kinematics(model, data)
    foot_z, leg_lengths = [], []
    for leg in spec.legs:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
        if sid < 0:
            raise RobotConfigError(
                tfile, f"[legs.{leg.name}].foot_site", f"site {leg.foot_site!r} not in {mfile}"
            )
        # the chain must be the joints from the root to the foot, in order
        body = int(model.site_bodyid[sid])
        ancestors: list[str] = []
        while body > 0:
            for k in range(model.body_jntnum[body]):
                jid = model.body_jntadr[body] + k
                if model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_HINGE:
                    ancestors.append(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, jid))
            body = int(model.body_parentid[body])
        ancestors.reverse()
        if tuple(ancestors) != leg.joints:
            raise RobotConfigError(
                tfile,
                f"[legs.{leg.name}].joints",
                f"must list the joints from the body to {leg.foot_site} in order: {ancestors}",
            )
        first = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, leg.joints[0])
        anchor = data.xanchor[first]
        foot = data.site_xpos[sid]
        foot_z.append(float(foot[2]))
        leg_lengths.append(float(anchor[2] - foot[2]))
    order = {name: i for i, name in enumerate(j.name for j in joints)}
    legs_joints = [n for leg in spec.legs for n in leg.joints]
    if sorted(legs_joints, key=order.__getitem__) != sorted(order, key=order.__getitem__):
        missing = sorted(set(order) - set(legs_joints))
        raise RobotConfigError(tfile, "[legs]", f"joints not in any leg: {missing}")
    return Robot(
        name=spec.name,
        description=spec.description,
        root_dir=root,
        mjcf_path=mjcf_path,
        toml_path=toml_path,
        fingerprint=fingerprint,
        joints=tuple(joints),
        legs=spec.legs,
        mass_kg=float(sum(model.body_mass)),
        foot_radius_m=spec.foot_radius_m,
        bus_baud=spec.bus_baud,
        stance_base_height_m=spec.foot_radius_m - min(foot_z),
        leg_length_m=sum(leg_lengths) / len(leg_lengths),
    )

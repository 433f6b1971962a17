"""The Robot: one legged build, loaded from its MJCF (`robot.xml`) and servo map (`robot.toml`).

Everything the planner, simulator and player know about a robot comes from these two files; see
`load`. MuJoCo is imported lazily (only to parse the MJCF), so `hardware` stays light.

robot.toml tables: ``[robot]`` (name, description, foot_radius_m, bus_baud), ``[servos.NAME]``
(servo models, the fields of robots/servos.toml), ``[joints.NAME]`` (one per MJCF hinge),
``[legs.NAME]`` (foot site + joint chain).

Servo models, by precedence of their name: robot.toml's ``[servos.NAME]`` > the user catalogue
file (``servo_catalogue=`` / ``--servos FILE``, else ``$GAITSMITH_SERVOS``) > the built-in
catalogue robots/servos.toml. One validation for all three (`robots.servo.parse_servo`).

Joint roles: ``role = "leg"`` (default) joints belong to exactly one leg; ``role = "hold"`` joints
(a head, arm, neck, tail or spine servo) are in no leg and are held at their stance angle: the
model keeps their bodies (mass and inertia exactly as modelled), the planner fixes them at
``stance_deg`` at every knot and checks their holding torque against their servo, gait files
carry them as a constant column, the simulator and the player drive them like any servo.

Damping rule (MJCF damping/armature vs the servo model), the same in planner and simulator:
the servo model owns the motor — its torque–speed line τ ≤ τ_stall·(1 − q̇/ω₀) already contains
the back-EMF b = τ_stall/ω₀, which gaitsmith charges itself. The MJCF's joint ``damping`` and
``armature`` are the passive mechanics *beyond* the motor (gearbox viscous loss, reflected rotor
inertia), a load the servo must also overcome: the planner charges them in its inverse dynamics,
the simulator in MuJoCo's. An MJCF whose damping models the servo itself (public models often
set damping ≈ a position actuator's kv, ≥ b) therefore counts the motor twice;
`damping_budget` flags it, and ``damping_nm_s_per_rad`` / ``armature_kg_m2`` in
``[joints.NAME]`` replace the MJCF's values in the prepared model (for planner and sim alike).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from robots import toml_schema as ts
from robots.errors import RobotConfigError
from robots.mjcf import JointPrep, PreparedMjcf, prepare
from robots.servo import (
    ServoModel,
    load_catalogue,
    parse_servo_tables,
    read_catalogue_file,
    user_catalogue_path,
)

BUILTIN_DIR = Path(__file__).parent
ROLES = ("leg", "hold")


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
    role: str = "leg"  # "leg" or "hold" (held at stance_rad; see the module docstring)

    @property
    def held(self) -> bool:
        return self.role == "hold"

    def angle_to_ticks(self, angle_rad: float) -> float:
        """Servo goal position for a joint angle (no limit check; see hardware.play.calibration)."""
        return self.zero_offset_ticks + self.direction * angle_rad * self.servo.ticks_per_rad


@dataclass(frozen=True)
class Leg:
    """A leg: its foot site (contact point, at the centre of the foot sphere) and joint chain.

    `foot_body` is the body carrying the foot site; every collidable geom of it (`foot_geoms`,
    names in the prepared model) counts as the foot.
    """

    name: str
    foot_site: str
    joints: tuple[str, ...]
    foot_body: str = ""
    foot_geoms: tuple[str, ...] = ()
    #: "point" (a sphere: the site is its centre) or "flat" (a rectangular sole lying on the
    #: ground in stance, see `robots.sole`)
    foot_kind: str = "point"
    #: flat feet: sole half length (along the sole frame's x) and half width (y) [m]
    sole_half_extents_m: tuple[float, float] | None = None
    #: flat feet: the box geom the sole is the bottom face of, "" when robot.toml gives
    #: sole_size_m (then the foot site is the sole centre and its frame the sole frame)
    sole_geom: str = ""

    @property
    def is_flat(self) -> bool:
        return self.foot_kind == "flat"


@dataclass(frozen=True)
class ImuSpec:
    """robot.toml's ``[imu]``: the build has an IMU the player can read roll and pitch from.
    `attitude_gain`: the default gain of the attitude feedback (`robots.attitude`; None: the
    rule in `robots.attitude.default_attitude_gain`)."""

    description: str = ""
    attitude_gain: float | None = None


@dataclass(frozen=True)
class Robot:
    """A legged robot build. `fingerprint` hashes robot.xml + robot.toml (+ the figures of any
    servo model taken from a user catalogue file)."""

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
    prepared: PreparedMjcf | None = None
    servo_catalogue_path: Path | None = None  # the user catalogue file in force at load
    imu: ImuSpec | None = None  # robot.toml's [imu]: the build carries an IMU (robots.attitude)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def hold_joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints if j.held)

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

    @property
    def notices(self) -> tuple[str, ...]:
        """One-line notices from model preparation (actuators removed, floor added, …)."""
        return () if self.prepared is None else self.prepared.notices

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    def mj_spec(self) -> Any:
        """A fresh `mujoco.MjSpec` of the prepared model (see `robots.mjcf`)."""
        if self.prepared is None:
            import mujoco

            return mujoco.MjSpec.from_file(str(self.mjcf_path))
        return self.prepared.spec()

    def mj_model(self) -> Any:
        """The compiled prepared model (`mujoco.MjModel`)."""
        return self.mj_spec().compile()


# ---------------------------------------------------------------------------------------------
# robot.toml parsing


_TOP_KEYS = {"robot", "servos", "joints", "legs", "imu"}
_IMU_KEYS = {"description", "attitude_gain"}
_ROBOT_KEYS = {"name", "description", "foot_radius_m", "bus_baud"}
_JOINT_KEYS = {
    "servo",
    "bus_id",
    "direction",
    "zero_offset_ticks",
    "stance_deg",
    "limits_deg",
    "role",
    "damping_nm_s_per_rad",
    "armature_kg_m2",
}
_LEG_KEYS = {"foot_site", "joints", "foot", "sole_size_m"}
FOOT_KINDS = ("point", "flat")
MAX_SOLE_SIZE_M = 1.0
MAX_FOOT_RADIUS_M = 1.0
MIN_FOOT_RADIUS_M = 1e-4
MAX_STANCE_HEIGHT_M = 100.0


@dataclass(frozen=True)
class _JointSpec:
    name: str
    servo: ServoModel
    bus_id: int
    direction: int
    zero_offset_ticks: int
    stance_rad: float
    limits_rad: tuple[float, float] | None
    role: str = "leg"
    damping_nm_s_per_rad: float | None = None
    armature_kg_m2: float | None = None


@dataclass(frozen=True)
class RobotSpec:
    """robot.toml as validated data, before it is checked against the MJCF."""

    name: str
    description: str
    foot_radius_m: float
    bus_baud: int
    joints: tuple[_JointSpec, ...]
    legs: tuple[Leg, ...]
    user_servos: tuple[ServoModel, ...] = ()  # models taken from the user catalogue file
    imu: ImuSpec | None = None


def _parse_joint(
    file: str,
    name: str,
    table: Any,
    catalogue: dict[str, ServoModel],
    sources: dict[str, str],
) -> _JointSpec:
    where = f"[joints.{name}]"
    if not isinstance(table, dict):
        raise RobotConfigError(file, where, "must be a table")
    ts.string(file, f"{where} (the joint's name)", name)
    ts.check_keys(file, where, table, _JOINT_KEYS)
    for key in ("servo", "bus_id", "direction", "zero_offset_ticks", "stance_deg"):
        if key not in table:
            raise RobotConfigError(file, f"{where}.{key}", "missing; every joint table needs it")
    servo_name = ts.string(file, f"{where}.servo", table["servo"])
    if servo_name not in catalogue:
        raise RobotConfigError(
            file,
            f"{where}.servo",
            f"unknown servo model {servo_name!r}; known: {', '.join(sorted(catalogue))}; "
            f"add a [servos.{servo_name}] table, or a catalogue file (--servos FILE or "
            "$GAITSMITH_SERVOS)",
        )
    servo = catalogue[servo_name]
    direction = table["direction"]
    if isinstance(direction, bool) or not isinstance(direction, int) or direction not in (1, -1):
        raise RobotConfigError(
            file, f"{where}.direction", f"must be the integer 1 or -1, got {direction!r:.40}"
        )
    limits = table.get("limits_deg")
    limits_rad = None
    if limits is not None:
        if not isinstance(limits, list) or len(limits) != 2:
            raise RobotConfigError(file, f"{where}.limits_deg", "must be [lower, upper] in degrees")
        lo = ts.number(file, f"{where}.limits_deg[0]", limits[0], -360.0, 360.0, unit="°")
        hi = ts.number(file, f"{where}.limits_deg[1]", limits[1], -360.0, 360.0, unit="°")
        if not lo < hi:
            raise RobotConfigError(file, f"{where}.limits_deg", "lower must be below upper")
        limits_rad = (math.radians(lo), math.radians(hi))
    role = table.get("role", "leg")
    if role not in ROLES:
        raise RobotConfigError(file, f"{where}.role", f'must be "leg" or "hold", got {role!r:.40}')
    optional: dict[str, float | None] = {}
    for key, hi_v in (("damping_nm_s_per_rad", 1e3), ("armature_kg_m2", 10.0)):
        v = table.get(key)
        optional[key] = None if v is None else ts.number(file, f"{where}.{key}", v, 0.0, hi_v)
    sources.setdefault(servo_name, "used")
    return _JointSpec(
        name=name,
        servo=servo,
        bus_id=ts.integer(file, f"{where}.bus_id", table["bus_id"], 0, 252),
        direction=int(direction),
        zero_offset_ticks=ts.integer(
            file,
            f"{where}.zero_offset_ticks",
            table["zero_offset_ticks"],
            servo.position_min_tick,
            servo.position_max_tick,
        ),
        stance_rad=math.radians(
            ts.number(file, f"{where}.stance_deg", table["stance_deg"], -360.0, 360.0, unit="°")
        ),
        limits_rad=limits_rad,
        role=str(role),
        **optional,  # type: ignore[arg-type]
    )


def parse_robot_toml(text: str, file: str, servo_catalogue: str | Path | None = None) -> RobotSpec:
    """Validate robot.toml's text; raises RobotConfigError naming the field at fault.

    `servo_catalogue`: the user catalogue file (else $GAITSMITH_SERVOS); see the module docstring.
    """
    data = ts.read_toml(text, file)
    ts.check_keys(file, "<top>", data, _TOP_KEYS)
    head = ts.table(file, "[robot]", data.get("robot"))
    ts.check_keys(file, "[robot]", head, _ROBOT_KEYS)
    name = ts.string(file, "[robot].name", head.get("name")).strip()
    description = ts.string(
        file, "[robot].description", head.get("description", ""), allow_empty=True
    )
    foot_radius = ts.number(
        file,
        "[robot].foot_radius_m",
        head.get("foot_radius_m"),
        MIN_FOOT_RADIUS_M,
        MAX_FOOT_RADIUS_M,
        unit="m",
    )
    catalogue = dict(load_catalogue())
    user_path = user_catalogue_path(servo_catalogue)
    user: dict[str, ServoModel] = {}
    if user_path is not None:
        user = read_catalogue_file(user_path)
        catalogue.update(user)
    catalogue.update(parse_servo_tables(file, "servos.", data.get("servos", {})))
    sources: dict[str, str] = {}
    joint_tables = ts.table(file, "[joints]", data.get("joints"))
    joints = tuple(_parse_joint(file, n, t, catalogue, sources) for n, t in joint_tables.items())
    in_toml = set(data.get("servos", {}))
    user_used = tuple(user[n] for n in sorted(sources) if n in user and n not in in_toml)
    first = joints[0].servo
    lowest_baud = 0 if first.default_baud == 0 else 1  # 0: PWM servos, no serial bus
    baud = ts.integer(
        file, "[robot].bus_baud", head.get("bus_baud", first.default_baud), lowest_baud, 10**8
    )
    seen: dict[int, str] = {}
    for j in joints:
        if j.bus_id in seen:
            raise RobotConfigError(
                file,
                f"[joints.{j.name}].bus_id",
                f"duplicate bus id {j.bus_id} (also [joints.{seen[j.bus_id]}]); give each "
                "servo its own id",
            )
        seen[j.bus_id] = j.name
        if j.servo.protocol != first.protocol:
            raise RobotConfigError(
                file,
                f"[joints.{j.name}].servo",
                f"protocol {j.servo.protocol} differs from {first.protocol} "
                f"([joints.{joints[0].name}]); one bus, one protocol",
            )
    legs = _parse_legs(file, ts.table(file, "[legs]", data.get("legs")), joints)
    imu = _parse_imu(file, data["imu"]) if "imu" in data else None
    return RobotSpec(name, description, foot_radius, baud, joints, legs, user_used, imu)


def _parse_imu(file: str, value: Any) -> ImuSpec:
    """``[imu]``: an optional description and an optional default attitude gain."""
    from robots.attitude import MAX_ATTITUDE_GAIN

    if isinstance(value, dict) and not value:
        return ImuSpec()  # `[imu]` alone: the build has an IMU, nothing more to say
    table = ts.table(file, "[imu]", value)
    ts.check_keys(file, "[imu]", table, _IMU_KEYS)
    description = ts.string(file, "[imu].description", table.get("description", ""),
                            allow_empty=True)
    gain = table.get("attitude_gain")
    return ImuSpec(description, None if gain is None else ts.number(
        file, "[imu].attitude_gain", gain, 0.0, MAX_ATTITUDE_GAIN))


def _parse_legs(
    file: str, tables: dict[str, Any], joints: tuple[_JointSpec, ...]
) -> tuple[Leg, ...]:
    roles = {j.name: j.role for j in joints}
    legs: list[Leg] = []
    used: dict[str, str] = {}
    for leg_name, table in tables.items():
        where = f"[legs.{leg_name}]"
        if not isinstance(table, dict):
            raise RobotConfigError(file, where, "must be a table")
        ts.string(file, f"{where} (the leg's name)", leg_name)
        ts.check_keys(file, where, table, _LEG_KEYS)
        site = ts.string(file, f"{where}.foot_site", table.get("foot_site"))
        chain = table.get("joints")
        if not isinstance(chain, list) or not chain or not all(isinstance(c, str) for c in chain):
            raise RobotConfigError(
                file, f"{where}.joints", "must be a non-empty list of joint names"
            )
        for c in chain:
            if c not in roles:
                raise RobotConfigError(
                    file, f"{where}.joints", f"joint {c!r} has no [joints.{c}] table; add one"
                )
            if roles[c] == "hold":
                raise RobotConfigError(
                    file,
                    f"{where}.joints",
                    f'joint {c!r} has role = "hold" ([joints.{c}].role); a held joint is in '
                    "no leg: remove it from the list or drop its role",
                )
            if c in used:
                raise RobotConfigError(
                    file, f"{where}.joints", f"joint {c!r} is already in [legs.{used[c]}]"
                )
            used[c] = leg_name
        kind = table.get("foot", "point")
        if kind not in FOOT_KINDS:
            raise RobotConfigError(
                file, f"{where}.foot", f'must be "point" or "flat", got {kind!r:.40}'
            )
        sole = table.get("sole_size_m")
        half: tuple[float, float] | None = None
        if sole is not None:
            if kind != "flat":
                raise RobotConfigError(
                    file, f"{where}.sole_size_m", 'only a flat foot has a sole; add foot = "flat"'
                )
            if not isinstance(sole, list) or len(sole) != 2:
                raise RobotConfigError(
                    file, f"{where}.sole_size_m", "must be [length, width] in metres"
                )
            length, width = (
                ts.number(file, f"{where}.sole_size_m[{i}]", v, 1e-3, MAX_SOLE_SIZE_M, unit="m")
                for i, v in enumerate(sole)
            )
            half = (0.5 * length, 0.5 * width)
        legs.append(
            Leg(leg_name, site, tuple(chain), foot_kind=str(kind), sole_half_extents_m=half)
        )
    loose = [n for n, r in roles.items() if r == "leg" and n not in used]
    if loose:
        raise RobotConfigError(
            file,
            f"[joints.{loose[0]}]",
            f"joint {loose[0]!r} is in no leg (joints not in any leg: {loose}); add it to a "
            '[legs.NAME].joints list, or set role = "hold" to hold it at its stance angle',
        )
    return tuple(legs)


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


def load(name_or_path: str | Path, servo_catalogue: str | Path | None = None) -> Robot:
    """Load a built-in robot by name ("quad12") or a user's folder with robot.xml + robot.toml.

    `servo_catalogue`: a user servo catalogue file (the CLI's ``--servos FILE``); without it,
    ``$GAITSMITH_SERVOS`` if set. robot.toml's own [servos] tables take precedence over both.
    """
    root = _resolve_dir(name_or_path).resolve()  # absolute: a Robot outlives a chdir
    toml_path, mjcf_path = root / "robot.toml", root / "robot.xml"
    for p in (toml_path, mjcf_path):
        if not p.is_file():
            raise RobotConfigError(
                str(p), "<file>", "missing; a robot folder needs robot.xml and robot.toml"
            )
    toml_bytes, mjcf_bytes = toml_path.read_bytes(), mjcf_path.read_bytes()
    if len(toml_bytes) > ts.MAX_TOML_BYTES:
        raise RobotConfigError(
            str(toml_path), "<file>", f"is {len(toml_bytes)} bytes; at most {ts.MAX_TOML_BYTES}"
        )
    try:
        toml_text = toml_bytes.decode("utf-8")
    except UnicodeDecodeError:
        raise RobotConfigError(str(toml_path), "<file>", "not UTF-8 text") from None
    spec = parse_robot_toml(toml_text, str(toml_path), servo_catalogue)
    digest = hashlib.sha256(mjcf_bytes).digest() + hashlib.sha256(toml_bytes).digest()
    if spec.user_servos:  # a different user catalogue is a different build
        digest += hashlib.sha256(repr(spec.user_servos).encode()).digest()
    fingerprint = hashlib.sha256(digest).hexdigest()[:16]
    robot = _build(spec, root, mjcf_path, toml_path, fingerprint)
    if user_catalogue_path(servo_catalogue) is not None:
        from dataclasses import replace

        robot = replace(robot, servo_catalogue_path=user_catalogue_path(servo_catalogue))
    return robot


def _build(
    spec: RobotSpec, root: Path, mjcf_path: Path, toml_path: Path, fingerprint: str
) -> Robot:
    import mujoco  # lazy: only robot loading needs MJCF parsing

    tfile, mfile = str(toml_path), str(mjcf_path)
    prepared = prepare(
        mjcf_path,
        tuple(
            JointPrep(js.name, js.limits_rad, js.damping_nm_s_per_rad, js.armature_kg_m2)
            for js in spec.joints
        ),
        tfile,
    )
    model = prepared.model()
    if model.njnt == 0 or model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise RobotConfigError(
            mfile, "<freejoint>", "the robot's root body needs a <freejoint/>; add one"
        )
    joints: list[Joint] = []
    for js in spec.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, js.name)
        where = f"[joints.{js.name}]"
        if jid < 0:
            raise RobotConfigError(
                tfile, where, f"joint {js.name!r} is not in {mfile}; check the name"
            )
        if model.jnt_type[jid] != mujoco.mjtJoint.mjJNT_HINGE:
            raise RobotConfigError(mfile, f"joint {js.name}", "must be a hinge joint")
        lo, hi = (float(x) for x in model.jnt_range[jid])
        if not lo < hi:
            raise RobotConfigError(
                mfile,
                f"joint {js.name}",
                f'range [{lo:g}, {hi:g}] rad is empty; give range="lo hi" with lo < hi',
            )
        if js.limits_rad is not None:
            if js.limits_rad[0] < lo - 1e-9 or js.limits_rad[1] > hi + 1e-9:
                raise RobotConfigError(
                    tfile,
                    f"{where}.limits_deg",
                    f"must lie inside the MJCF range [{math.degrees(lo):.1f}, "
                    f"{math.degrees(hi):.1f}]°",
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
                    "narrow the joint range (limits_deg) or change zero_offset_ticks",
                )
        if not lo <= js.stance_rad <= hi:
            raise RobotConfigError(
                tfile,
                f"{where}.stance_deg",
                f"{math.degrees(js.stance_rad):.1f}° is outside the joint limits "
                f"[{math.degrees(lo):.1f}, {math.degrees(hi):.1f}]°",
            )
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
                js.role,
            )
        )
    mapped = {j.name for j in joints}
    for i in range(model.njnt):
        if model.jnt_type[i] == mujoco.mjtJoint.mjJNT_FREE and i == 0:
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, i) or f"#{i}"
        if model.jnt_type[i] != mujoco.mjtJoint.mjJNT_HINGE:
            raise RobotConfigError(
                mfile,
                f"joint {name}",
                "only hinge joints (servos) and the root freejoint are supported; make it a "
                "hinge or remove it",
            )
        if name not in mapped:
            raise RobotConfigError(
                tfile,
                f"[joints.{name}]",
                f"MJCF joint {name!r} has no servo mapping — add a [joints.{name}] table "
                '(with role = "hold" if it is in no leg)',
            )

    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0:3] = 0.0
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    for j in joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        data.qpos[model.jnt_qposadr[jid]] = j.stance_rad
    mujoco.mj_kinematics(model, data)
    held = {j.name for j in joints if j.held}
    foot_z, leg_lengths = [], []
    sole_notices: list[str] = []
    legs: list[Leg] = []
    for leg in spec.legs:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
        if sid < 0:
            raise RobotConfigError(
                tfile,
                f"[legs.{leg.name}].foot_site",
                f"site {leg.foot_site!r} not in {mfile}; add a <site> at the foot's contact "
                "point (the centre of the foot sphere)",
            )
        # the chain must be the leg joints from the root to the foot, in order (held joints,
        # e.g. a spine, may sit between them)
        body = int(model.site_bodyid[sid])
        ancestors: list[str] = []
        while body > 0:
            for k in range(model.body_jntnum[body]):
                jid = model.body_jntadr[body] + k
                if model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_HINGE:
                    jname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, jid)
                    if jname not in held:
                        ancestors.insert(0, jname)
            body = int(model.body_parentid[body])
        if tuple(ancestors) != leg.joints:
            raise RobotConfigError(
                tfile,
                f"[legs.{leg.name}].joints",
                f"must list the joints from the body to {leg.foot_site} in order: {ancestors}",
            )
        foot_body = int(model.site_bodyid[sid])
        geoms = tuple(
            mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
            for g in range(model.ngeom)
            if int(model.geom_bodyid[g]) == foot_body
            and (int(model.geom_contype[g]) != 0 or int(model.geom_conaffinity[g]) != 0)
        )
        body_name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, foot_body)
        if not geoms:
            raise RobotConfigError(
                mfile,
                f"body {body_name}",
                f"carries foot site {leg.foot_site!r} ([legs.{leg.name}]) but no collidable "
                "geom; give the foot a geom with contype/conaffinity set",
            )
        built = Leg(leg.name, leg.foot_site, leg.joints, body_name, geoms)
        if not leg.is_flat:
            sole_notices.extend(_box_sole_notice(model, leg.name, geoms))
        # the contact point's height: the sphere's centre (its radius is added below) or, for a
        # flat foot, the sole centre lifted by the radius so both kinds compare alike
        foot = float(data.site_xpos[sid][2])
        if leg.is_flat:
            from robots.sole import resolve_sole, sole_pose_world

            built = resolve_sole(model, leg, built, tfile, mfile)
            foot = float(sole_pose_world(model, data, built)[0][2]) + spec.foot_radius_m
        legs.append(built)
        first = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, leg.joints[0])
        anchor = data.xanchor[first]
        foot_z.append(foot)
        leg_lengths.append(float(anchor[2] - foot) + (spec.foot_radius_m if leg.is_flat else 0.0))
    if sole_notices:
        prepared = replace(prepared, notices=(*prepared.notices, *sole_notices))
    height = spec.foot_radius_m - min(foot_z)
    if not 0.0 < height <= MAX_STANCE_HEIGHT_M:
        raise RobotConfigError(
            tfile,
            "[joints].stance_deg",
            f"at the stance pose the lowest foot site is {-min(foot_z):.3g} m below the root "
            f"body; it must be between 0 and {MAX_STANCE_HEIGHT_M:g} m (check stance_deg and "
            "the foot sites)",
        )
    return Robot(
        name=spec.name,
        description=spec.description,
        root_dir=root,
        mjcf_path=mjcf_path,
        toml_path=toml_path,
        fingerprint=fingerprint,
        joints=tuple(joints),
        legs=tuple(legs),
        mass_kg=float(sum(model.body_mass)),
        foot_radius_m=spec.foot_radius_m,
        bus_baud=spec.bus_baud,
        stance_base_height_m=height,
        leg_length_m=sum(leg_lengths) / len(leg_lengths),
        prepared=prepared,
        imu=spec.imu,
    )


def _box_sole_notice(model: Any, leg_name: str, foot_geoms: tuple[str, ...]) -> list[str]:
    """A notice when a point foot's only collidable geom is a box: a sole the planner would
    balance on a point (`robots init` declares such feet flat; a hand-written folder may not)."""
    import mujoco

    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in foot_geoms]
    if len(ids) != 1 or int(model.geom_type[ids[0]]) != int(mujoco.mjtGeom.mjGEOM_BOX):
        return []
    size = model.geom_size[ids[0]]
    return [
        f"[legs.{leg_name}]: the foot is box geom {foot_geoms[0]!r} "
        f"({2e3 * size[0]:.0f} × {2e3 * size[1]:.0f} mm) but the leg declares a point foot; "
        'add foot = "flat" so the planner keeps the sole flat on the ground'
    ]


# ---------------------------------------------------------------------------------------------
# MJCF damping and armature vs the servo (see the damping rule in the module docstring)

TYPICAL_SPEED_FRACTION = 0.5  # typical peak joint speed in a gait: half the no-load speed
TYPICAL_FREQUENCY_HZ = 2.0  # a joint swinging at that speed as a 2 Hz sinusoid (q̈ = 2πf·q̇)
DOUBLE_COUNT_FRACTION = 0.5  # MJCF damping ≥ half the servo's back-EMF slope: likely the motor
LOAD_SHARE_FLAG = 0.25  # damping + armature take more than a quarter of the stall torque
# MJCF armature below this share of the servo's identified rotor inertia: legs too light
ARMATURE_LOW_FRACTION = 0.5
ARMATURE_OWN_ROTOR_FRACTION = 1.5  # up to this multiple it is the servo's own rotor, not a mistake


def _own_rotor(armature_kg_m2: float, identified_kg_m2: float | None) -> bool:
    """Whether the MJCF armature is the servo's identified rotor inertia (a heavy rotor is a
    property of the servo, not a modelling mistake to flag)."""
    if identified_kg_m2 is None:
        return False
    return armature_kg_m2 <= ARMATURE_OWN_ROTOR_FRACTION * identified_kg_m2


@dataclass(frozen=True)
class JointLoadBudget:
    """Share of one joint's stall torque that MJCF damping and armature take at a typical speed."""

    joint: str
    servo: str
    mjcf_damping_nm_s_per_rad: float
    armature_kg_m2: float
    back_emf_nm_s_per_rad: float  # the servo's own b = τ_stall/ω₀ (charged by gaitsmith)
    speed_rad_s: float
    acceleration_rad_s2: float
    damping_share: float  # damping·q̇ / τ_stall
    armature_share: float  # armature·q̈ / τ_stall
    back_emf_share: float  # b·q̇ / τ_stall, for comparison (= q̇/ω₀)
    flag: str | None  # why this joint's MJCF likely double counts the servo, or None


def damping_budget(
    robot: Robot,
    speed_fraction: float = TYPICAL_SPEED_FRACTION,
    frequency_hz: float = TYPICAL_FREQUENCY_HZ,
) -> tuple[JointLoadBudget, ...]:
    """Per joint: how much of the servo's torque the prepared model's damping and armature take
    at a typical gait speed (`speed_fraction`·ω₀, as a sinusoid at `frequency_hz`), with a flag
    where the MJCF damping likely models the motor again (see the module docstring)."""
    import mujoco

    model = robot.mj_model()
    out: list[JointLoadBudget] = []
    for j in robot.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        dof = int(model.jnt_dofadr[jid])
        damping = float(model.dof_damping[dof])
        armature = float(model.dof_armature[dof])
        stall, w0 = j.servo.stall_torque_nm, j.servo.no_load_speed_rad_s
        identified = j.servo.armature_kg_m2
        b = stall / w0
        speed = speed_fraction * w0
        acc = 2.0 * math.pi * frequency_hz * speed
        d_share, a_share = damping * speed / stall, armature * acc / stall
        flag = None
        if damping >= DOUBLE_COUNT_FRACTION * b:
            flag = (
                f"MJCF damping {damping:.3g} N·m·s/rad is {damping / b:.0%} of the servo's own "
                f"back-EMF slope {b:.3g} (τ_stall/ω₀, already charged): it likely models the "
                f"motor again; set damping_nm_s_per_rad in [joints.{j.name}] (gearbox loss only) "
                "or lower damping in the MJCF"
            )
        elif identified is not None and armature < ARMATURE_LOW_FRACTION * identified:
            flag = (
                f"MJCF armature {armature:.3g} kg·m² is {armature / identified:.0%} of "
                f"{j.servo.name}'s identified rotor inertia {identified:.3g} (robots/servos.toml): "
                "the legs swing lighter in MuJoCo than on the real servos; set armature_kg_m2 = "
                f"{identified:g} in [joints.{j.name}] or the MJCF"
            )
        elif d_share + a_share > LOAD_SHARE_FLAG and not _own_rotor(armature, identified):
            flag = (
                f"MJCF damping and armature take {d_share + a_share:.0%} of {j.servo.name}'s "
                f"stall torque at {speed:.2g} rad/s; check damping_nm_s_per_rad / "
                f"armature_kg_m2 in [joints.{j.name}] or the MJCF"
            )
        out.append(
            JointLoadBudget(
                j.name,
                j.servo.name,
                damping,
                armature,
                b,
                speed,
                acc,
                d_share,
                a_share,
                speed / w0,
                flag,
            )
        )
    return tuple(out)

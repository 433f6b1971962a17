"""The robot's MJCF turned into a simulation: servo actuators, perturbations and sensors.

Everything is discovered from the `Robot` (joints, legs, foot sites); nothing here knows a leg
count, a joint name or a link length. Sensors (prefixed ``gs_``) log per physics step, so a whole
rollout runs natively in `mujoco.rollout`:

- base: frame position, quaternion and linear velocity of the root (freejoint) body;
- per joint: position, velocity, actuator force (the clipped drive of `sim.servo`);
- per foot: foot-site position, linear and angular velocity, and a contact sensor between the
  foot body (all its geoms: a foot of several geoms is one foot) and the world body (number of
  contacts, net force);
- one contact sensor between the whole robot and the world body: the number of robot–ground
  contacts; any beyond the feet' count means the body (or a shin) touched the ground.

Contacts: MuJoCo's soft constraints let a loaded foot creep inside its friction cone (the
friction rows are regularised like the normal one). Rubber feet do not: on spotmicro's trot the
stance feet crept 3-9 mm back per stance at 30 % of the friction limit and the robot walked 13 %
slow. The build runs MuJoCo's noslip post-solver (`NOSLIP_ITERATIONS`, or the MJCF's own count if
higher), which removes that drift in the friction dimensions without stiffening the normal
contact (spotmicro: net creep ≤ 3 mm, speed within 4 %).

Lifted mode (`SimConditions(lifted=True)`, the servo identification bench, issue #18 item 6):
the root body's freejoint is removed, so the base is welded to the world, raised by
`LIFT_M` above its stance height, and the world's geoms (the floor) collide with nothing: the
legs swing freely in the air, as on a robot hung from a stand. Only the joints remain in qpos.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from robots.robot import Robot
from robots.servo_params import ServoSetting
from sim.errors import SimConfigError, SimSetupError
from sim.servo import ServoParams, servo_params

CONTACT_FOUND = int(mujoco.mjtConDataField.mjCONDATA_FOUND)
CONTACT_FORCE = int(mujoco.mjtConDataField.mjCONDATA_FORCE)
REDUCE_NETFORCE = 3
#: iterations of MuJoCo's noslip solver (`mjOption.noslip_iterations`), see the module docstring
NOSLIP_ITERATIONS = 10
#: lifted mode: the base sits this far above its stance height (the feet clear the floor)
LIFT_M = 0.3


@dataclass(frozen=True)
class SimConditions:
    """Perturbations of the nominal build (robustness sweep axes, except stream latency)."""

    friction: float | None = None  # sliding µ for every geom; None keeps the MJCF's
    payload_kg: float = 0.0  # extra mass on the root body (inertia scaled with it)
    strength: float = 1.0  # servo strength scale (1 = datasheet)
    lifted: bool = False  # base welded in the air, floor contacts off (see the module docstring)

    def __post_init__(self) -> None:
        if self.friction is not None and not (math.isfinite(self.friction) and self.friction > 0):
            raise SimConfigError(f"friction must be positive, got {self.friction!r}")
        if not (math.isfinite(self.payload_kg) and self.payload_kg >= 0):
            raise SimConfigError(f"payload must be ≥ 0 kg, got {self.payload_kg!r}")
        if not (math.isfinite(self.strength) and self.strength > 0):
            raise SimConfigError(f"servo strength scale must be positive, got {self.strength!r}")


@dataclass(frozen=True, eq=False)
class SimModel:
    """A compiled model plus the index maps the rollout and metrics need."""

    robot: Robot
    model: mujoco.MjModel
    conditions: SimConditions
    servos: tuple[ServoParams, ...]
    qpos_adr: np.ndarray  # (J,) qpos index of each robot joint, in robot.joints order
    dof_adr: np.ndarray  # (J,)
    root_body: int
    foot_geoms: tuple[tuple[int, ...], ...]  # per leg: every collidable geom of its foot body
    mass_kg: float  # robot + payload
    sensors: dict[str, slice] = field(default_factory=dict)

    @property
    def n_joints(self) -> int:
        return len(self.servos)

    @property
    def n_feet(self) -> int:
        return len(self.foot_geoms)

    @property
    def back_emf_nm_s_per_rad(self) -> np.ndarray:
        return np.array([s.back_emf_nm_s_per_rad for s in self.servos])

    @property
    def servo_latency_s(self) -> np.ndarray:
        """Each servo's own goal delay (identified, `robots.servo_params`; 0 = catalogue)."""
        return np.array([s.latency_s for s in self.servos])

    @property
    def stall_torque_nm(self) -> np.ndarray:
        """Datasheet stall torque per joint (not scaled by strength)."""
        return np.array([s.stall_torque_nm for s in self.servos])

    def sensor(self, sensordata: np.ndarray, name: str) -> np.ndarray:
        """Columns of sensor `name` from a (…, nsensordata) array."""
        return sensordata[..., self.sensors[name]]

    def initial_state(self) -> np.ndarray:
        """Full physics state at rest in the nominal stance, feet just touching the floor."""
        data = mujoco.MjData(self.model)
        data.qpos[:] = self.model.qpos0
        if not self.conditions.lifted:  # lifted: the base is welded where the build put it
            data.qpos[0:3] = (0.0, 0.0, self.robot.stance_base_height_m + 5e-4)
            data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        data.qpos[self.qpos_adr] = self.robot.nominal_stance_rad
        state = np.empty(mujoco.mj_stateSize(self.model, STATE_SPEC))
        mujoco.mj_getState(self.model, data, state, STATE_SPEC)
        return state


STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


def _foot_geom_ids(model: mujoco.MjModel, robot: Robot) -> tuple[tuple[int, ...], ...]:
    """Per leg, the ids of its foot geoms (every collidable geom of the foot body, as
    `robots.load` found them in the prepared model)."""
    out = []
    for leg in robot.legs:
        ids = tuple(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in leg.foot_geoms)
        if not ids or min(ids) < 0:
            raise SimSetupError(
                f"foot {leg.name}: foot geoms {list(leg.foot_geoms)} not in the prepared model"
            )
        out.append(ids)
    return tuple(out)


def servos_for(
    robot: Robot, conditions: SimConditions, settings: Sequence[ServoSetting] | None = None
) -> tuple[ServoParams, ...]:
    """One `ServoParams` per joint: the catalogue servo at its factory gains, scaled by the
    identified `settings` (gain, strength, latency; `robots.servo_params`) when given, its
    strength also by `conditions.strength`."""
    if settings is None:
        settings = [ServoSetting()] * robot.dof
    if len(settings) != robot.dof:
        raise SimConfigError(f"{len(settings)} servo settings for the {robot.dof} joints")
    return tuple(
        servo_params(
            j.servo,
            strength=conditions.strength * st.strength,
            gain_scale=st.gain_scale,
            latency_s=st.latency_s,
        )
        for j, st in zip(robot.joints, settings, strict=True)
    )


def build_sim_model(
    robot: Robot,
    conditions: SimConditions = SimConditions(),
    *,
    servos: tuple[ServoParams, ...] | None = None,
    timestep_s: float | None = None,
    servo_settings: Sequence[ServoSetting] | None = None,
) -> SimModel:
    """Compile the robot's MJCF with one servo per joint and the logging sensors (`servos`, or
    the catalogue servos scaled by the identified `servo_settings`, see `servos_for`)."""
    try:  # the prepared model (robots.mjcf): its own actuators removed, floor, absolute paths
        spec = robot.mj_spec()
        base = spec.compile()
    except Exception as exc:  # mujoco raises ValueError with its parser's message
        raise SimSetupError(f"{robot.mjcf_path}: MuJoCo cannot load it: {exc}") from None
    if servos is None:
        servos = servos_for(robot, conditions, servo_settings)
    elif len(servos) != robot.dof:
        raise SimConfigError(f"{len(servos)} servo parameter sets for {robot.dof} joints")
    root_body = int(base.jnt_bodyid[0])
    root_name = mujoco.mj_id2name(base, mujoco.mjtObj.mjOBJ_BODY, root_body)
    if conditions.payload_kg > 0:
        body = spec.body(root_name)
        scale = (body.mass + conditions.payload_kg) / body.mass
        body.mass = body.mass + conditions.payload_kg
        body.inertia = np.asarray(body.inertia) * scale
    if conditions.lifted:
        _weld_base_in_air(spec, root_name, robot.stance_base_height_m + LIFT_M)
    for joint, sp in zip(robot.joints, servos, strict=True):
        act = spec.add_actuator()
        act.name = f"gs_servo_{joint.name}"
        act.target = joint.name
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.set_to_position(kp=sp.kp_nm_per_rad, kv=sp.kd_nm_s_per_rad)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = (-sp.drive_limit_nm, sp.drive_limit_nm)
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    names = _add_sensors(spec, base, robot, root_name)
    try:
        model = spec.compile()
    except Exception as exc:
        raise SimSetupError(f"{robot.mjcf_path}: cannot add servos/sensors: {exc}") from None
    qpos_adr, dof_adr = [], []
    for joint, sp in zip(robot.joints, servos, strict=True):
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
        qpos_adr.append(int(model.jnt_qposadr[jid]))
        dof_adr.append(int(model.jnt_dofadr[jid]))
        model.dof_damping[model.jnt_dofadr[jid]] += sp.back_emf_nm_s_per_rad
    model.opt.noslip_iterations = max(int(model.opt.noslip_iterations), NOSLIP_ITERATIONS)
    if timestep_s is not None:
        model.opt.timestep = timestep_s
    if conditions.friction is not None:
        model.geom_friction[:, 0] = conditions.friction
    if conditions.lifted:  # nothing touches the world's geoms (the floor)
        world_geoms = model.geom_bodyid == 0
        model.geom_contype[world_geoms] = 0
        model.geom_conaffinity[world_geoms] = 0
    foot_geoms = _foot_geom_ids(model, robot)
    sensors = {}
    for name in names:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
        adr = int(model.sensor_adr[sid])
        sensors[name] = slice(adr, adr + int(model.sensor_dim[sid]))
    return SimModel(
        robot=robot,
        model=model,
        conditions=conditions,
        servos=servos,
        qpos_adr=np.array(qpos_adr),
        dof_adr=np.array(dof_adr),
        root_body=root_body,
        foot_geoms=foot_geoms,
        mass_kg=float(np.sum(model.body_mass)),
        sensors=sensors,
    )


def _weld_base_in_air(spec: mujoco.MjSpec, root_name: str, height_m: float) -> None:
    """Remove the root body's freejoint (the base becomes part of the world) and put it, level,
    at `height_m`."""
    body = spec.body(root_name)
    for joint in list(body.joints):
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            spec.delete(joint)
    body.pos = (0.0, 0.0, height_m)
    body.quat = (1.0, 0.0, 0.0, 0.0)


def _add_sensors(
    spec: mujoco.MjSpec, base: mujoco.MjModel, robot: Robot, root_name: str
) -> list[str]:
    names: list[str] = []

    def add(
        name: str,
        kind: mujoco.mjtSensor,
        objtype: mujoco.mjtObj,
        objname: str,
        reftype: mujoco.mjtObj | None = None,
        refname: str = "",
        intprm: tuple[int, int, int] | None = None,
    ) -> None:
        s = spec.add_sensor()
        s.name, s.type, s.objtype, s.objname = name, kind, objtype, objname
        if reftype is not None:
            s.reftype, s.refname = reftype, refname
        if intprm is not None:
            s.intprm = intprm
        names.append(name)

    world = mujoco.mj_id2name(base, mujoco.mjtObj.mjOBJ_BODY, 0) or "world"
    xbody, site = mujoco.mjtObj.mjOBJ_XBODY, mujoco.mjtObj.mjOBJ_SITE
    add("gs_base_pos", mujoco.mjtSensor.mjSENS_FRAMEPOS, xbody, root_name)
    add("gs_base_quat", mujoco.mjtSensor.mjSENS_FRAMEQUAT, xbody, root_name)
    add("gs_base_linvel", mujoco.mjtSensor.mjSENS_FRAMELINVEL, xbody, root_name)
    for j in robot.joints:
        add(f"gs_q_{j.name}", mujoco.mjtSensor.mjSENS_JOINTPOS, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        add(f"gs_qd_{j.name}", mujoco.mjtSensor.mjSENS_JOINTVEL, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        add(
            f"gs_drive_{j.name}",
            mujoco.mjtSensor.mjSENS_ACTUATORFRC,
            mujoco.mjtObj.mjOBJ_ACTUATOR,
            f"gs_servo_{j.name}",
        )
    for leg in robot.legs:
        if not leg.foot_body:
            raise SimSetupError(f"foot {leg.name}: the robot was loaded without its foot body")
        add(f"gs_foot_pos_{leg.name}", mujoco.mjtSensor.mjSENS_FRAMEPOS, site, leg.foot_site)
        add(f"gs_foot_vel_{leg.name}", mujoco.mjtSensor.mjSENS_FRAMELINVEL, site, leg.foot_site)
        add(f"gs_foot_angvel_{leg.name}", mujoco.mjtSensor.mjSENS_FRAMEANGVEL, site, leg.foot_site)
        add(
            f"gs_foot_contact_{leg.name}",
            mujoco.mjtSensor.mjSENS_CONTACT,
            mujoco.mjtObj.mjOBJ_BODY,  # every geom of the foot body counts as the foot
            leg.foot_body,
            mujoco.mjtObj.mjOBJ_BODY,
            world,
            (1 << CONTACT_FOUND | 1 << CONTACT_FORCE, REDUCE_NETFORCE, 1),
        )
    add(
        "gs_robot_contacts",
        mujoco.mjtSensor.mjSENS_CONTACT,
        xbody,
        root_name,
        mujoco.mjtObj.mjOBJ_BODY,
        world,
        (1 << CONTACT_FOUND, REDUCE_NETFORCE, 1),
    )
    return names

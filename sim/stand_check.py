"""`robots check`: does the robot stand on its servos, and how hard do they work to hold it?

The robot starts in its nominal stance (feet just touching the floor, `SimModel.initial_state`),
every servo holding its stance angle through the servo model of `sim.servo` (clipped position
loop + back-EMF), and the physics runs for `duration_s`. Over the last `WINDOW_FRACTION` of the
run we measure base height, tilt, speed and the servos' output torque τ = drive − b·q̇.

It stands when nothing diverged, it is upright (tilt ≤ MAX_TILT_DEG), its centre of mass kept
most of its starting height (drop ≤ MAX_DROP_FRACTION; the CoM, not the root body's frame, which
a URDF may put anywhere, e.g. at a `base_footprint` on the ground), it is still (base speed
≤ MAX_SPEED_M_S), only its feet touch the ground, and no servo is saturated (holding load
< 100 % of stall).

The torque budget is `robots.robot.damping_budget` (the damping rule there): the share of each
servo's stall torque that the MJCF's joint damping and armature take at a typical gait speed,
flagged where the damping looks like the motor's back-EMF counted a second time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from robots.robot import Robot, damping_budget
from sim.errors import SimConfigError
from sim.model import SimModel, build_sim_model

WINDOW_FRACTION = 0.25
MAX_TILT_DEG = 15.0
MAX_DROP_FRACTION = 0.25
MAX_SPEED_M_S = 0.05


@dataclass(frozen=True)
class JointLoad:
    name: str
    servo: str
    stall_torque_nm: float
    holding_torque_nm: float  # mean servo output torque over the window
    load_fraction: float  # |holding torque| / stall
    damping_nm_s_per_rad: float  # MJCF joint damping (without the servo's back-EMF)
    back_emf_nm_s_per_rad: float  # what the servo model adds
    armature_kg_m2: float
    damping_share: float  # d·ω_t / τ_stall
    armature_share: float  # I_a·α_t / τ_stall
    budget_flag: str | None  # why damping/armature look double-counted or too heavy, or None


@dataclass(frozen=True)
class StandReport:
    robot: str
    mass_kg: float
    legs: int
    duration_s: float
    stands: bool
    reasons: tuple[str, ...]  # why it does not stand (empty when it stands)
    stance_base_height_m: float
    base_height_m: float
    tilt_deg: float  # largest tilt over the window
    base_speed_m_s: float
    joints: tuple[JointLoad, ...]
    warnings: tuple[str, ...]
    notices: tuple[str, ...] = ()  # what model preparation changed (robots.mjcf)

    @property
    def worst(self) -> JointLoad:
        """The joint with the least margin (highest holding load)."""
        return max(self.joints, key=lambda j: j.load_fraction)


def _joint_list(names: list[str], total: int) -> str:
    return f"all {total} joints" if len(names) == total else ", ".join(names)


def _tilt_deg(xmat: np.ndarray) -> float:
    return math.degrees(math.acos(float(np.clip(xmat.reshape(3, 3)[2, 2], -1.0, 1.0))))


def check_stand(robot: Robot, *, duration_s: float = 2.0) -> StandReport:
    """Stand the robot on its servos for `duration_s` and measure (see module docstring)."""
    if not (math.isfinite(duration_s) and 0.2 <= duration_s <= 60.0):
        raise SimConfigError(f"stand duration must be in [0.2, 60] s, got {duration_s!r}")
    sim = build_sim_model(robot)
    model = sim.model
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, sim.initial_state(), mujoco.mjtState.mjSTATE_FULLPHYSICS)
    data.ctrl[: sim.n_joints] = robot.nominal_stance_rad
    mujoco.mj_forward(model, data)
    n_steps = max(1, round(duration_s / model.opt.timestep))
    start = int(n_steps * (1.0 - WINDOW_FRACTION))
    emf = sim.back_emf_nm_s_per_rad
    root = sim.root_body
    com0 = float(data.subtree_com[root][2])
    heights, coms, tilts, speeds, torques = [], [], [], [], []
    diverged = False
    for step in range(n_steps):
        mujoco.mj_step(model, data)
        if not np.all(np.isfinite(data.qpos)):
            diverged = True
            break
        if step >= start:
            heights.append(float(data.xpos[root][2]))
            coms.append(float(data.subtree_com[root][2]))
            tilts.append(_tilt_deg(data.xmat[sim.root_body]))
            speeds.append(float(np.linalg.norm(data.qvel[0:3])))
            qd = data.qvel[sim.dof_adr]
            torques.append(data.actuator_force[: sim.n_joints] - emf * qd)
    stall = sim.stall_torque_nm
    reasons: list[str] = []
    warnings: list[str] = []
    if diverged or not heights:
        reasons.append("the simulation diverged (NaN): check masses, inertias and armature")
        hold = np.full(sim.n_joints, np.nan)
        height = tilt = speed = float("nan")
    else:
        hold = np.mean(torques, axis=0)
        height, tilt, speed = float(np.mean(heights)), float(max(tilts)), float(np.mean(speeds))
        com = float(np.mean(coms))
        if tilt > MAX_TILT_DEG:
            reasons.append(f"it tips over (tilt {tilt:.1f}° > {MAX_TILT_DEG:.0f}°)")
        if com0 - com > MAX_DROP_FRACTION * com0:
            reasons.append(
                f"it sinks: its centre of mass drops from {com0:.3f} m to {com:.3f} m (more "
                f"than {MAX_DROP_FRACTION:.0%})"
            )
        if speed > MAX_SPEED_M_S:
            reasons.append(f"it does not come to rest (base speed {speed:.2f} m/s)")
        touching = _non_foot_contacts(sim, data)
        if touching:
            reasons.append(f"not only the feet touch the ground: {', '.join(touching)}")
        for j, frac in zip(robot.joints, np.abs(hold) / stall, strict=True):
            if frac >= 0.999:
                reasons.append(f"servo {j.name} is saturated (holding at {frac:.0%} of stall)")
    budget = {b.joint: b for b in damping_budget(robot)}
    joints = []
    for k, j in enumerate(robot.joints):
        b = budget[j.name]
        stall_nm = j.servo.stall_torque_nm
        joints.append(
            JointLoad(
                name=j.name,
                servo=j.servo.name,
                stall_torque_nm=stall_nm,
                holding_torque_nm=float(hold[k]),
                load_fraction=float(abs(hold[k]) / stall_nm),
                damping_nm_s_per_rad=b.mjcf_damping_nm_s_per_rad,
                back_emf_nm_s_per_rad=b.back_emf_nm_s_per_rad,
                armature_kg_m2=b.armature_kg_m2,
                damping_share=b.damping_share,
                armature_share=b.armature_share,
                budget_flag=b.flag,
            )
        )
    flagged = [j for j in joints if j.budget_flag]
    if flagged:
        first = flagged[0].budget_flag
        more = f" (and {len(flagged) - 1} more joints)" if len(flagged) > 1 else ""
        warnings.append(f"{flagged[0].name}: {first}{more}")
    return StandReport(
        robot=robot.name,
        mass_kg=robot.mass_kg,
        legs=len(robot.legs),
        duration_s=n_steps * float(model.opt.timestep),
        stands=not reasons,
        reasons=tuple(reasons),
        stance_base_height_m=robot.stance_base_height_m,
        base_height_m=height,
        tilt_deg=tilt,
        base_speed_m_s=speed,
        joints=tuple(joints),
        warnings=tuple(warnings),
        notices=robot.prepared.notices if robot.prepared is not None else (),
    )


def _non_foot_contacts(sim: SimModel, data: mujoco.MjData) -> list[str]:
    model = sim.model
    foot_bodies = {
        int(model.site_bodyid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)])
        for leg in sim.robot.legs
    }
    names = set()
    for c in data.contact[: data.ncon]:
        for g, other in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
            body = int(model.geom_bodyid[g])
            if model.geom_bodyid[other] == 0 and body != 0 and body not in foot_bodies:
                names.add(
                    mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}"
                )
    return sorted(names)

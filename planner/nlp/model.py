"""Symbolic (CasADi) rigid-body model of a floating-base legged robot, built from its MJCF tree.

Everything comes from `mujoco.MjModel`: the body tree (parents, offsets), hinge axes/anchors and
reference angles, masses, COM offsets and principal inertias, joint armature (reflected servo
inertia), damping and stiffness. Nothing here knows about legs or joint names beyond what the
`Robot` provides (its joint order and foot sites).

Generalised coordinates (the planner's convention, see `planner.nlp.rotations`):
``q = (x, y, z, roll, pitch, yaw, q_1 … q_J)`` with the joints in `Robot.joints` order.
Velocities/accelerations are passed MuJoCo-style for the base — linear velocity of the base
origin in the world frame and angular velocity in the world frame — plus joint rates.

Inverse dynamics is the recursive Newton–Euler algorithm in world-frame Plücker coordinates
(Featherstone, *Rigid Body Dynamics Algorithms*, §5.3 with the world origin as reference point):
forward pass for spatial velocities/accelerations with gravity as a fictitious base acceleration,
backward pass for subtree wrenches with the contact forces at the foot sites subtracted. It returns
the generalised forces in MuJoCo's coordinates: base rows = world force and body-frame torque about
the base origin (MuJoCo freejoint), joint rows = joint torques incl. armature·q̈ + damping·q̇ +
stiffness·(q − q_spring) — exactly what `mujoco.mj_inverse` reports with the same external forces.
The six base rows being zero is W&P 2009 eqs 7-8 (whole-body Newton–Euler balance).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import mujoco
import numpy as np

from planner.errors import ModelError
from planner.nlp.rotations import omega_world_matrix, rpy_to_matrix
from robots import Robot
from robots.rotation import inertia_tensor, quat_to_mat


@dataclass(frozen=True)
class _Joint:
    index: int  # position in Robot.joints order
    pos_local: np.ndarray  # anchor in the body frame
    axis_local: np.ndarray  # unit axis in the body frame
    ref_rad: float  # qpos0: angle at which the body has its MJCF pose


@dataclass(frozen=True)
class _Body:
    parent: int  # index into the body list, -1 for the floating base
    pos: np.ndarray
    rot: np.ndarray  # 3×3 offset rotation relative to the parent
    joints: tuple[_Joint, ...]
    mass_kg: float
    com_local: np.ndarray
    inertia_local: np.ndarray  # 3×3 about the COM in the body frame


def _hat(v: Any) -> Any:
    return ca.vertcat(
        ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0)
    )


def _axis_rotation(axis: np.ndarray, angle: Any) -> Any:
    """Rodrigues: rotation by `angle` about the constant unit `axis` (zeros simplify away in SX)."""
    k = ca.DM(_hat_np(axis))
    return ca.DM.eye(3) + ca.sin(angle) * k + (1 - ca.cos(angle)) * (k @ k)


def _hat_np(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]], dtype=float)


class RobotModel:
    """The symbolic model of one robot; CasADi Functions are built once in `__init__`.

    Attributes: `n_joints`, `n_feet`, `n_bodies`, `foot_radius_m`, `total_mass_kg`,
    `gravity_m_s2` (3,), and the Functions `fk`, `inverse_dynamics`, `momentum` (see their docs
    in `_build_functions`).
    """

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        mj = robot.mj_model()  # the prepared model (robots.mjcf), shared with sim
        self.mj_model = mj
        self.n_joints = len(robot.joints)
        self.n_feet = len(robot.legs)
        self.foot_radius_m = float(robot.foot_radius_m)
        self.gravity_m_s2 = np.array(mj.opt.gravity, dtype=float)
        self._bodies, self._sites = self._read_tree(mj, robot)
        # flat feet (`robots.sole`): the contact point is the sole centre, not the foot site
        from robots.sole import sole_frame_local

        #: indices (Robot.legs order) of the flat feet; their contact carries a moment too
        self.flat_feet = tuple(i for i, leg in enumerate(robot.legs) if leg.is_flat)
        self._sole_rot_local: list[np.ndarray] = []
        for i in self.flat_feet:
            centre, rot = sole_frame_local(mj, robot.legs[i])
            self._sites[i] = (self._sites[i][0], centre)
            self._sole_rot_local.append(rot)
        self.n_bodies = len(self._bodies)
        self.total_mass_kg = float(sum(b.mass_kg for b in self._bodies))
        self.armature = np.zeros(6 + self.n_joints)
        self.damping = np.zeros(6 + self.n_joints)
        self.stiffness = np.zeros(self.n_joints)
        self.spring_ref_rad = np.zeros(self.n_joints)
        self.joint_qposadr = np.zeros(self.n_joints, dtype=int)
        self.joint_dofadr = np.zeros(self.n_joints, dtype=int)
        free = 0  # the freejoint (checked by robots.load)
        self.armature[:6] = mj.dof_armature[mj.jnt_dofadr[free] : mj.jnt_dofadr[free] + 6]
        self.damping[:6] = mj.dof_damping[mj.jnt_dofadr[free] : mj.jnt_dofadr[free] + 6]
        for i, j in enumerate(robot.joints):
            jid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            dof, qadr = int(mj.jnt_dofadr[jid]), int(mj.jnt_qposadr[jid])
            self.joint_qposadr[i], self.joint_dofadr[i] = qadr, dof
            self.armature[6 + i] = mj.dof_armature[dof]
            self.damping[6 + i] = mj.dof_damping[dof]
            self.stiffness[i] = mj.jnt_stiffness[jid]
            self.spring_ref_rad[i] = mj.qpos_spring[qadr]
        self._build_functions()
        self.foot_distance_m = self._foot_distances()

    # -- reading the MJCF --------------------------------------------------------------------

    @staticmethod
    def _read_tree(
        mj: mujoco.MjModel, robot: Robot
    ) -> tuple[list[_Body], list[tuple[int, np.ndarray]]]:
        root = int(mj.jnt_bodyid[0])
        if int(mj.body_parentid[root]) != 0:
            raise ModelError(f"{robot.mjcf_path}: the freejoint body must be a child of the world")
        joint_index = {name: i for i, name in enumerate(robot.joint_names)}
        index: dict[int, int] = {}
        bodies: list[_Body] = []
        for b in range(root, mj.nbody):  # MuJoCo orders parents before children
            parent = int(mj.body_parentid[b])
            if b != root and parent not in index:
                continue  # not in the robot's tree (e.g. props welded to the world)
            joints: list[_Joint] = []
            for jid in range(int(mj.body_jntadr[b]), int(mj.body_jntadr[b] + mj.body_jntnum[b])):
                if b == root:
                    if mj.body_jntnum[b] != 1:
                        raise ModelError(
                            f"{robot.mjcf_path}: the root body may only have its freejoint"
                        )
                    continue
                name = mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_JOINT, jid)
                if mj.jnt_type[jid] != mujoco.mjtJoint.mjJNT_HINGE or name not in joint_index:
                    raise ModelError(
                        f"{robot.mjcf_path}: joint {name!r}: only servo hinge joints are supported"
                    )
                axis = np.array(mj.jnt_axis[jid], dtype=float)
                joints.append(
                    _Joint(
                        joint_index[name],
                        np.array(mj.jnt_pos[jid], dtype=float),
                        axis / np.linalg.norm(axis),
                        float(mj.qpos0[mj.jnt_qposadr[jid]]),
                    )
                )
            index[b] = len(bodies)
            bodies.append(
                _Body(
                    parent=-1 if b == root else index[parent],
                    pos=np.array(mj.body_pos[b], dtype=float),
                    rot=quat_to_mat(mj.body_quat[b]),
                    joints=tuple(joints),
                    mass_kg=float(mj.body_mass[b]),
                    com_local=np.array(mj.body_ipos[b], dtype=float),
                    inertia_local=inertia_tensor(mj.body_iquat[b], mj.body_inertia[b]),
                )
            )
        sites: list[tuple[int, np.ndarray]] = []
        for leg in robot.legs:
            sid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
            body = int(mj.site_bodyid[sid])
            if body not in index:
                raise ModelError(
                    f"{robot.mjcf_path}: foot site {leg.foot_site!r} is not on the robot"
                )
            sites.append((index[body], np.array(mj.site_pos[sid], dtype=float)))
        return bodies, sites

    def _foot_distances(self) -> np.ndarray:
        """Per body, the distance from its origin to the nearest foot site it carries, in the
        nominal stance (inf for bodies that carry no foot). A body closer to its foot than the
        body clearance (an ankle or sole link) has its height set by the foot's own contact
        constraints; `planner.nlp.constraints` leaves it out of the body clearance (W&P eq 1)."""
        feet_dm, origins_dm, _ = self.fk(
            ca.DM.zeros(3), ca.DM.zeros(3), ca.DM(self.robot.nominal_stance_rad)
        )
        feet, origins = np.asarray(feet_dm, dtype=float), np.asarray(origins_dm, dtype=float)
        out = np.full(self.n_bodies, np.inf)
        for f, (body, _) in enumerate(self._sites):
            b = body
            while b >= 0:
                out[b] = min(out[b], float(np.linalg.norm(origins[:, b] - feet[:, f])))
                b = self._bodies[b].parent
        return out

    # -- symbolic functions ------------------------------------------------------------------

    def _frames(
        self, base_pos: Any, base_rpy: Any, qj: Any
    ) -> tuple[list[Any], list[Any], list[list[tuple[Any, Any]]]]:
        """World rotation and origin of every body, and each hinge's (world anchor, world axis)."""
        rots: list[Any] = []
        origins: list[Any] = []
        hinges: list[list[tuple[Any, Any]]] = []
        for body in self._bodies:
            if body.parent < 0:
                rot, pos = rpy_to_matrix(base_rpy), base_pos
            else:
                rp, pp = rots[body.parent], origins[body.parent]
                rot, pos = rp @ ca.DM(body.rot), pp + rp @ ca.DM(body.pos)
            axes: list[tuple[Any, Any]] = []
            for jt in body.joints:
                anchor = pos + rot @ ca.DM(jt.pos_local)
                axes.append((anchor, rot @ ca.DM(jt.axis_local)))
                rot = rot @ _axis_rotation(jt.axis_local, qj[jt.index] - jt.ref_rad)
                pos = anchor - rot @ ca.DM(jt.pos_local)
            rots.append(rot)
            origins.append(pos)
            hinges.append(axes)
        return rots, origins, hinges

    def _velocities(
        self,
        base_pos: Any,
        rots_hinges: list[list[tuple[Any, Any]]],
        v_base: Any,
        w_base: Any,
        qdj: Any,
        a_base: Any,
        dw_base: Any,
        qddj: Any,
    ) -> tuple[list[Any], list[Any]]:
        """Spatial velocity/acceleration (ω, v_O) per body, world-origin Plücker coordinates.

        The acceleration of the root includes −g (gravity as a fictitious upward acceleration).
        """
        vel: list[Any] = []
        acc: list[Any] = []
        grav = ca.vertcat(ca.DM.zeros(3), -ca.DM(self.gravity_m_s2))
        for i, body in enumerate(self._bodies):
            if body.parent < 0:
                v = ca.vertcat(w_base, v_base - ca.cross(w_base, base_pos))
                a = (
                    ca.vertcat(
                        dw_base, a_base - ca.cross(dw_base, base_pos) - ca.cross(w_base, v_base)
                    )
                    + grav
                )
            else:
                v, a = vel[body.parent], acc[body.parent]
            for jt, (anchor, axis) in zip(body.joints, rots_hinges[i], strict=False):
                s = ca.vertcat(axis, ca.cross(anchor, axis))
                v = v + s * qdj[jt.index]
                a = a + s * qddj[jt.index] + _cross_motion(v, s * qdj[jt.index])
            vel.append(v)
            acc.append(a)
        return vel, acc

    def _inertia_world(self, rot: Any, origin: Any, body: _Body) -> tuple[Any, Any]:
        com = origin + rot @ ca.DM(body.com_local)
        return com, rot @ ca.DM(body.inertia_local) @ rot.T

    def _build_functions(self) -> None:
        nj, nf = self.n_joints, self.n_feet
        pos, rpy = ca.SX.sym("base_pos", 3), ca.SX.sym("base_rpy", 3)
        qj, qdj, qddj = ca.SX.sym("q", nj), ca.SX.sym("qd", nj), ca.SX.sym("qdd", nj)
        v_b, w_b = ca.SX.sym("v_base", 3), ca.SX.sym("w_base", 3)
        a_b, dw_b = ca.SX.sym("a_base", 3), ca.SX.sym("dw_base", 3)
        forces = ca.SX.sym("f_feet", 3, nf)
        moments = ca.SX.sym("m_feet", 3, nf)  # contact moments about the contact points
        rots, origins, hinges = self._frames(pos, rpy, qj)
        feet = ca.horzcat(*[origins[b] + rots[b] @ ca.DM(p) for b, p in self._sites])
        body_origins = ca.horzcat(*origins)
        coms, inertias = zip(
            *(
                self._inertia_world(r, o, b)
                for r, o, b in zip(rots, origins, self._bodies, strict=True)
            ),
            strict=True,
        )
        mass = self.total_mass_kg
        weighted = (b.mass_kg * c for b, c in zip(self._bodies, coms, strict=True))
        com = sum(weighted, ca.SX.zeros(3)) / mass
        #: soles(base_pos, base_rpy, q) -> 3×3·F_flat world rotations of the flat feet's sole
        #: frames, side by side (the sole centres are `fk`'s feet columns of those feet)
        self.soles = ca.Function(
            "soles",
            [pos, rpy, qj],
            [
                ca.horzcat(
                    *[
                        rots[self._sites[i][0]] @ ca.DM(r)
                        for i, r in zip(self.flat_feet, self._sole_rot_local, strict=True)
                    ]
                )
                if self.flat_feet
                else ca.SX.zeros(3, 0)
            ],
            ["base_pos", "base_rpy", "q"],
            ["rot"],
        )
        #: fk(base_pos, base_rpy, q) -> (feet 3×F contact points: foot-site centres, sole
        #: centres for flat feet; body_origins 3×B, com 3)
        self.fk = ca.Function(
            "fk",
            [pos, rpy, qj],
            [feet, body_origins, com],
            ["base_pos", "base_rpy", "q"],
            ["feet", "body_origins", "com"],
        )
        vel, acc = self._velocities(pos, hinges, v_b, w_b, qdj, a_b, dw_b, qddj)
        lin = ca.SX.zeros(3)
        ang_o = ca.SX.zeros(3)
        wrench: list[Any] = []
        for body, c, inertia, v, a in zip(self._bodies, coms, inertias, vel, acc, strict=False):
            h_lin, h_ang = _momentum(body.mass_kg, c, inertia, v)
            lin, ang_o = lin + h_lin, ang_o + h_ang
            f_lin, f_ang = _momentum(body.mass_kg, c, inertia, a)  # I·A
            w, vo = v[:3], v[3:]
            wrench.append(
                ca.vertcat(
                    f_ang + ca.cross(w, h_ang) + ca.cross(vo, h_lin), f_lin + ca.cross(w, h_lin)
                )
            )
        body_wrench = wrench

        def generalised_forces(contact_moments: Any) -> list[Any]:
            """[base_rows, joint_rows] with the contact forces (and moments, unless None)."""
            wrench = list(body_wrench)
            for f, (b, _) in enumerate(self._sites):
                foot = feet[:, f]
                ang = ca.cross(foot, forces[:, f])
                if contact_moments is not None:
                    ang = ang + contact_moments[:, f]
                wrench[b] = wrench[b] - ca.vertcat(ang, forces[:, f])
            for i in reversed(range(self.n_bodies)):  # backward pass: subtree wrenches
                parent = self._bodies[i].parent
                if parent >= 0:
                    wrench[parent] = wrench[parent] + wrench[i]
            tau = [ca.SX(0)] * nj
            for i, body in enumerate(self._bodies):
                for jt, (anchor, axis) in zip(body.joints, hinges[i], strict=False):
                    tau[jt.index] = ca.dot(ca.vertcat(axis, ca.cross(anchor, axis)), wrench[i])
            root = wrench[0]
            base_force = root[3:]
            base_torque = rots[0].T @ (root[:3] - ca.cross(pos, base_force))
            arm, damp = self.armature, self.damping
            joint_rows = (
                ca.vertcat(*tau)
                + ca.DM(arm[6:]) * qddj
                + ca.DM(damp[6:]) * qdj
                + ca.DM(self.stiffness) * (qj - ca.DM(self.spring_ref_rad))
            )
            base_acc_body = ca.vertcat(a_b, rots[0].T @ dw_b)
            base_vel_body = ca.vertcat(v_b, rots[0].T @ w_b)
            base_rows = (
                ca.vertcat(base_force, base_torque)
                + ca.DM(arm[:6]) * base_acc_body
                + ca.DM(damp[:6]) * base_vel_body
            )
            return [base_rows, joint_rows]

        args = [pos, rpy, qj, v_b, w_b, qdj, a_b, dw_b, qddj, forces]
        names = [
            "base_pos",
            "base_rpy",
            "q",
            "v_base",
            "w_base",
            "qd",
            "a_base",
            "dw_base",
            "qdd",
            "f_feet",
        ]
        #: inverse_dynamics_wrench(..., f_feet, m_feet) -> as `inverse_dynamics` with contact
        #: wrenches: world force f and world moment m about each contact point (flat feet) —
        #: MuJoCo's qfrc_inverse minus Jᵀ(f, m) with the contact point's Jacobian
        self.inverse_dynamics_wrench = ca.Function(
            "inverse_dynamics_wrench",
            [*args, moments],
            generalised_forces(moments),
            [*names, "m_feet"],
            ["base_rows", "tau"],
        )
        #: inverse_dynamics(...) -> (base_rows 6: world force + body-frame torque about the base
        #: origin, joint_rows J: joint torques [N·m]) — MuJoCo's qfrc_inverse minus Jᵀf
        self.inverse_dynamics = ca.Function(
            "inverse_dynamics", args, generalised_forces(None), names, ["base_rows", "tau"]
        )
        ang_com = ang_o - ca.cross(com, lin)
        #: momentum(base_pos, base_rpy, q, v_base, w_base, qd) -> (linear [kg·m/s], angular about
        #: the COM [kg·m²/s], com [m])
        self.momentum = ca.Function(
            "momentum",
            [pos, rpy, qj, v_b, w_b, qdj],
            [lin, ang_com, com],
            names[:6],
            ["linear", "angular_com", "com"],
        )
        rdot = ca.SX.sym("rpy_dot", 3)
        rddot = ca.SX.sym("rpy_ddot", 3)
        e_w = omega_world_matrix(rpy)
        omega = e_w @ rdot
        domega = e_w @ rddot + ca.jtimes(omega, rpy, rdot)
        #: base_rates(rpy, rpy_dot, rpy_ddot) -> (ω_world, ω̇_world) for roll/pitch/yaw rates
        self.base_rates = ca.Function(
            "base_rates",
            [rpy, rdot, rddot],
            [omega, domega],
            ["rpy", "rpy_dot", "rpy_ddot"],
            ["w_world", "dw_world"],
        )

    # -- numeric helpers ---------------------------------------------------------------------

    def mujoco_qpos(self, base_pose: np.ndarray, q_rad: np.ndarray) -> np.ndarray:
        """MuJoCo qpos for a planner state (base x,y,z,roll,pitch,yaw + joints in Robot order)."""
        from planner.nlp.rotations import rpy_to_quat_np

        qpos = np.array(self.mj_model.qpos0, dtype=float)
        qpos[0:3] = base_pose[:3]
        qpos[3:7] = rpy_to_quat_np(base_pose[3:6])
        qpos[self.joint_qposadr] = q_rad
        return qpos

    def foot_body_index(self, foot: int) -> int:
        """Index (in `fk`'s body_origins columns) of the body carrying foot `foot`."""
        return self._sites[foot][0]

    def body_parent(self, body: int) -> int:
        """Index of a body's parent, −1 for the floating base."""
        return self._bodies[body].parent

    def joint_limits_rad(self) -> tuple[np.ndarray, np.ndarray]:
        return (
            np.array([j.lower_rad for j in self.robot.joints]),
            np.array([j.upper_rad for j in self.robot.joints]),
        )


def _cross_motion(v: Any, m: Any) -> Any:
    """Spatial motion cross product v ×ₘ m for (ω, v_O) 6-vectors."""
    return ca.vertcat(ca.cross(v[:3], m[:3]), ca.cross(v[:3], m[3:]) + ca.cross(v[3:], m[:3]))


def _momentum(mass: float, com: Any, inertia: Any, v: Any) -> tuple[Any, Any]:
    """Spatial inertia times a motion vector (ω, v_O): (linear, angular about the world origin)."""
    lin = mass * (v[3:] + ca.cross(v[:3], com))
    return lin, inertia @ v[:3] + ca.cross(com, lin)

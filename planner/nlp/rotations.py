"""Base orientation: roll/pitch/yaw and its maps to MuJoCo's freejoint quaternion.

Convention (documented once, used everywhere in the planner and in gait files' ``base_pose``):
``R = Rz(yaw) · Ry(pitch) · Rx(roll)`` — intrinsic z-y'-x'' (Tait–Bryan, aerospace) angles;
R maps body-frame vectors to the world frame, like MuJoCo's ``xmat``.

MuJoCo's freejoint stores the orientation as the quaternion ``qpos[3:7] = (w, x, y, z)`` of R and
its angular velocity as ``qvel[3:6] = ω_body`` (body frame). With ``ρ = (roll, pitch, yaw)``:
``ω_world = E_w(ρ) ρ̇``, ``ω_body = Rᵀ ω_world``. The functions accept numpy arrays or CasADi
symbols (the `ops` module argument picks the backend).
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np


def rot_x(a: Any) -> Any:
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_y(a: Any) -> Any:
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def rot_z(a: Any) -> Any:
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def rpy_to_matrix(rpy: Any) -> Any:
    """CasADi: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return rot_z(rpy[2]) @ rot_y(rpy[1]) @ rot_x(rpy[0])


def omega_world_matrix(rpy: Any) -> Any:
    """CasADi: E_w(ρ) with ω_world = E_w ρ̇ (columns: roll, pitch, yaw rate contributions)."""
    ez = ca.DM([0.0, 0.0, 1.0])
    rz = rot_z(rpy[2])
    return ca.horzcat(rz @ rot_y(rpy[1]) @ ca.DM([1.0, 0.0, 0.0]), rz @ ca.DM([0.0, 1.0, 0.0]), ez)


def rpy_to_matrix_np(rpy: np.ndarray) -> np.ndarray:
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def rpy_to_quat_np(rpy: np.ndarray) -> np.ndarray:
    """MuJoCo quaternion (w, x, y, z) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    hr, hp, hy = (0.5 * float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = (
        math.cos(hr),
        math.sin(hr),
        math.cos(hp),
        math.sin(hp),
        math.cos(hy),
        math.sin(hy),
    )
    return np.array(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


def omega_world_matrix_np(rpy: np.ndarray) -> np.ndarray:
    """numpy: E_w(ρ), the columns being the world axes of the roll, pitch and yaw rotations."""
    _, p, y = (float(v) for v in rpy)
    cp, sp, cy, sy = math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, -sy, 0.0], [sy * cp, cy, 0.0], [-sp, 0.0, 1.0]])


def rpy_rates_to_body_omega_np(rpy: np.ndarray, rpy_dot: np.ndarray) -> np.ndarray:
    """ω_body = Rᵀ E_w(ρ) ρ̇ — MuJoCo's freejoint qvel[3:6]."""
    return rpy_to_matrix_np(rpy).T @ omega_world_matrix_np(rpy) @ np.asarray(rpy_dot)

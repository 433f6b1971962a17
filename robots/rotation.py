"""Rotations and inertia tensors from MuJoCo's quaternions (w, x, y, z), as numpy arrays.

Pure numpy + MuJoCo: shared by the robot loader (flat soles, scaffolds), the planner's symbolic
model and the bodies the design search and retargeting write.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np


def quat_to_mat(quat: Any) -> np.ndarray:
    """The 3×3 rotation matrix of the unit quaternion `quat` (w, x, y, z; `mju_quat2Mat`)."""
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, np.asarray(quat, dtype=float))
    return out.reshape(3, 3)


def inertia_tensor(iquat: Any, principal: Any) -> np.ndarray:
    """The 3×3 inertia tensor in the body frame from MuJoCo's principal axes and moments
    (``body_iquat``, ``body_inertia``): R·diag(I)·Rᵀ."""
    rot = quat_to_mat(iquat)
    return rot @ np.diag(np.asarray(principal, dtype=float)) @ rot.T

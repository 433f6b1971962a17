"""`robots.rotation`: MuJoCo quaternions to matrices, principal inertias to body-frame tensors."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from robots.rotation import inertia_tensor, quat_to_mat


def test_a_quarter_turn_about_z_maps_x_to_y() -> None:
    half = math.pi / 4
    rot = quat_to_mat([math.cos(half), 0.0, 0.0, math.sin(half)])
    np.testing.assert_allclose(rot @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-15)


def test_the_tensor_mujoco_diagonalises_comes_back() -> None:
    """A body given a full inertia tensor: MuJoCo stores its principal axes and moments, and
    `inertia_tensor` rebuilds the tensor written."""
    tensor = np.array([[0.004, 0.0005, -0.0002], [0.0005, 0.003, 0.0003],
                       [-0.0002, 0.0003, 0.002]])
    full = " ".join(f"{v:.6g}" for v in tensor[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]])
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/>"
        f'<inertial pos="0 0 0" mass="1" fullinertia="{full}"/>'
        "</body></worldbody></mujoco>")
    np.testing.assert_allclose(inertia_tensor(model.body_iquat[1], model.body_inertia[1]), tensor,
                               atol=1e-12)

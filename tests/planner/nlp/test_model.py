"""The CasADi model against MuJoCo: inverse dynamics (mj_inverse − Jᵀf), FK, momentum."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import robots
from planner.nlp.model import RobotModel
from planner.nlp.rotations import (
    omega_world_matrix_np,
    rpy_rates_to_body_omega_np,
    rpy_to_matrix_np,
    rpy_to_quat_np,
)


@pytest.fixture(scope="module", params=["quad12", "hex18"])
def model(request: pytest.FixtureRequest) -> RobotModel:
    return RobotModel(robots.load(request.param))


def _random_state(m: RobotModel, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    base = np.r_[rng.normal(size=2) * 0.2, 0.15 + 0.05 * rng.normal(), rng.uniform(-0.5, 0.5, 3)]
    q = rng.uniform(*m.joint_limits_rad())
    nv = 6 + m.n_joints
    return (
        base,
        q,
        rng.normal(size=nv) * 2.0,
        rng.normal(size=nv) * 20.0,
        rng.normal(size=(3, m.n_feet)) * 8.0,
    )


def _site_ids(m: RobotModel) -> list[int]:
    return [
        mujoco.mj_name2id(m.mj_model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
        for leg in m.robot.legs
    ]


def _mj_dofs(m: RobotModel) -> np.ndarray:
    return np.r_[np.arange(6), m.joint_dofadr]


def test_inverse_dynamics_matches_mj_inverse(model: RobotModel) -> None:
    mj = model.mj_model
    data = mujoco.MjData(mj)
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT  # contacts are our explicit forces
    rng = np.random.default_rng(4)
    dofs = _mj_dofs(model)
    for _ in range(20):
        base, q, vel, acc, forces = _random_state(model, rng)
        data.qpos[:] = model.mujoco_qpos(base, q)
        data.qvel[dofs], data.qacc[dofs] = vel, acc
        mujoco.mj_inverse(mj, data)
        expected = data.qfrc_inverse.copy()
        for f, sid in enumerate(_site_ids(model)):
            jac = np.zeros((3, mj.nv))
            mujoco.mj_jacSite(mj, data, jac, None, sid)
            expected -= jac.T @ forces[:, f]
        rot = rpy_to_matrix_np(base[3:])
        base_rows, tau = model.inverse_dynamics(
            base[:3],
            base[3:],
            q,
            vel[:3],
            rot @ vel[3:6],
            vel[6:],
            acc[:3],
            rot @ acc[3:6],
            acc[6:],
            forces,
        )
        ours = np.r_[np.asarray(base_rows).ravel(), np.asarray(tau).ravel()]
        ref = expected[dofs]
        assert np.max(np.abs(ours - ref)) <= 1e-6 * max(1.0, np.max(np.abs(ref)))


def test_fk_com_and_momentum_match_mujoco(model: RobotModel) -> None:
    mj = model.mj_model
    data = mujoco.MjData(mj)
    rng = np.random.default_rng(5)
    dofs = _mj_dofs(model)
    root = int(mj.jnt_bodyid[0])
    for _ in range(20):
        base, q, vel, _, _ = _random_state(model, rng)
        data.qpos[:] = model.mujoco_qpos(base, q)
        data.qvel[dofs] = vel
        mujoco.mj_forward(mj, data)
        mujoco.mj_subtreeVel(mj, data)
        feet, _, com = model.fk(base[:3], base[3:], q)
        np.testing.assert_allclose(np.asarray(feet).T, data.site_xpos[_site_ids(model)], atol=1e-12)
        np.testing.assert_allclose(np.asarray(com).ravel(), data.subtree_com[root], atol=1e-12)
        rot = rpy_to_matrix_np(base[3:])
        lin, ang, _ = model.momentum(base[:3], base[3:], q, vel[:3], rot @ vel[3:6], vel[6:])
        np.testing.assert_allclose(
            np.asarray(lin).ravel(), data.subtree_linvel[root] * model.total_mass_kg, atol=1e-10
        )
        np.testing.assert_allclose(np.asarray(ang).ravel(), data.subtree_angmom[root], atol=1e-10)


def test_rpy_conventions_match_mujoco_quaternion() -> None:
    rng = np.random.default_rng(6)
    for _ in range(20):
        rpy = rng.uniform(-1.0, 1.0, 3)
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, rpy_to_quat_np(rpy))
        np.testing.assert_allclose(mat.reshape(3, 3), rpy_to_matrix_np(rpy), atol=1e-12)
        # ω_world = E_w ρ̇: compare with the finite-difference rotation rate
        rate, h = rng.normal(size=3), 1e-6
        r_dot = (rpy_to_matrix_np(rpy + h * rate) - rpy_to_matrix_np(rpy - h * rate)) / (2 * h)
        w_hat = r_dot @ rpy_to_matrix_np(rpy).T
        w = np.array([w_hat[2, 1], w_hat[0, 2], w_hat[1, 0]])
        np.testing.assert_allclose(omega_world_matrix_np(rpy) @ rate, w, atol=1e-7)
        np.testing.assert_allclose(
            rpy_rates_to_body_omega_np(rpy, rate), rpy_to_matrix_np(rpy).T @ w, atol=1e-7
        )


def test_base_rates_chain_rule(model: RobotModel) -> None:
    rng = np.random.default_rng(7)
    rpy, rate, acc, h = rng.uniform(-0.5, 0.5, 3), rng.normal(size=3), rng.normal(size=3), 1e-5
    _, dw = model.base_rates(rpy, rate, acc)
    w_plus, _ = model.base_rates(rpy + h * rate + 0.5 * h * h * acc, rate + h * acc, acc)
    w_minus, _ = model.base_rates(rpy - h * rate + 0.5 * h * h * acc, rate - h * acc, acc)
    np.testing.assert_allclose(
        np.asarray(dw).ravel(),
        (np.asarray(w_plus) - np.asarray(w_minus)).ravel() / (2 * h),
        atol=1e-6,
    )


def test_ankle_and_sole_links_are_left_out_of_the_body_clearance() -> None:
    """A biped's ankle and sole links sit 1-3 cm above the ground in stance, under the 0.17·L
    body clearance: bound like the body they made every humanoid20 plan infeasible."""
    from planner.nlp.config import PlannerOptions
    from tests.zoo.fixtures import ZOO

    clearance = PlannerOptions().body_clearance_for
    biped = RobotModel(robots.load(ZOO / "humanoid20"))
    names = [
        mujoco.mj_id2name(biped.mj_model, mujoco.mjtObj.mjOBJ_BODY, b)
        for b in range(1, biped.mj_model.nbody)
    ]
    near = {n for n, d in zip(names, biped.foot_distance_m, strict=True)
            if d < clearance(biped.robot.leg_length_m)}
    assert near == {"l_ankle", "l_foot", "r_ankle", "r_foot"}
    for name in ("quad12", "hex18"):  # knees and tibias are far from their feet
        m = RobotModel(robots.load(name))
        assert np.all(m.foot_distance_m >= clearance(m.robot.leg_length_m))

"""Swing slack: joint shares of a forward foot motion, the fastest servo swing, the figure."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.stance import stance_kinematics
from planner.swing_slack import fastest_swing_s, joint_swings, swing_slack
from planner.templates import default_gait_for, make_schedule


def _bang_bang_s(dq: float, inertia: float, torque: float, w0: float, cap: float) -> float:
    """The bang-bang move integrated numerically: full envelope torque from rest until the
    speed cap or the midpoint, cruise, and the mirror image (time reversal) back to rest."""
    dt = 1e-6
    q = qd = t = 0.0
    while q < dq / 2 and qd < cap * w0:
        qd = min(qd + torque * (1 - qd / w0) / inertia * dt, cap * w0)
        q += qd * dt
        t += dt
    if q >= dq / 2:
        return 2 * t
    return 2 * t + (dq - 2 * q) / (cap * w0)


@pytest.mark.parametrize(("dq", "inertia", "cap"), [(0.6, 0.03, 1.0), (0.3, 0.002, 0.9),
                                                    (1.0, 0.03, 0.9)])
def test_fastest_swing_matches_a_brute_force_bang_bang(dq: float, inertia: float,
                                                       cap: float) -> None:
    torque, w0 = 1.5, 4.7
    got = fastest_swing_s(dq, inertia, torque, w0, cap)
    assert got == pytest.approx(_bang_bang_s(dq, inertia, torque, w0, cap), rel=2e-3)


def test_fastest_swing_limits() -> None:
    # a light rotor: the speed cap alone, Δq / (m_v·ω₀), plus a vanishing ramp
    assert fastest_swing_s(1.0, 1e-9, 1.0, 5.0, 0.9) == pytest.approx(1.0 / 4.5, rel=1e-4)
    # a heavy rotor on a fast motor: a double integrator, 2·√(Δq·I/τ)
    assert fastest_swing_s(0.5, 0.02, 1.0, 1e6) == pytest.approx(2 * math.sqrt(0.5 * 0.02),
                                                                 rel=1e-4)
    assert fastest_swing_s(0.0, 0.02, 1.0, 5.0) == 0.0
    with pytest.raises(PlannerConfigError):
        fastest_swing_s(0.5, 0.0, 1.0, 5.0)


@pytest.mark.parametrize("name", ["tests/zoo/knee8", "quad12"])
def test_excursion_moves_the_foot_forward(name: str) -> None:
    """Turning a leg's joints by their signed share moves the foot forward by that much:
    checked by finite differences of MuJoCo's forward kinematics."""
    bot = robots.load(name)
    stance = stance_kinematics(bot)
    model = stance.model
    base = mujoco.MjData(model)
    base.qpos[:] = stance.data.qpos
    mujoco.mj_forward(model, base)
    shares = {js.joint: js for js in joint_swings(bot)}
    leg = bot.legs[0]
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
    jac = np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, base, jac, None, site)
    names = [j.name for j in bot.joints]
    cols = [int(model.jnt_dofadr[stance.joint_ids[names.index(n)]]) for n in leg.joints]
    signed = np.linalg.pinv(jac[:, cols]) @ np.array([1.0, 0.0, 0.0])
    assert np.allclose(np.abs(signed), [shares[n].excursion_rad_per_m for n in leg.joints])
    step = 1e-4
    data = mujoco.MjData(model)
    data.qpos[:] = base.qpos
    for n, s in zip(leg.joints, signed, strict=True):
        data.qpos[model.jnt_qposadr[stance.joint_ids[names.index(n)]]] += s * step
    mujoco.mj_kinematics(model, data)
    moved = (data.site_xpos[site] - base.site_xpos[site]) / step
    assert moved[0] == pytest.approx(1.0, abs=2e-3)
    # and the inertia includes the rotor
    assert all(js.inertia_kg_m2 >= js.armature_kg_m2 > 0 for js in shares.values())


def test_swing_slack_figures() -> None:
    knee8 = robots.load("tests/zoo/knee8")
    quad = robots.load("quad12")
    walk = make_schedule(knee8, default_gait_for(knee8))
    tight = swing_slack(knee8, walk, 0.182)
    assert tight.ratio < 1 and tight.joint.endswith("hip")  # the heavy-rotor walk cannot swing
    assert tight.ratio == pytest.approx(tight.swing_s / tight.fastest_swing_s)
    assert swing_slack(quad, make_schedule(quad, "trot"), 0.25).ratio > 1
    # a lower duty and a longer period both give the swing more time
    longer = swing_slack(knee8, make_schedule(knee8, "walk", period_s=1.3, duty_factor=0.6), 0.182)
    assert longer.ratio > tight.ratio
    assert swing_slack(knee8, walk, 0.0).ratio == math.inf

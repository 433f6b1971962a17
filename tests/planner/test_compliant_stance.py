"""The stance-compliance rule (`planner.compliant_stance`): the figure λ = m·g·h/kp from the
body, and the defaults it asks for."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import robots
from planner.compliant_stance import (
    COMPLIANT_FORCE_RATE,
    COMPLIANT_LOOP_GAIN,
    StanceCompliance,
    compliant_stance_defaults,
    defaults_for_compliance,
    stance_compliance,
)
from planner.nlp.config import GRAVITY_M_S2, CostWeights
from planner.nlp.servo_loop import factory_servo_loops
from robots.gait import MAX_ENTRY_CYCLES
from robots.servo_params import ServoSetting
from tests.zoo.fixtures import ZOO


def _figure(loop_gain: float) -> StanceCompliance:
    """A stance of the given λ (1 kg, kp 10 N·m/rad)."""
    return StanceCompliance(1.0, loop_gain * 10.0 / GRAVITY_M_S2, "ankle", 10.0)


def test_loop_gain_and_amplification() -> None:
    c = StanceCompliance(2.0, 0.2, "ankle", 6.0)
    assert c.loop_gain == pytest.approx(2.0 * GRAVITY_M_S2 * 0.2 / 6.0)
    assert c.lean_amplification == pytest.approx(1.0 / (1.0 - c.loop_gain))
    assert _figure(1.2).lean_amplification == math.inf


@pytest.mark.parametrize("loop_gain", [0.0, 0.2, 0.49])
def test_a_stiff_stance_changes_nothing(loop_gain: float) -> None:
    d = defaults_for_compliance(_figure(loop_gain))
    assert not d.applies
    assert (d.force_rate_weights_per_t0, d.bounce_s2_m2, d.entry_cycles) == (None, None, 1)


def test_no_flat_foot_changes_nothing() -> None:
    d = defaults_for_compliance(None)
    assert not d.applies and d.entry_cycles == 1 and d.force_rate_weights_per_t0 is None
    assert "no flat foot" in d.summary()


@pytest.mark.parametrize(("loop_gain", "cycles"), [(0.5, 2), (0.61, 3), (0.7, 4), (0.9, 10)])
def test_a_compliant_stance_gets_ceil_amplification_cycles(loop_gain: float,
                                                           cycles: int) -> None:
    """K = ⌈1/(1 − λ)⌉ entry cycles, bounce weight K × default, the force-rate bound."""
    d = defaults_for_compliance(_figure(loop_gain))
    assert d.applies and d.entry_cycles == cycles
    assert d.bounce_s2_m2 == pytest.approx(cycles * CostWeights().bounce_s2_m2)
    assert d.force_rate_weights_per_t0 == COMPLIANT_FORCE_RATE


def test_a_stance_the_servo_cannot_hold_gets_the_longest_entry() -> None:
    assert defaults_for_compliance(_figure(1.0)).entry_cycles == MAX_ENTRY_CYCLES
    assert defaults_for_compliance(_figure(0.999)).entry_cycles == MAX_ENTRY_CYCLES


def test_point_feet_have_no_figure() -> None:
    for name in ("quad12", "hex18"):
        assert stance_compliance(robots.load(name)) is None
        assert not compliant_stance_defaults(robots.load(name)).applies


def test_the_builtin_biped_is_stiff_and_humanoid20_compliant() -> None:
    """The two flat-footed robots sit on either side of the threshold (docs/results/zoo_gaits.md,
    "Session 26"): the biped's XM430-W210 (kp 13.8 N·m/rad) holds its 1.55 kg at λ ≈ 0.20,
    humanoid20's XL430-W250 (kp 6.45) holds 1.89 kg at λ ≈ 0.61."""
    biped = stance_compliance(robots.load("biped"))
    h20 = stance_compliance(robots.load(ZOO / "humanoid20"))
    assert biped is not None and h20 is not None
    assert biped.ankle_joint.endswith("ankle_pitch") and h20.ankle_joint.endswith("ankle_pitch")
    assert biped.loop_gain == pytest.approx(0.20, abs=0.01)
    assert h20.loop_gain == pytest.approx(0.61, abs=0.01)
    assert biped.loop_gain < COMPLIANT_LOOP_GAIN <= h20.loop_gain
    d = compliant_stance_defaults(robots.load(ZOO / "humanoid20"))
    assert (d.entry_cycles, d.bounce_s2_m2, d.force_rate_weights_per_t0) == (3, 30.0, 10.0)
    assert not compliant_stance_defaults(robots.load("biped")).applies


def test_figure_from_mujoco_centre_of_mass_and_factory_gain() -> None:
    """h is MuJoCo's whole-body centre of mass (mj_comPos) over the foot site at the stance,
    kp the ankle pitch's factory P gain."""
    bot = robots.load(ZOO / "humanoid20")
    c = stance_compliance(bot)
    assert c is not None
    model = bot.mj_model()
    data = mujoco.MjData(model)
    for joint in bot.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
        data.qpos[model.jnt_qposadr[jid]] = joint.stance_rad
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    root = int(model.body_rootid[1])
    sole = max(float(data.site_xpos[model.site(leg.foot_site).id][2]) for leg in bot.legs)
    assert c.com_height_m == pytest.approx(float(data.subtree_com[root][2]) - sole, abs=1e-9)
    kp = {j.name: s.kp_nm_per_rad for j, s in zip(bot.joints, factory_servo_loops(bot),
                                                   strict=True)}
    assert c.ankle_kp_nm_per_rad == kp[c.ankle_joint]
    assert c.mass_kg == pytest.approx(float(np.sum(model.body_mass)), rel=1e-9)


def test_stronger_servos_stiffen_the_stance() -> None:
    """Identified servos 1.5× strong: kp × 1.5, λ / 1.5 (humanoid20: below the threshold)."""
    bot = robots.load(ZOO / "humanoid20")
    strong = tuple(ServoSetting(strength=1.5) for _ in bot.joints)
    base, stiff = stance_compliance(bot), stance_compliance(bot, strong)
    assert base is not None and stiff is not None
    assert stiff.loop_gain == pytest.approx(base.loop_gain / 1.5)
    assert not compliant_stance_defaults(bot, strong).applies

"""Feet keep apart (`planner.nlp.foot_separation`): the biped's planned soles never overlap."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.foot_separation import FOOT_GAP_LEG_LENGTHS, foot_pairs
from planner.nlp.model import RobotModel
from robots import ContactSchedule
from robots.sole import sole_pose_world

ZOO = Path(__file__).parents[2] / "zoo"


def test_only_feet_that_stand_close_get_a_row() -> None:
    biped = robots.load("biped")
    pairs = foot_pairs(RobotModel(biped))
    assert len(pairs) == 1
    i, j, u, need = pairs[0]
    assert (i, j) == (0, 1)
    np.testing.assert_allclose(u, [0.0, -1.0], atol=1e-9)  # left → right
    half_width = biped.legs[0].sole_half_extents_m[1]  # type: ignore[index]
    assert need == pytest.approx(min(2 * half_width + FOOT_GAP_LEG_LENGTHS * biped.leg_length_m,
                                     0.09))  # at most the stance separation (hips 90 mm apart)
    for name in ("quad12", "hex18"):  # their NLPs are unchanged: feet far apart
        assert foot_pairs(RobotModel(robots.load(name))) == ()
    assert foot_pairs(RobotModel(robots.load(ZOO / "star5"))) == ()


def _sole_rectangles(bot: robots.Robot, qpos: np.ndarray) -> list[np.ndarray]:
    model = bot.mj_model()
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    out = []
    for leg in bot.legs:
        centre, rot = sole_pose_world(model, data, leg)
        hl, hw = leg.sole_half_extents_m  # type: ignore[misc]
        corners = [centre + rot @ np.array([sx * hl, sy * hw, 0.0])
                   for sx in (-1, 1) for sy in (-1, 1)]
        out.append(np.array(corners)[:, :2])
    return out


def _overlap_along(a: np.ndarray, b: np.ndarray, axis: np.ndarray) -> float:
    pa, pb = a @ axis, b @ axis
    return float(min(pa.max(), pb.max()) - max(pa.min(), pb.min()))


def _rectangles_separated(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test of two convex quadrilaterals (edges of both as candidate axes)."""
    for poly in (a, b):
        hull = poly[[0, 1, 3, 2]]
        for k in range(4):
            edge = hull[(k + 1) % 4] - hull[k]
            axis = np.array([-edge[1], edge[0]]) / np.linalg.norm(edge)
            if _overlap_along(a, b, axis) < 0:
                return True
    return False


@pytest.mark.slow
def test_planned_biped_walk_keeps_its_soles_apart() -> None:
    """Before the foot-separation rows the cheapest biped walk crossed its feet (left sole centre
    at y = −0.03 m, right at +0.03 m) and yawed its soles 22° so that the toes overlapped."""
    from planner.nlp.spacetime import GaitPlanner

    bot = robots.load("biped")
    planner = GaitPlanner(bot, n_knots=12)
    schedule = ContactSchedule(0.64, bot.foot_names, (0.0, 0.5), (0.6, 0.6))
    result = planner.solve(schedule, 0.1, warm_start=False)
    assert result.feasible, result.message
    gait = planner.to_gait(result, "biped_walk")
    model = bot.mj_model()
    for k, q in enumerate(gait.knots_rad):
        qpos = np.array(model.qpos0)
        qpos[:7] = (0, 0, 0, 1, 0, 0, 0)
        for name, angle in zip(gait.joint_names, q, strict=True):
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            qpos[model.jnt_qposadr[jid]] = angle
        left, right = _sole_rectangles(bot, qpos)
        assert left[:, 1].mean() > right[:, 1].mean() + 0.06, k  # left foot stays on the left
        assert _rectangles_separated(left, right), k


def test_separation_unit_counts_the_rows_in_leg_lengths_and_keeps_the_bound() -> None:
    """`PlannerOptions.separation_unit_leg_lengths`: the same rows divided by the unit, the
    same lower bound 0 (so the same feasible set), and a nondimensional scale that still reads
    leg lengths."""
    from planner.nlp.spacetime import GaitPlanner

    bot = robots.load("biped")
    metres = GaitPlanner(bot, n_knots=8,
                         options=PlannerOptions(separation_unit_leg_lengths=None))
    unit = GaitPlanner(bot, n_knots=8, options=PlannerOptions(separation_unit_leg_lengths=0.4))
    schedule = ContactSchedule(0.64, bot.foot_names, (0.0, 0.5), (0.6, 0.6))
    p = metres._solver_parameters(schedule, 0.1)
    rng = np.random.default_rng(0)
    x = metres.primal_start(np.zeros(metres.layout.size)).x
    x = np.clip(x + 0.02 * rng.standard_normal(x.size), metres._lbx, metres._ubx)
    rows = dict(metres._slices)["foot separation"]
    assert rows == dict(unit._slices)["foot separation"]
    g_m = np.asarray(metres._evaluate(x, p)[0]).ravel()[rows]
    g_u = np.asarray(unit._evaluate(x, p)[0]).ravel()[rows]
    assert np.abs(g_m).max() > 1e-3  # a point where the rows are not all 0
    np.testing.assert_allclose(g_u, g_m / (0.4 * bot.leg_length_m), rtol=1e-12, atol=1e-15)
    assert np.array_equal(unit._lbg[rows], metres._lbg[rows])
    assert np.all(unit._lbg[rows] == 0) and np.all(np.isposinf(unit._ubg[rows]))
    others = np.ones(metres._lbg.size, dtype=bool)
    others[rows] = False
    np.testing.assert_array_equal(np.asarray(unit._evaluate(x, p)[0]).ravel()[others],
                                  np.asarray(metres._evaluate(x, p)[0]).ravel()[others])


def test_separation_unit_option_is_checked() -> None:
    assert PlannerOptions(separation_unit_leg_lengths=None).separation_unit_m(0.25) == 1.0
    assert PlannerOptions(separation_unit_leg_lengths=0.4).separation_unit_m(0.25) == \
        pytest.approx(0.1)
    for bad in (0.0, -0.4, float("nan"), float("inf"), 20.0):
        with pytest.raises(PlannerConfigError, match="separation_unit_leg_lengths"):
            PlannerOptions(separation_unit_leg_lengths=bad)


@pytest.mark.slow
def test_the_template_paths_defaults_plan_the_bipeds_slow_walk_without_wandering() -> None:
    """The template path's defaults (`DEFAULT_SWING_WRENCH` "bounds" with the separation rows
    in `DEFAULT_SEPARATION_UNIT_LEG_LENGTHS`) plan the biped's 0.1 m/s walk, cold on the
    half-cycle NLP, in 15 iterations; "rows" took 22 and "bounds" with the rows in metres 35
    (23-118 over re-draws of the start: the swing foot carried across the other,
    docs/results/planner_speed_coldstart.md, sessions 41-42)."""
    from planner.nlp.spacetime import GaitPlanner
    from planner.templates import make_schedule

    bot = robots.load("biped")
    planner = GaitPlanner(bot, n_knots=30)
    result = planner.solve(make_schedule(bot, "biped_walk"), 0.1, warm_start=False)
    assert result.feasible, result.message
    assert result.stats["half_cycle"] and result.stats["swing_wrench"] == "bounds"
    assert result.iterations <= 18
    assert result.cost == pytest.approx(0.2255803, rel=1e-4)  # rows' optimum

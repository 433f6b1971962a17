"""Warm starts onto another contact schedule (`planner.nlp.warm_start`,
`PlannerOptions.warm_retime`, `warm_swing_wrench`, `warm_half_cycle`; issue #16, session 41)."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, WarmStart
from planner.nlp.variables import Layout
from planner.nlp.warm_start import foot_phase_knots, per_foot_applies, per_foot_retimed
from planner.templates import make_schedule

N = 20
SAME_COST_RTOL = 1e-4


@pytest.fixture(scope="module")
def quad12() -> robots.Robot:
    return robots.load("quad12")


def _layout(robot: robots.Robot, n: int = N) -> Layout:
    return Layout(n, len(robot.joint_names), len(robot.foot_names))


def _moved(schedule: robots.ContactSchedule, foot: int, phase: float = 0.0, duty: float = 0.0,
           period: float = 1.0) -> robots.ContactSchedule:
    td = list(schedule.touchdown_phase)
    df = list(schedule.duty_factor)
    td[foot] = (td[foot] + phase) % 1.0
    df[foot] += duty
    return robots.ContactSchedule(schedule.period_s * period, schedule.feet, tuple(td), tuple(df))


def test_the_same_schedule_maps_every_knot_onto_itself() -> None:
    knots, rate = foot_phase_knots(N, 0.3, 0.6, 0.3, 0.6)
    np.testing.assert_allclose(knots, np.arange(N), atol=1e-6)
    np.testing.assert_allclose(rate, 1.0)


def test_stance_maps_onto_stance_and_rates_follow_the_durations() -> None:
    knots, rate = foot_phase_knots(N, 0.0, 0.5, 0.0, 0.6)  # stance 10 knots → 12
    assert knots[0] == pytest.approx(0.0, abs=1e-6)
    assert knots[6] == pytest.approx(5.0, abs=1e-6)  # halfway through stance
    assert knots[12] == pytest.approx(10.0, abs=1e-6)  # lift-off on lift-off
    np.testing.assert_allclose(rate[:12], 0.5 / 0.6)
    np.testing.assert_allclose(rate[12:], 0.5 / 0.4)
    with pytest.raises(PlannerConfigError, match="duty"):
        foot_phase_knots(N, 0.0, 1.0, 0.0, 0.5)


def test_a_foot_moved_by_one_knot_carries_its_leg_and_leaves_the_others(
        quad12: robots.Robot) -> None:
    layout = _layout(quad12)
    base = make_schedule(quad12, "trot")
    moved = _moved(base, 0, phase=1.0 / N)
    x = np.random.default_rng(0).standard_normal(layout.size)
    out = per_foot_retimed(layout, quad12, x, base, moved)
    q, q0 = layout.view(out, "q"), layout.view(x, "q")
    names = quad12.joint_names
    leg = [names.index(j) for j in quad12.legs[0].joints]
    rest = [i for i in range(len(names)) if i not in leg]
    np.testing.assert_allclose(q[:, leg], np.roll(q0[:, leg], 1, axis=0), atol=1e-6)
    np.testing.assert_allclose(q[:, rest], q0[:, rest], atol=1e-6)
    np.testing.assert_array_equal(layout.view(out, "base"), layout.view(x, "base"))
    # the moved foot's forces: its old ones one knot later, zero where it swings now
    f = layout.view(out, "forces")[:, 0:3]
    f0 = layout.view(x, "forces")[:, 0:3]
    stance = moved.contact_matrix(N)[:, 0]
    np.testing.assert_array_equal(f[~stance], 0.0)
    shifted = np.roll(f0, 1, axis=0)
    both = stance & (shifted[:, 2] > 0)
    np.testing.assert_allclose(f[both], shifted[both], atol=1e-6)


def test_the_same_schedule_gives_the_same_point(quad12: robots.Robot) -> None:
    layout = _layout(quad12)
    base = make_schedule(quad12, "trot")
    x = np.abs(np.random.default_rng(1).standard_normal(layout.size))
    force = layout.view(x, "forces").reshape(N, 4, 3)
    force[~base.contact_matrix(N)] = 0.0  # a solved point: no force in swing
    np.testing.assert_allclose(per_foot_retimed(layout, quad12, x, base, base), x, atol=1e-6)


def test_per_foot_needs_a_stance_and_a_swing_on_every_foot(quad12: robots.Robot) -> None:
    base = make_schedule(quad12, "trot")
    stand = robots.ContactSchedule(base.period_s, base.feet, base.touchdown_phase,
                                   (1.0,) * len(base.feet))
    assert per_foot_applies(base, base)
    assert not per_foot_applies(base, stand)


def test_options_are_checked() -> None:
    with pytest.raises(PlannerConfigError, match="warm_retime"):
        PlannerOptions(warm_retime="per leg")
    with pytest.raises(PlannerConfigError, match="warm_swing_wrench"):
        PlannerOptions(warm_swing_wrench="free")


@pytest.mark.slow
def test_per_foot_warm_start_reaches_the_cold_optimum_and_holds_the_wrench_by_bounds(
        quad12: robots.Robot) -> None:
    base = make_schedule(quad12, "trot")
    changed = _moved(_moved(base, 0, phase=0.06, duty=0.03, period=1.04), 3, phase=-0.05)
    assert (base.contact_matrix(N) != changed.contact_matrix(N)).any()
    planner = GaitPlanner(quad12, N, PlannerOptions(warm_retime="per foot", swing_wrench="rows",
                                                    warm_swing_wrench="bounds"))
    start = planner.solve(base, 0.25, warm_start=False)
    assert start.feasible, start.message
    assert start.warm_start.schedule == base
    cold = planner.solve(changed, 0.25, warm_start=False)
    assert cold.stats["swing_wrench"] == "rows"
    warm = planner.solve(changed, 0.25, warm_start=start.warm_start)
    assert warm.feasible and cold.feasible, (warm.message, cold.message)
    assert warm.stats["swing_wrench"] == "bounds"
    assert warm.cost <= cold.cost * (1 + SAME_COST_RTOL)
    # the start the solve used is the re-timed one, not the old point
    retimed = planner._retimed(start.warm_start, changed)
    assert retimed.schedule == changed
    assert not np.array_equal(retimed.x, start.warm_start.x)
    # a start without a schedule is used as it is
    bare = WarmStart(start.warm_start.x, start.warm_start.lam_x, start.warm_start.lam_g)
    assert planner._retimed(bare, changed) is bare


@pytest.mark.slow
def test_warm_half_cycle_solves_a_symmetric_change_on_half_the_knots(
        quad12: robots.Robot) -> None:
    base = make_schedule(quad12, "trot")
    stretched = robots.ContactSchedule(base.period_s * 1.05, base.feet, base.touchdown_phase,
                                       tuple(d + 0.05 for d in base.duty_factor))
    full = GaitPlanner(quad12, N, PlannerOptions(warm_half_cycle=False))
    half = GaitPlanner(quad12, N)  # `warm_half_cycle` on by default
    cold = full.solve(stretched, 0.25, warm_start=False)
    for planner in (full, half):
        assert planner.solve(base, 0.25, warm_start=False).stats["half_cycle"]
    warm_full = full.solve(stretched, 0.25)
    warm_half = half.solve(stretched, 0.25)
    assert not warm_full.stats["half_cycle"]
    assert warm_half.stats["half_cycle"]
    assert warm_half.feasible and cold.feasible
    assert warm_half.cost <= cold.cost * (1 + SAME_COST_RTOL)

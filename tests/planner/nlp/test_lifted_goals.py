"""PlannerOptions.servo_goal_form "lifted": the servo goal of every joint and knot a variable tied
to q + τ/k_p + (d/k_p)·q̇ by an equality group; the goal rows read it. The same rows at every
point on the new equalities, so the same feasible set and optimum
(docs/results/planner_speed_rows.md, session 43)."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import fill_servo_goals, group_labels
from planner.nlp.model import RobotModel
from planner.nlp.servo_loop import loop_arrays, servo_loops
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.stagewise import stage_functions
from planner.nlp.variables import Layout, parameter_vector
from planner.templates import make_schedule

N = 8


@pytest.fixture(scope="module")
def pair() -> tuple[GaitPlanner, GaitPlanner]:
    robot = robots.load("quad12")
    return (GaitPlanner(robot, N, PlannerOptions(servo_goal_form="direct")),
            GaitPlanner(robot, N, PlannerOptions(servo_goal_form="lifted")))


def test_option_values() -> None:
    assert PlannerOptions().servo_goal_form == "lifted"  # the default since session 43
    assert PlannerOptions().lifted_goals
    assert not PlannerOptions(servo_goal_form="direct").lifted_goals
    assert PlannerOptions(servo_goal_form="lifted").lifted_goals
    assert not PlannerOptions(servo_goal_form="lifted", servo_goals=False).lifted_goals
    with pytest.raises(PlannerConfigError, match="servo_goal_form"):
        PlannerOptions(servo_goal_form="banded")


def test_sizes_and_layout(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    direct, lifted = pair
    nj = direct.layout.n_joints
    assert lifted.layout.size == direct.layout.size + nj * N
    # every other block where it was: the goals come last
    for name in ("base", "q", "forces", "vel", "acc", "tau", "goal_slope", "moments"):
        assert lifted.layout.block(name) == direct.layout.block(name)
    assert lifted._lbg.size == direct._lbg.size + nj * N
    assert lifted.options.max_iter == direct.options.max_iter  # the same iteration cap
    labels = lifted._x_labels
    assert labels[-1] == f"servo goal {lifted.robot.joint_names[-1]}@knot {N - 1}"
    assert len(group_labels(lifted.model, N)["servo goal"]) == nj * N
    names = [name for name, _ in lifted._slices]
    assert names.index("servo goal") == names.index("servo goal limits") - 1


def test_same_rows_on_the_goal_equalities(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """At random points (goals set from q, τ, q̇) every group of the direct NLP has the same rows
    in the lifted one, and the "servo goal" rows are 0; a goal off its formula shows there."""
    direct, lifted = pair
    robot = direct.robot
    p = parameter_vector(make_schedule(robot, "trot"), N, 0.25, direct.swing_clearance_m)
    rng = np.random.default_rng(3)
    for _ in range(3):
        x = rng.normal(scale=0.3, size=direct.layout.size)
        xl = fill_servo_goals(lifted.layout, lifted.model, lifted.options,
                              np.r_[x, np.zeros(lifted.layout.size - x.size)])
        g = np.asarray(direct._evaluate(x, p)[0]).ravel()
        gl = np.asarray(lifted._evaluate(xl, p)[0]).ravel()
        rows_l = dict(lifted._slices)
        for name, sl in direct._slices:
            np.testing.assert_allclose(gl[rows_l[name]], g[sl], rtol=1e-12, atol=1e-12,
                                       err_msg=name)
        assert np.abs(gl[rows_l["servo goal"]]).max() < 1e-12
        xl[lifted.layout.block("goal")] += 0.1
        off = np.asarray(lifted._evaluate(xl, p)[0]).ravel()[rows_l["servo goal"]]
        np.testing.assert_allclose(off, 0.1, atol=1e-12)


def test_fill_servo_goals_values() -> None:
    robot = robots.load("quad12")
    model = RobotModel(robot)
    layout = Layout.of(model, N, lifted_goals=True)
    rng = np.random.default_rng(0)
    x = rng.normal(size=layout.size)
    out = fill_servo_goals(layout, model, PlannerOptions(), x)
    kp, damping = loop_arrays(servo_loops(robot, None))
    expected = (layout.view(x, "q") + layout.view(x, "tau") / kp
                + layout.view(x, "vel")[:, 6:] * damping / kp)
    np.testing.assert_allclose(layout.view(out, "goal"), expected)
    np.testing.assert_array_equal(out[: layout.block("goal").start],
                                  x[: layout.block("goal").start])
    plain = Layout.of(model, N)
    assert fill_servo_goals(plain, model, PlannerOptions(), x[: plain.size]) is not None


def test_stagewise_refuses() -> None:
    model = RobotModel(robots.load("quad12"))
    with pytest.raises(PlannerConfigError, match="servo_goal_form"):
        stage_functions(model, N, PlannerOptions(servo_goal_form="lifted"))


def test_same_optimum_half_cycle(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """quad12 trot at N = 8, cold, on the half-cycle NLP: the same optimum, the goals on their
    formula at the solution."""
    direct, lifted = pair
    schedule = make_schedule(direct.robot, "trot")
    a = direct.solve(schedule, 0.25, warm_start=False)
    b = lifted.solve(schedule, 0.25, warm_start=False)
    assert a.feasible and b.feasible
    assert b.stats["half_cycle"] == a.stats["half_cycle"]
    assert abs(b.cost - a.cost) <= 1e-6 * abs(a.cost)
    np.testing.assert_allclose(b.joint_angles_rad, a.joint_angles_rad, atol=1e-4)
    x = b.warm_start.x
    np.testing.assert_allclose(
        fill_servo_goals(lifted.layout, lifted.model, lifted.options, x), x, atol=1e-7)

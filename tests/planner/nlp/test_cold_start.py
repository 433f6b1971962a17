"""Cold starts (`planner.nlp.cold_start`): the rows each start claims to satisfy hold, bounds."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.cold_start import ColdStarter, StartCommand
from planner.nlp.command import VelocityCommand
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import finite_difference_rates, knot_function
from planner.nlp.model import RobotModel
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import (
    Layout,
    initial_guess,
    make_symbols,
    parameter_vector,
    variable_bounds,
)
from planner.templates import default_gait_for, make_schedule
from tests.zoo.fixtures import ZOO, ZOO_ROBOTS


def _violations(planner: GaitPlanner, x: np.ndarray, p: np.ndarray,
                schedule: robots.ContactSchedule) -> dict[str, float]:
    g = np.asarray(planner._evaluate(x / planner._x_scale, p)[0]).ravel()
    lb, ub = planner._row_lower_bounds(schedule), planner._ubg
    v = np.maximum(lb - g, 0.0) + np.maximum(g - ub, 0.0)
    return {name: float(v[sl].max(initial=0.0)) for name, sl in planner._slices}


@pytest.mark.parametrize("kind", ["balanced", "stride"])
def test_start_satisfies_the_rows_it_claims(quad_planner: GaitPlanner, kind: str) -> None:
    schedule = make_schedule(quad_planner.robot, "trot")
    speed = 0.25
    p = parameter_vector(schedule, quad_planner.n_knots, speed, quad_planner.swing_clearance_m)
    command = StartCommand(VelocityCommand(speed), quad_planner.swing_clearance_m)
    stance = initial_guess(quad_planner.layout, quad_planner.model, schedule)
    starter = ColdStarter(
        quad_planner.layout, quad_planner.model, quad_planner.options,
        knot_function(quad_planner.model),
        lambda x, p: np.asarray(quad_planner._evaluate(x, p)[0]).ravel()[
            dict(quad_planner._slices)["finite differences"]],
    )
    x = starter.start(kind, schedule, command, p)
    before, after = _violations(quad_planner, stance, p, schedule), _violations(
        quad_planner, x, p, schedule)
    assert before["inverse dynamics"] > 0.1  # the stance start's gravity torques
    for rows in ("finite differences", "inverse dynamics", "servo goal spline"):
        assert after[rows] < 1e-9, (rows, after[rows])
    # the wrench balances the body better than the even share (a trot's diagonal support
    # cannot hold every moment statically; the accelerations of "stride" add to it)
    if kind == "balanced":
        assert after["dynamics"] < 0.5 * before["dynamics"]
    else:  # the feet walk the treadmill and lift: no-slip and clearance rows nearly hold
        assert after["stance no-slip"] < 0.05 * before["stance no-slip"]
        assert after["swing clearance"] < 0.05 * before["swing clearance"]
    lo, hi = variable_bounds(quad_planner.layout, quad_planner.model, quad_planner.options)
    assert np.all(x >= lo) and np.all(x <= hi)


def _starter(robot: robots.Robot, n: int) -> tuple[ColdStarter, Layout, RobotModel]:
    """A `ColdStarter` with the NLP's finite differences, without building the NLP."""
    model = RobotModel(robot)
    layout = Layout(n, model.n_joints, model.n_feet, len(model.flat_feet))
    options = PlannerOptions()
    sym = make_symbols(layout)
    vel, acc = finite_difference_rates(sym, n)
    fd = ca.Function("fd", [sym.x, sym.p], [ca.vertcat(ca.vec(sym.vel - vel),
                                                       ca.vec(sym.acc - acc))])
    return (ColdStarter(layout, model, options, knot_function(model),
                        lambda x, p: np.asarray(fd(x, p)).ravel()), layout, model)


@pytest.mark.parametrize("name", ["biped", *[str(ZOO / z) for z in ZOO_ROBOTS]])
def test_every_zoo_robot_gets_a_start_inside_its_bounds(name: str) -> None:
    robot = robots.load(name)
    n = 12
    starter, layout, model = _starter(robot, n)
    schedule = make_schedule(robot, default_gait_for(robot))
    clearance = PlannerOptions().swing_clearance_for(robot.leg_length_m)
    speed = 0.1 * robot.leg_length_m / 0.18
    p = parameter_vector(schedule, n, speed, clearance)
    lo, hi = variable_bounds(layout, model, PlannerOptions())
    held = np.array([j.held for j in robot.joints], dtype=bool)
    for kind in ("balanced", "stride"):
        x = starter.start(kind, schedule, StartCommand(VelocityCommand(speed), clearance), p)
        assert np.all(np.isfinite(x)), (name, kind)
        assert np.all(x >= lo) and np.all(x <= hi), (name, kind)
        _, q, f = layout.unpack(x)
        stance = np.asarray(robot.nominal_stance_rad)
        assert np.allclose(q[:, held], stance[held])  # held joints stay at their stance
        swing = ~schedule.contact_matrix(n).astype(bool)
        assert np.all(f[swing] == 0.0)  # no force on a swing foot
        assert np.all(f[..., 2] >= 0.0)


def test_a_bad_cold_start_is_a_one_line_error() -> None:
    with pytest.raises(PlannerConfigError, match=r"cold_start='warm'.*stance, balanced, stride"):
        PlannerOptions(cold_start="warm")
    with pytest.raises(PlannerConfigError, match=r"swing_wrench='free'.*rows, bounds"):
        PlannerOptions(swing_wrench="free")

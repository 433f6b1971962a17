"""PlannerOptions.compact_rows: inequality rows handed to IPOPT in a smaller form (variable
bounds, ranged rows) with exactly the same feasible set, still reported by their groups' names
(docs/results/planner_speed_rows.md)."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp import diagnostics
from planner.nlp.config import COMPACT_ROWS, PlannerOptions
from planner.nlp.constraints import (
    GOAL_SPEED_INSIDE,
    GOAL_SPEED_SAMPLES_PER_KNOT,
    group_labels,
)
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import (
    force_indices,
    parameter_vector,
    swing_force_upper_bounds,
)
from planner.templates import make_schedule

N = 8
TOL = 1e-12  # a row or bound is met when within this (the points are drawn away from it)


@pytest.fixture(scope="module")
def pair() -> tuple[GaitPlanner, GaitPlanner]:
    """quad12 at N = 8 with the rows (before) and with every compact form."""
    robot = robots.load("quad12")
    return (GaitPlanner(robot, N, PlannerOptions(compact_rows=())),
            GaitPlanner(robot, N, PlannerOptions(compact_rows=COMPACT_ROWS)))


def _random_point(planner: GaitPlanner, rng: np.random.Generator) -> np.ndarray:
    """A point whose joint speeds, goal slopes, torques and normal forces straddle their limits
    (about half of each inside)."""
    layout, robot = planner.layout, planner.robot
    n, nj = layout.n_knots, layout.n_joints
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in robot.joints])
    stall = np.array([j.servo.stall_torque_nm for j in robot.joints])
    x = rng.normal(scale=0.1, size=layout.size)
    layout.view(x, "vel")[:, 6:] = omega0 * rng.uniform(-1.3, 1.3, size=(n, nj))
    layout.view(x, "tau")[:] = stall * rng.uniform(-1.0, 1.0, size=(n, nj))
    layout.view(x, "goal_slope")[:] = omega0 * rng.uniform(-1.3, 1.3, size=(n, nj))
    x[force_indices(layout, 2)] = rng.uniform(-0.5, 4.0, size=n * layout.n_feet)
    return x


def _rows(planner: GaitPlanner, x: np.ndarray, p: np.ndarray, name: str) -> tuple[np.ndarray, ...]:
    g = np.asarray(planner._evaluate(x, p)[0]).ravel()
    sl = dict(planner._slices)[name]
    return g[sl], planner._lbg[sl], planner._ubg[sl]


def _met(value: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return (value >= lo - TOL) & (value <= hi + TOL)


def test_option_validated() -> None:
    assert PlannerOptions(compact_rows=("joint speed",)).compact_rows == ("joint speed",)
    for bad in (("joint speeds",), ("joint speed", "joint speed"), ["joint speed"]):
        with pytest.raises(PlannerConfigError, match=r"compact_rows.*joint speed, goal slope"):
            PlannerOptions(compact_rows=bad)  # type: ignore[arg-type]


def test_sizes(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """Each form removes its rows: joint speed J·N, the goal speed's u = 0 sample J·N, half the
    envelope's 4·J·N faces, the swing force's F·N rows."""
    rows, compact = pair
    nj, nf = rows.layout.n_joints, rows.layout.n_feet
    sizes = {name: sl.stop - sl.start for name, sl in rows._slices}
    new = {name: sl.stop - sl.start for name, sl in compact._slices}
    assert sizes["joint speed"] == nj * N and "joint speed" not in new
    assert sizes["swing force"] == nf * N and "swing force" not in new
    assert sizes["torque envelope"] == 4 * nj * N and new["torque envelope"] == 2 * nj * N
    assert sizes["servo goal speed"] == GOAL_SPEED_SAMPLES_PER_KNOT * nj * N
    assert new["servo goal speed"] == (GOAL_SPEED_SAMPLES_PER_KNOT - 1) * nj * N
    assert rows._lbg.size - compact._lbg.size == nj * N * 4 + nf * N
    assert {k: v for k, v in sizes.items() if k not in COMPACT_GROUPS} == {
        k: v for k, v in new.items() if k not in COMPACT_GROUPS}


COMPACT_GROUPS = ("joint speed", "swing force", "torque envelope", "servo goal speed")


def test_same_feasible_set_per_row(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """At random points straddling the limits every (joint or foot, knot) gets the same verdict
    from the old rows as from the new bounds and ranged rows, and every other row is unchanged."""
    rows, compact = pair
    robot, layout = rows.robot, rows.layout
    nj, nf = layout.n_joints, layout.n_feet
    rng = np.random.default_rng(3)
    trot = make_schedule(robot, "trot")
    p = parameter_vector(trot, N, 0.25, rows.swing_clearance_m)
    lbx, ubx = compact._variable_bounds(trot)
    families = ("joint speed", "goal slope", "torque envelope", "swing force")
    seen: dict[str, set[bool]] = {name: set() for name in families}
    for _ in range(6):
        x = _random_point(rows, rng)
        inside_x = _met(x, lbx, ubx)
        # joint speed: J·N rows q̇/ω₀ ∈ ±margin ⇔ the rates' bounds
        old = _met(*_rows(rows, x, p, "joint speed"))
        index = layout.indices("vel")[:, 6:]  # the joint rates, knot-major
        np.testing.assert_array_equal(old, inside_x[index.ravel()])
        seen["joint speed"] |= set(old.tolist())
        # goal speed at u = 0: the first J·N rows ⇔ the slopes' bounds; the rest unchanged
        value, lo, hi = _rows(rows, x, p, "servo goal speed")
        slopes = layout.block("goal_slope")
        old = _met(value[: nj * N], lo[: nj * N], hi[: nj * N])
        np.testing.assert_array_equal(old, inside_x[slopes])
        seen["goal slope"] |= set(old.tolist())
        new_value, *_ = _rows(compact, x, p, "servo goal speed")
        np.testing.assert_allclose(new_value, value[nj * N :], rtol=1e-12, atol=1e-12)
        # torque envelope: four faces met ⇔ both ranged rows met, per (joint, knot)
        faces = np.all(_met(*_rows(rows, x, p, "torque envelope")).reshape(4, -1), axis=0)
        ranged = np.all(_met(*_rows(compact, x, p, "torque envelope")).reshape(2, -1), axis=0)
        np.testing.assert_array_equal(faces, ranged)
        seen["torque envelope"] |= set(np.asarray(faces, dtype=bool).tolist())
        # swing force: C·f_max − f_z ≥ 0 ⇔ f_z ≤ its per-solve upper bound
        old = _met(*_rows(rows, x, p, "swing force"))
        fz = force_indices(layout, 2)
        np.testing.assert_array_equal(old, x[fz] <= ubx[fz] + TOL)
        seen["swing force"] |= set(old.tolist())
        # every other group: the same rows, the same values
        g_old = np.asarray(rows._evaluate(x, p)[0]).ravel()
        g_new = np.asarray(compact._evaluate(x, p)[0]).ravel()
        new_slices = dict(compact._slices)
        for name, sl in rows._slices:
            if name not in COMPACT_GROUPS:
                np.testing.assert_array_equal(g_new[new_slices[name]], g_old[sl])
                np.testing.assert_array_equal(compact._lbg[new_slices[name]], rows._lbg[sl])
                np.testing.assert_array_equal(compact._ubg[new_slices[name]], rows._ubg[sl])
    # the points tested both verdicts of every family
    assert all(v == {True, False} for v in seen.values()), seen
    # the other bounds are the old ones
    keep = np.ones(layout.size, dtype=bool)
    keep[index.ravel()] = keep[slopes] = keep[force_indices(layout, 2)] = False
    lbx_old, ubx_old = rows._variable_bounds(trot)
    np.testing.assert_array_equal(lbx[keep], lbx_old[keep])
    np.testing.assert_array_equal(ubx[keep], ubx_old[keep])
    assert nf * N == force_indices(layout, 2).size


def test_bounds(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """Joint rates ±margin·ω₀, slopes ±0.98·margin·ω₀, f_z ≤ C·f_max (0 in swing: fixed)."""
    _, compact = pair
    robot, layout, options = compact.robot, compact.layout, compact.options
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in robot.joints])
    vel_hi = layout.view(compact._ubx, "vel")
    np.testing.assert_array_equal(vel_hi[:, 6:], np.tile(options.speed_margin * omega0, (N, 1)))
    assert np.all(np.isinf(vel_hi[:, :6]))
    slopes = layout.block("goal_slope")
    np.testing.assert_allclose(compact._ubx[slopes],
                               np.tile(GOAL_SPEED_INSIDE * options.speed_margin * omega0, N))
    np.testing.assert_array_equal(compact._lbx[slopes], -compact._ubx[slopes])
    trot = make_schedule(robot, "trot")
    lbx, ubx = compact._variable_bounds(trot)
    contact = trot.contact_matrix(N).astype(float)
    fz = force_indices(layout, 2)
    np.testing.assert_array_equal(ubx[fz], contact.ravel() * options.max_force_body_weights)
    assert np.all(lbx[fz][contact.ravel() == 0] == ubx[fz][contact.ravel() == 0])
    with pytest.raises(PlannerConfigError, match="contact matrix"):
        swing_force_upper_bounds(layout, ubx, contact.T, 3.0)


def _reports(planner: GaitPlanner, x: np.ndarray, p: np.ndarray, lam_x: np.ndarray,
             lam_g: np.ndarray, lbx: np.ndarray, ubx: np.ndarray
             ) -> dict[str, diagnostics.GroupReport]:
    g = np.asarray(planner._evaluate(x, p)[0]).ravel()
    merged = diagnostics.with_bound_rows(planner._slices, g, planner._lbg, planner._ubg, lam_g,
                                         planner._bound_rows, x, lbx, ubx, lam_x)
    return {r.name: r for r in diagnostics.group_reports(*merged, planner._labels)}


def test_reports_name_the_rows_as_before(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """The bounds are reported as their groups' rows: the same violation, worst row, active and
    near counts and multiplier sums (λ_x·ω₀ = the row's λ)."""
    rows, compact = pair
    layout, robot = rows.layout, rows.robot
    rng = np.random.default_rng(5)
    trot = make_schedule(robot, "trot")
    p = parameter_vector(trot, N, 0.25, rows.swing_clearance_m)
    x = _random_point(rows, rng)
    # some rates exactly at their limit: "active" rows
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in robot.joints])
    index = layout.indices("vel")[:, 6:]  # the joint rates, knot-major
    x[index[2, 3]] = 0.9 * omega0[3]
    lam_g = np.zeros(rows._lbg.size)
    sl = dict(rows._slices)["joint speed"]
    lam_g[sl] = rng.normal(size=sl.stop - sl.start)
    lam_x = np.zeros(layout.size)
    lam_x[index.ravel()] = lam_g[sl] / np.tile(omega0, N)
    old = _reports(rows, x, p, np.zeros(layout.size), lam_g, *rows._variable_bounds(trot))
    new = _reports(compact, x, p, lam_x, np.zeros(compact._lbg.size),
                   *compact._variable_bounds(trot))
    for name in COMPACT_GROUPS:
        a, b = old[name], new[name]
        assert b.max_violation == pytest.approx(a.max_violation, rel=1e-12), name
        assert b.worst_row == a.worst_row, name
        assert (b.n_active, b.n_near) == (a.n_active, a.n_near), name
        if name != "torque envelope":  # 2 ranged rows against 4 faces: the first may differ
            assert (b.first_active, b.first_near) == (a.first_active, a.first_near), name
    assert old["joint speed"].max_violation > 0.1  # the point violates the limit
    assert new["joint speed"].multiplier_sum == pytest.approx(old["joint speed"].multiplier_sum)
    assert new["joint speed"].n_active >= 1
    assert new["joint speed"].first_active.endswith("@knot 2")
    # and the one-line explanation names the group and its row
    reports = list(new.values())
    binding = diagnostics.binding_limits(reports, feasible=False)
    assert "joint speed" in dict(binding)
    message = diagnostics.explain(reports, binding, "Infeasible_Problem_Detected")
    assert f"joint speed (violated by {new['joint speed'].max_violation:.3g} at " in message


def test_same_optimum_on_a_trot(pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """Cold quad12 trot at N = 8: both forms feasible, the same cost to 1e-4 relative."""
    rows, compact = pair
    trot = make_schedule(rows.robot, "trot")
    a = rows.solve(trot, 0.25, warm_start=False)
    b = compact.solve(trot, 0.25, warm_start=False)
    assert a.feasible and b.feasible
    assert b.cost == pytest.approx(a.cost, rel=1e-4)
    np.testing.assert_allclose(b.joint_angles_rad, a.joint_angles_rad, atol=1e-3)


def test_binding_joint_speed_is_named_from_its_bounds() -> None:
    """Servos too slow for the trot (speed margin 0.2 of ω₀): infeasible, and the report names
    the joint speed that binds — now bounds of the lifted rates — as it named the rows."""
    robot = robots.load("quad12")
    planner = GaitPlanner(robot, N, PlannerOptions(compact_rows=COMPACT_ROWS, speed_margin=0.2))
    result = planner.solve(make_schedule(robot, "trot"), 0.25, warm_start=False)
    assert not result.feasible
    assert "joint speed" in dict(result.binding), result.message
    assert "joint speed (at its limit in " in result.message


def test_stagewise_refuses_rows_as_bounds() -> None:
    """The stage-wise NLP (FATROP) has rows only: the bound forms are refused in one line; the
    ranged envelope is its rows' own form (labelled two per joint and knot)."""
    from planner.nlp.model import RobotModel
    from planner.nlp.stagewise import stage_functions

    model = RobotModel(robots.load("quad12"))
    with pytest.raises(PlannerConfigError, match="compact_rows joint speed"):
        stage_functions(model, N, PlannerOptions(compact_rows=("joint speed", "torque envelope"),
                                                 servo_goal_form="direct"))
    labels = group_labels(model, N, ("torque envelope",))
    assert len(labels["torque envelope"]) == 2 * model.n_joints * N

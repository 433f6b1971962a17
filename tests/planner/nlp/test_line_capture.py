"""PlannerOptions.line_capture_margin_leg_lengths: on two-foot support the capture point lies on
the side of the support line where the next swing foot lands (`planner.nlp.line_capture`)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.line_capture import (
    capture_point,
    line_capture_labels,
    line_capture_rows,
    line_sides,
    lip_rate_s,
    next_touchdown_weights,
    rows_in_force,
)
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule, stance_foot_positions_m
from robots import ContactSchedule
from tests.planner.nlp.jacobian_pair import assembled_matches_ad, constraint_rows

#: a square of feet FL, FR, RL, RR (x forward, y left)
SQUARE = np.array([[0.1, 0.05], [0.1, -0.05], [-0.1, 0.05], [-0.1, -0.05]])


def test_option_validated() -> None:
    assert PlannerOptions(line_capture_margin_leg_lengths=0.16).line_capture_margin_leg_lengths
    for bad in (-0.1, 1.0, math.inf, math.nan):
        with pytest.raises(PlannerConfigError, match="line_capture_margin_leg_lengths"):
            PlannerOptions(line_capture_margin_leg_lengths=bad)


def test_next_touchdown_weights_pick_the_first_foot_to_land() -> None:
    """Foot 0 swings at knots 0-2 and lands at 3; foot 1 swings at 0-4 and lands at 5; foot 2
    stands throughout: at knot 0 the weights are γ², γ⁴ and 0, so foot 0 dominates."""
    c = np.ones((3, 8))
    c[0, 0:3] = 0
    c[1, 0:5] = 0
    g = 0.3
    w = [np.asarray(ca.DM(x)).ravel() for x in next_touchdown_weights(ca.DM(c), g)]
    np.testing.assert_allclose(w[0], [g**2, g, 1, 0, 0, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(w[1], [g**4, g**3, g**2, g, 1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(w[2], np.zeros(8))
    with pytest.raises(ValueError, match="decay"):
        next_touchdown_weights(ca.DM(c), 0.5)


def test_a_trot_pair_landing_together_on_both_sides_has_no_row_in_force() -> None:
    """Diagonal FL-RR stands, FR and RL (opposite sides of that line) land on the same knot:
    the side weight S is 0, so the row is 0 whatever the capture point."""
    c = np.array([[1, 1, 1, 1], [0, 0, 1, 1], [0, 0, 1, 1], [1, 1, 1, 1]], dtype=float)
    feet = ca.DM(np.column_stack([SQUARE, np.zeros(4)]).ravel()) @ ca.DM.ones(1, 4)
    icp = (ca.DM([[0.05, 0.05, 0.05, 0.05]]), ca.DM([[0.03, -0.04, 0.0, 0.0]]))
    rows = np.asarray(ca.DM(line_capture_rows(ca.DM(c), feet, icp, SQUARE, 0.02))).ravel()
    np.testing.assert_allclose(rows, 0.0, atol=1e-15)


def test_a_walk_line_phase_asks_the_capture_point_toward_the_landing_foot() -> None:
    """Diagonal FL-RR stands at knot 0; FR lands at knot 1, RL at knot 3. FR lies right of the
    line FL → RR. The row of that pair is S·d − |S|·m with S = side(FR) + γ²·side(RL), the
    signed distance d of the capture point from the line; every other pair has no row."""
    c = np.array([[1, 1, 1, 1], [0, 1, 1, 1], [0, 0, 0, 1], [1, 1, 1, 1]], dtype=float)
    feet = ca.DM(np.column_stack([SQUARE, np.zeros(4)]).ravel()) @ ca.DM.ones(1, 4)
    icp_y = [0.01, 0.0, 0.0, 0.0]
    icp = (ca.DM([[0.0] * 4]), ca.DM([icp_y]))
    m, g = 0.02, 0.3
    rows = np.asarray(ca.DM(line_capture_rows(ca.DM(c), feet, icp, SQUARE, m, g))).ravel()
    pairs = list(line_sides(SQUARE))
    k0 = rows[: len(pairs)]  # knot-major: knot 0's rows first
    sides = line_sides(SQUARE)[(0, 3)]
    u = SQUARE[3] - SQUARE[0]
    d = (u[0] * (icp_y[0] - SQUARE[0, 1]) - u[1] * (0.0 - SQUARE[0, 0])) / np.linalg.norm(u)
    s = sides[1] * 1.0 + sides[2] * g**2
    want = s * d - abs(s) * m
    assert sides[1] == -sides[2] != 0
    assert k0[pairs.index((0, 3))] == pytest.approx(want, rel=1e-9)
    assert np.all(np.delete(k0, pairs.index((0, 3))) == 0)
    assert len(line_capture_labels(("a", "b", "c", "d"), 4)) == rows.size


def test_capture_point_and_lip_rate() -> None:
    omega = lip_rate_s(0.2)
    assert omega == pytest.approx(math.sqrt(9.81 / 0.2))
    com = ca.DM([[0.0, 0.1], [0.0, 0.0], [0.2, 0.2]])
    x, y = capture_point(com, (ca.DM([[0.2, 0.3]]), ca.DM([[0.0, 0.1]])),
                         (ca.DM([[0.0, 0.1]]), ca.DM([[0.0, -0.1]])), 10.0, omega)
    np.testing.assert_allclose(np.asarray(ca.DM(x)).ravel(), [1.0 / omega, 0.1 + 1.0 / omega])
    np.testing.assert_allclose(np.asarray(ca.DM(y)).ravel(), [0.0, 1.0 / omega])
    with pytest.raises(ValueError, match="height"):
        lip_rate_s(0.0)


def test_no_rows_when_off_or_on_a_biped() -> None:
    assert PlannerOptions().line_capture_margin_leg_lengths is None
    on = PlannerOptions(line_capture_margin_leg_lengths=0.1)
    biped = robots.load("biped")
    assert constraint_rows(biped, 8, on) == constraint_rows(biped, 8)


def test_assembled_jacobian_with_the_rows_is_casadis_own_and_finite_differences() -> None:
    """The rows through `planner.nlp.assembled_jacobian`: CasADi's AD Jacobian to 1e-10, the
    NLP has exactly 6·N more rows (quad12: 6 pairs of 4 feet), and the rows' Jacobian matches
    central finite differences at a random point."""
    robot = robots.load("quad12")
    n = 8
    pair = assembled_matches_ad(robot, n, PlannerOptions(line_capture_margin_leg_lengths=0.1),
                                make_schedule(robot, "walk", duty_factor=0.6))
    got, f_as, x, p = pair.assembled, pair.jac_g, pair.x, pair.p
    assert got.shape[0] == constraint_rows(robot, n) + 6 * n
    g_on = np.asarray(f_as(x, p)[0].full()).ravel()
    sel = dict(pair.planner._slices)["line capture"]
    assert sel.stop - sel.start == 6 * n
    assert np.any(g_on[sel] != 0)  # the walk has two-foot knots at this point
    eps = 1e-6
    rng = np.random.default_rng(4)
    for col in rng.choice(x.size, size=12, replace=False):
        dx = np.zeros_like(x)
        dx[col] = eps
        fd = (np.asarray(f_as(x + dx, p)[0].full()).ravel()[sel]
              - np.asarray(f_as(x - dx, p)[0].full()).ravel()[sel]) / (2 * eps)
        np.testing.assert_allclose(got[sel, col], fd, rtol=1e-5, atol=1e-6)


def test_rows_in_force_only_where_a_pair_stands_and_the_next_touchdown_has_a_side() -> None:
    """A duty-0.6 lateral-sequence walk stands on a line 60 % of the cycle: one row in force per
    such knot; a trot (diagonal pairs land together) and a duty-0.75 walk on 30 knots (never
    two feet) have none, and the planner frees those rows for the solve."""
    quad = robots.load("quad12")
    nominal = stance_foot_positions_m(quad)[:, :2]

    def in_force(schedule: ContactSchedule, n: int) -> np.ndarray:
        return rows_in_force(np.asarray(schedule.contact_matrix(n), dtype=float).T, nominal)

    walk = make_schedule(quad, "walk", duty_factor=0.6)
    assert in_force(walk, 30).sum() == 18
    assert in_force(make_schedule(quad, "trot"), 30).sum() == 0
    assert in_force(make_schedule(quad, "walk"), 30).sum() == 0
    planner = GaitPlanner(quad, 10, PlannerOptions(line_capture_margin_leg_lengths=0.1))
    rows = dict(planner._slices)["line capture"]
    for schedule in (walk, make_schedule(quad, "trot")):
        lb = planner._row_lower_bounds(schedule)[rows]
        np.testing.assert_array_equal(lb == 0, in_force(schedule, 10))
        assert np.all(np.isneginf(lb[~in_force(schedule, 10)]))
    plain = GaitPlanner(quad, 10, PlannerOptions())
    assert plain._row_lower_bounds(walk) is plain._lbg

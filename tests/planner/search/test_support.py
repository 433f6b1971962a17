"""The search's support term: line-support phases and their open-loop tipping amplification."""

from __future__ import annotations

import math

import numpy as np
import pytest

import robots
from planner.search.support import (
    TippingCost,
    line_support_durations_s,
    support_phases,
    tipping_amplification,
    tipping_time_constant_s,
)
from planner.templates import make_schedule, stance_foot_positions_m
from robots import ContactSchedule


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


def _xy(robot: robots.Robot) -> np.ndarray:
    return stance_foot_positions_m(robot)[:, :2]


def test_phases_tile_the_cycle_and_classify_support(quad: robots.Robot) -> None:
    for gait in ("walk", "diagonal_walk", "trot", "pace", "bound", "gallop_rotary", "pronk"):
        sched = make_schedule(quad, gait)
        phases = support_phases(sched, _xy(quad))
        assert sum(p.duration_s for p in phases) == pytest.approx(sched.period_s)
        for p in phases:
            n = len(p.stance)
            assert p.kind == ("flight" if n == 0 else "line" if n <= 2 else "polygon")


def test_walks_never_stand_on_a_line_and_trots_do_twice(quad: robots.Robot) -> None:
    h = quad.stance_base_height_m
    assert tipping_amplification(make_schedule(quad, "walk"), _xy(quad), h) == 0.0
    assert tipping_amplification(make_schedule(quad, "diagonal_walk"), _xy(quad), h) == 0.0
    trot = make_schedule(quad, "trot")  # duty 0.6: each diagonal pair swings 0.4 of the period
    runs = line_support_durations_s(trot, _xy(quad))
    np.testing.assert_allclose(runs, [0.4 * trot.period_s] * 2)
    tau = tipping_time_constant_s(h)
    assert tipping_amplification(trot, _xy(quad), h) == pytest.approx(
        2 * (math.cosh(0.4 * trot.period_s / tau) - 1))
    # a slower trot (same duty) tips exponentially more: the failure seen in MuJoCo
    slow = trot.with_period(2 * trot.period_s)
    assert tipping_amplification(slow, _xy(quad), h) > 4 * tipping_amplification(trot, _xy(quad), h)


def test_consecutive_line_phases_form_one_run_and_flight_ends_it(quad: robots.Robot) -> None:
    gallop = make_schedule(quad, "gallop_rotary")  # hind 1 → 2 → 1 foot, flight, fore 1 → 2 → 1
    runs = line_support_durations_s(gallop, _xy(quad))
    assert len(runs) == 2
    flight = sum(p.duration_s for p in support_phases(gallop, _xy(quad)) if p.kind == "flight")
    assert sum(runs) + flight == pytest.approx(gallop.period_s)
    # pronk: all four feet, then flight: never a line
    assert line_support_durations_s(make_schedule(quad, "pronk"), _xy(quad)) == []


def test_collinear_feet_are_a_line_and_a_tripod_is_a_polygon() -> None:
    hexa = robots.load("hex18")
    tripod = make_schedule(hexa, "tripod")
    assert all(p.kind == "polygon" for p in support_phases(tripod, _xy(hexa)))
    # a rectangular hexapod: one side's three feet are collinear; standing on them is a line
    xy = np.array([[0.2, 0.15], [0.0, 0.15], [-0.2, 0.15], [0.2, -0.15], [0.0, -0.15],
                   [-0.2, -0.15]])
    phases = (0.0, 0.0, 0.0, 0.5, 0.5, 0.5)
    sched = ContactSchedule(1.0, hexa.foot_names, phases, (0.5,) * 6)
    assert [p.kind for p in support_phases(sched, xy)] == ["line", "line"]
    assert line_support_durations_s(sched, xy) == [1.0]  # never off the line: the whole cycle
    assert all(p.kind == "polygon" for p in support_phases(tripod, xy))


def test_tipping_cost_scales_and_validates(quad: robots.Robot) -> None:
    trot = make_schedule(quad, "trot")
    cost = TippingCost.for_robot(quad, 0.05)
    assert cost(trot) == pytest.approx(0.05 * cost.amplification(trot))
    assert TippingCost.for_robot(quad, 0.0)(trot) == 0.0
    with pytest.raises(ValueError, match="tipping weight"):
        TippingCost.for_robot(quad, -1.0)
    with pytest.raises(ValueError, match="CoM height"):
        tipping_time_constant_s(0.0)


def test_polygon_edges_of_a_rectangle_by_hand() -> None:
    """Feet fl, fr, hl, hr at (±0.1, ±0.1): each stance set's edges run counter-clockwise."""
    from planner.search.support import polygon_edges, static_margin_m

    xy = np.array([[0.1, 0.1], [0.1, -0.1], [-0.1, 0.1], [-0.1, -0.1]])
    edges = polygon_edges(xy)
    assert len(edges) == 12  # every ordered pair

    def active(stance: list[int]) -> set[tuple[int, int]]:
        return {(e.i, e.j) for e in edges if e.active(np.array(stance, dtype=bool))}

    assert active([1, 1, 1, 1]) == {(3, 1), (1, 0), (0, 2), (2, 3)}
    assert active([1, 1, 1, 0]) == {(1, 0), (0, 2), (2, 1)}  # hr swings: fr → hl closes it
    assert active([1, 0, 0, 1]) == set()  # a diagonal is no polygon
    assert active([0, 0, 0, 0]) == set()
    centre = np.zeros(2)
    assert static_margin_m(centre, xy, np.ones(4), edges) == pytest.approx(0.1)
    # on the diagonal of a triangle: margin 0; 5 cm towards the swinging foot: outside
    assert static_margin_m(centre, xy, np.array([1, 1, 1, 0]), edges) == pytest.approx(0.0)
    assert static_margin_m(np.array([-0.05, -0.05]), xy, np.array([1, 1, 1, 0]),
                           edges) == pytest.approx(-0.05 * math.sqrt(2))
    assert static_margin_m(centre, xy, np.array([1, 0, 0, 1]), edges) is None

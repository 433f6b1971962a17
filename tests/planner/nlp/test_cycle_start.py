"""The written cycle starts at its most static-like knot; rotating a periodic plan is exact."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.nlp.cycle_start import (
    LOAD_TIE,
    rotate,
    rotate_schedule,
    start_from_rest_like_knot,
    start_knot,
)
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule, templates_for
from robots import ContactSchedule


@pytest.fixture(scope="module")
def walk_result(quad_planner: GaitPlanner):  # type: ignore[no-untyped-def]
    result = quad_planner.solve(make_schedule(quad_planner.robot, "walk"), 0.15, warm_start=False)
    assert result.feasible
    return result


@pytest.mark.parametrize("name", ["quad12", "hex18"])
def test_rotation_keeps_every_template_contact_pattern(name: str) -> None:
    robot = robots.load(name)
    n = 30
    for gait in templates_for(robot):
        sched = make_schedule(robot, gait)
        before = sched.contact_matrix(n)
        for k in range(n):
            after = rotate_schedule(sched, k, n)
            np.testing.assert_array_equal(after.contact_matrix(n), np.roll(before, -k, axis=0))


@pytest.mark.parametrize("ulps", [-1, 0, 1])
def test_rotation_of_phases_a_hair_off_a_knot(ulps: int) -> None:
    """The search decodes star5's ripple to phases like 0.19999999999999996: rotating by the
    knot just above (6 of 30) wrapped it to 1.0, which ContactSchedule refuses."""
    n = 30
    def hair(p: float) -> float:  # `ulps` representable doubles away from p
        for _ in range(abs(ulps)):
            p = float(np.nextafter(p, np.sign(ulps) * np.inf))
        return p

    sched = ContactSchedule(0.6, ("a", "b", "c"), (0.0, hair(0.2), hair(0.8)),
                            (0.58, 0.58, 0.58))
    before = sched.contact_matrix(n)
    for k in range(n):
        after = rotate_schedule(sched, k, n)
        assert all(0.0 <= p < 1.0 for p in after.touchdown_phase)
        np.testing.assert_array_equal(after.contact_matrix(n), np.roll(before, -k, axis=0))


def test_rotate_rolls_arrays_and_shifts_phases(walk_result) -> None:  # type: ignore[no-untyped-def]
    n = walk_result.joint_angles_rad.shape[0]
    k = 7
    rot = rotate(walk_result, k)
    np.testing.assert_array_equal(rot.joint_angles_rad,
                                  np.roll(walk_result.joint_angles_rad, -k, 0))
    np.testing.assert_array_equal(rot.contact_forces_n,
                                  np.roll(walk_result.contact_forces_n, -k, 0))
    np.testing.assert_array_equal(rot.schedule.contact_matrix(n),
                                  np.roll(walk_result.schedule.contact_matrix(n), -k, 0))
    assert rotate(walk_result, n) is walk_result and rot.cost == walk_result.cost


def test_start_knot_has_most_feet_down_and_the_evenest_load(walk_result) -> None:  # type: ignore[no-untyped-def]
    sched, forces = walk_result.schedule, walk_result.contact_forces_n
    k = start_knot(sched, forces)
    contact = sched.contact_matrix(forces.shape[0])
    assert contact[k].sum() == contact.sum(axis=1).max()
    fz = forces[:, :, 2]

    def imbalance(i: int) -> float:
        loads = fz[i, contact[i]]
        return float(np.max(np.abs(loads - loads.mean())) / loads.sum())

    full = [i for i in range(len(contact)) if contact[i].sum() == contact[k].sum()]
    assert imbalance(k) == pytest.approx(min(imbalance(i) for i in full))
    started = start_from_rest_like_knot(walk_result)
    assert started.schedule.contact_matrix(forces.shape[0])[0].sum() == contact[k].sum()


@pytest.mark.parametrize("noise", [1e-13, -1e-13, 0.0])
def test_start_knot_breaks_a_mirror_tie_by_index_not_by_rounding(noise: float) -> None:
    # A two-foot walk (duty 0.6, N = 10): double support at knots 0 and 5 (mirror images), each
    # with the same 40/60 load split. Rounding-level differences must not pick the start.
    sched = ContactSchedule(1.0, ("left", "right"), (0.0, 0.5), (0.6, 0.6))
    n = 10
    contact = sched.contact_matrix(n)
    doubles = [i for i in range(n) if contact[i].all()]
    forces = np.zeros((n, 2, 3))
    forces[:, :, 2] = np.where(contact, 15.0, 0.0)
    first, second = doubles
    forces[first, :, 2] = (6.0, 9.0)
    forces[second, :, 2] = (9.0 + noise, 6.0)
    assert start_knot(sched, forces) == first


def test_start_knot_prefers_a_evener_load_beyond_the_tie_over_the_lower_index() -> None:
    sched = ContactSchedule(1.0, ("left", "right"), (0.0, 0.5), (0.6, 0.6))
    n = 10
    contact = sched.contact_matrix(n)
    forces = np.zeros((n, 2, 3))
    forces[:, :, 2] = np.where(contact, 15.0, 0.0)
    first, second = [i for i in range(n) if contact[i].all()]
    forces[first, :, 2] = (7.5 - 3e-4, 7.5 + 3e-4)  # imbalance 2.0e-5 of the load
    forces[second, :, 2] = (7.5 - 1e-4, 7.5 + 1e-4)  # 0.67e-5: evener by more than LOAD_TIE
    assert LOAD_TIE < 1.3e-5
    assert start_knot(sched, forces) == second

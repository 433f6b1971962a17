"""Warm starts onto another contact schedule: each foot's quantities re-timed by its own phase.

`planner.nlp.variables.retimed_start` keeps knot k at phase k/N for every quantity, so a foot
whose touchdown moved by a knot or whose duty factor changed keeps its old stance and swing
motion at the old knots and only its forces follow the new contact matrix. `per_foot_retimed`
maps, for every foot, its leg's joint quantities (angles, rates, accelerations, torques, servo
goal slopes) and its contact force by the phase since that foot's touchdown: a new knot that is
a fraction u through the new stance (swing) reads the old point at the knot a fraction u through
the old stance (swing), linearly interpolated between knots. Rates scale by the ratio of the old
to the new stance (swing) duration, accelerations by its square; the base and the joints of no
leg are re-timed as a whole (`retimed_start`). Forces are zero where the foot now swings and,
at a stance knot that reads none, the cold start's share of the weight (`initial_guess`).
"""

from __future__ import annotations

import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.variables import Layout, retimed_start
from robots import ContactSchedule, Robot
from robots.schedule import KNOT_TOL


def foot_phase_knots(n_knots: int, touchdown_from: float, duty_from: float,
                     touchdown_to: float, duty_to: float) -> tuple[np.ndarray, np.ndarray]:
    """For every knot of the new schedule, the (fractional) knot of the old one at the same
    fraction of stance or swing since touchdown, and the rate factor there (old duration of
    that stance or swing over the new one, in units of the period)."""
    if not (0.0 < duty_from < 1.0 and 0.0 < duty_to < 1.0):
        raise PlannerConfigError(
            f"per-foot re-timing needs duty factors in (0, 1), got {duty_from}, {duty_to}")
    since = (np.arange(n_knots) / n_knots - touchdown_to + KNOT_TOL) % 1.0
    stance = since < duty_to
    u = np.where(stance, since / duty_to * duty_from,
                 duty_from + (since - duty_to) / (1.0 - duty_to) * (1.0 - duty_from))
    knots = ((touchdown_from + u) % 1.0) * n_knots
    rate = np.where(stance, duty_from / duty_to, (1.0 - duty_from) / (1.0 - duty_to))
    return knots, rate


def _at_knots(values: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Rows of the cyclic N × w array `values` at fractional knots (linear interpolation)."""
    n = values.shape[0]
    lo = np.floor(knots).astype(int)
    t = (knots - lo)[:, None]
    return (1.0 - t) * values[lo % n] + t * values[(lo + 1) % n]


def per_foot_applies(schedule_from: ContactSchedule, schedule_to: ContactSchedule) -> bool:
    """Can `per_foot_retimed` map between these schedules (the same feet, every duty factor
    in (0, 1): every foot has a stance and a swing to map)?"""
    duties = (*schedule_from.duty_factor, *schedule_to.duty_factor)
    return schedule_from.feet == schedule_to.feet and all(0.0 < d < 1.0 for d in duties)


def per_foot_retimed(layout: Layout, robot: Robot, x: np.ndarray,
                     schedule_from: ContactSchedule, schedule_to: ContactSchedule) -> np.ndarray:
    """The solved point `x` (physical units) of `schedule_from` mapped onto `schedule_to` foot
    by foot (module docstring)."""
    n = layout.n_knots
    contact_from = schedule_from.contact_matrix(n)
    contact_to = schedule_to.contact_matrix(n)
    # base, held joints, moments: the whole trajectory re-timed (rates by T_from / T_to)
    out = retimed_start(layout, x, schedule_from.period_s, schedule_to.period_s,
                        contact_from, contact_to)
    x = np.asarray(x, dtype=float).ravel()
    period_ratio = schedule_from.period_s / schedule_to.period_s
    names = robot.joint_names
    share = 1.0 / np.maximum(contact_to.sum(axis=1), 1)
    src = {b: layout.view(x, b) for b in ("q", "vel", "acc", "tau", "goal_slope", "forces")}
    dst = {b: layout.view(out, b) for b in src}
    for f, leg in enumerate(robot.legs):
        knots, duty_rate = foot_phase_knots(
            n, schedule_from.touchdown_phase[f], schedule_from.duty_factor[f],
            schedule_to.touchdown_phase[f], schedule_to.duty_factor[f])
        rate = (duty_rate * period_ratio)[:, None]
        joints = np.array([names.index(j) for j in leg.joints], dtype=int)
        dst["q"][:, joints] = _at_knots(src["q"][:, joints], knots)
        dst["tau"][:, joints] = _at_knots(src["tau"][:, joints], knots)
        dst["goal_slope"][:, joints] = rate * _at_knots(src["goal_slope"][:, joints], knots)
        dst["vel"][:, 6 + joints] = rate * _at_knots(src["vel"][:, 6 + joints], knots)
        dst["acc"][:, 6 + joints] = rate**2 * _at_knots(src["acc"][:, 6 + joints], knots)
        cols = slice(3 * f, 3 * f + 3)
        force = _at_knots(src["forces"][:, cols], knots)
        force[~contact_to[:, f]] = 0.0
        # a stance knot read off the old swing (a boundary moved): the cold start's share
        lifted = contact_to[:, f] & (force[:, 2] <= 0.0)
        force[lifted, 2] = share[lifted]
        force[:, 2] = np.maximum(force[:, 2], 0.0)
        dst["forces"][:, cols] = force
    return out

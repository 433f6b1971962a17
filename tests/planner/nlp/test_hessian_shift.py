"""PlannerOptions.hessian_shift_acc: IPOPT is handed W + σ·s on the lifted accelerations'
diagonal (`planner.nlp.hessian_shift`); the NLP — objective, rows, optimality test — is the
same, so the solve reaches the same optimum (docs/results/planner_speed_rows.md, session 44)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.hessian_shift import shifted_hessian
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule

N = 8


def _toy_hessian() -> ca.Function:
    x, p = ca.MX.sym("x", 3), ca.MX.sym("p", 1)
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", 1)
    lagrangian = lam_f * (x[0] ** 2 * x[1] + p * x[2] ** 2) + lam_g * ca.sin(x[0] * x[2])
    hess = ca.triu(ca.hessian(lagrangian, x)[0])
    return ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [hess],
                       ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])


def test_shift_adds_sigma_times_shift_on_the_masked_diagonal() -> None:
    plain = _toy_hessian()
    mask = np.array([False, True, True])
    shifted = shifted_hessian(plain, mask, 0.25)
    assert shifted.name_in() == plain.name_in() and shifted.name_out() == plain.name_out()
    x, p, lam_g = [0.3, -1.2, 0.7], 2.0, 0.4
    for sigma in (0.0, 1.0, 3.0):
        diff = np.asarray(ca.DM(shifted(x, p, sigma, lam_g) - plain(x, p, sigma, lam_g)).full())
        assert np.allclose(diff, np.diag(sigma * 0.25 * mask.astype(float)), atol=1e-15)
    with pytest.raises(ValueError, match="mask"):
        shifted_hessian(plain, np.ones(2, dtype=bool), 0.25)


def test_option_values() -> None:
    assert PlannerOptions().hessian_shift_acc == 0.0  # default: IPOPT gets W itself
    PlannerOptions(hessian_shift_acc=3e-7)
    for bad in (-1e-7, 1.0, float("nan"), float("inf")):
        with pytest.raises(PlannerConfigError, match="hessian_shift_acc"):
            PlannerOptions(hessian_shift_acc=bad)


def test_needs_the_assembled_hessian() -> None:
    with pytest.raises(PlannerConfigError, match="hessian_shift_acc"):
        GaitPlanner(robots.load("quad12"), N,
                    PlannerOptions(hessian_shift_acc=3e-7, nlp_hessian="ad"))


@pytest.mark.slow
def test_same_optimum_half_cycle_and_full() -> None:
    """quad12 trot at N = 8, half-cycle and full NLP: the shifted Hessian reaches the cost of the
    plain one (the shift only changes IPOPT's steps)."""
    robot = robots.load("quad12")
    schedule = make_schedule(robot, "trot")
    plain = GaitPlanner(robot, N, PlannerOptions())
    shifted = GaitPlanner(robot, N, PlannerOptions(hessian_shift_acc=3e-7))
    for half in (True, False):
        a = plain.solve(schedule, 0.25, warm_start=False, half_cycle=half)
        b = shifted.solve(schedule, 0.25, warm_start=False, half_cycle=half)
        assert a.feasible and b.feasible
        assert b.stats["half_cycle"] == a.stats["half_cycle"] == half
        assert abs(b.cost - a.cost) <= 1e-4 * abs(a.cost)

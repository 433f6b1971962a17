"""CasADi's AD constraint Jacobian against `planner.nlp.assembled_jacobian`'s, for the tests of
rows the assembled path builds by hand (rotor reserve, line capture, …)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import parameter_vector
from robots import ContactSchedule, Robot


@dataclass(frozen=True)
class JacobianPair:
    """The NLP's constraint Jacobian at one random point, by both paths (checked equal to 1e-10
    by `assembled_matches_ad`), and what the tests look at next."""

    ad: np.ndarray
    assembled: np.ndarray
    planner: GaitPlanner  # the assembled path's
    jac_g: ca.Function  # the assembled path's nlp_jac_g: (x, p) -> (g, ∂g/∂x)
    x: np.ndarray
    p: np.ndarray


def assembled_matches_ad(robot: Robot, n_knots: int, options: PlannerOptions,
                         schedule: ContactSchedule, speed_m_s: float = 0.1,
                         seed: int = 3) -> JacobianPair:
    """Both paths' Jacobians at a random point (normal, σ 0.2), asserted equal to 1e-10."""
    ad, assembled = (GaitPlanner(robot, n_knots, replace(options, nlp_jacobian=path))
                     for path in ("ad", "assembled"))
    p = parameter_vector(schedule, n_knots, speed_m_s, ad.swing_clearance_m)
    x = np.random.default_rng(seed).normal(scale=0.2, size=ad.layout.size)
    f_ad, f_as = (pl._solver.get_function("nlp_jac_g") for pl in (ad, assembled))
    want, got = (np.asarray(f(x, p)[1].full()) for f in (f_ad, f_as))
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())
    return JacobianPair(want, got, assembled, f_as, x, p)


def constraint_rows(robot: Robot, n_knots: int, options: PlannerOptions | None = None) -> int:
    """How many constraint rows the NLP has (default options: without any optional rows)."""
    planner = GaitPlanner(robot, n_knots, options or PlannerOptions())
    return int(planner._solver.get_function("nlp_jac_g").sparsity_out(1).size1())

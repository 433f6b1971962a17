"""IPOPT's μ-oracle centrality term for cold solves (`PlannerOptions.cold_mu_centrality`)."""

from __future__ import annotations

import pytest

from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, ipopt_options
from planner.templates import make_schedule

KEY = "quality_function_centrality"


def test_reaches_the_cold_options_only() -> None:
    rec = PlannerOptions(cold_mu_centrality="reciprocal")
    assert ipopt_options(rec, warm=False)[KEY] == "reciprocal"
    assert KEY not in ipopt_options(rec, warm=True)  # "tuned" warm solves keep theirs
    old = PlannerOptions(cold_mu_centrality="reciprocal", ipopt_tuning="session21")
    assert ipopt_options(old, warm=True) == ipopt_options(old, warm=False)  # one instance
    assert KEY not in ipopt_options(PlannerOptions(cold_mu_centrality="none"), warm=False)
    with pytest.raises(PlannerConfigError, match="cold_mu_centrality='cubed'"):
        PlannerOptions(cold_mu_centrality="cubed")


def test_the_half_cycle_solve_uses_it(hex_planner: GaitPlanner) -> None:
    """hex18's tripod takes the half-cycle NLP, built with the cold options: the centrality
    reaches it, IPOPT's path changes (other iterates from the same start) and the optimum is the
    same."""
    rec = GaitPlanner(hex_planner.robot, hex_planner.n_knots,
                      PlannerOptions(cold_mu_centrality="reciprocal"))
    none = GaitPlanner(hex_planner.robot, hex_planner.n_knots,
                       PlannerOptions(cold_mu_centrality="none"))
    schedule = make_schedule(hex_planner.robot, "tripod")
    a = none.solve(schedule, 0.15, warm_start=False)
    b = rec.solve(schedule, 0.15, warm_start=False)
    assert a.stats["half_cycle"] and b.stats["half_cycle"]
    assert a.feasible and b.feasible
    assert b.cost == pytest.approx(a.cost, rel=1e-4)
    path_a, path_b = a.stats["iterations"]["inf_pr"], b.stats["iterations"]["inf_pr"]
    assert path_a[0] == path_b[0] and path_a != path_b  # same start, another path

"""`planner.nlp.solver_cache.used_directions` reads CasADi's list of called functions
(`called_functions`): the same direction counts as walking the derivative functions' call
instructions, which it replaced in session 29 (docs/results/planner_speed_startup.md)."""

from __future__ import annotations

import re

import casadi as ca
import pytest

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.solver_cache import DERIVATIVE_FUNCTIONS, called_functions, used_directions
from planner.nlp.spacetime import GaitPlanner


def _walked(solver: ca.Function) -> list[str]:
    """Every function called by an OP_CALL instruction of the solver's derivative functions."""
    names = []
    for name in DERIVATIVE_FUNCTIONS:
        function = solver.get_function(name)
        names += [function.instruction_MX(k).which_function().name()
                  for k in range(function.n_instructions())
                  if function.instruction_id(k) == ca.OP_CALL]
    return names


@pytest.mark.parametrize(("robot_name", "options"), [
    # forward and second-order directions (CasADi's AD Hessian, whatever the default)
    ("quad12", PlannerOptions(nlp_jacobian="ad", nlp_hessian="ad")),
    # flat feet: flat_knot and soles have directions of their own
    ("biped", PlannerOptions(nlp_hessian="ad")),
])
def test_called_functions_are_the_call_instructions(robot_name: str,
                                                    options: PlannerOptions) -> None:
    planner = GaitPlanner(robots.load(robot_name), 8, options)
    solver = planner._solver
    assert sorted(set(called_functions(solver))) == sorted(set(_walked(solver)))
    knots = ["knot", *[name for name, *_ in (planner.derived.made if planner.derived else [])]]
    walked_names = _walked(solver)
    for knot in knots:
        forward, second = used_directions(solver, knot)
        assert second, knot  # the AD Hessian calls fwd<n>_adj1_… of every one
        for counts, middle in ((forward, "_"), (second, "_adj1_")):
            pattern = re.compile(rf"fwd(\d+){middle}map8_{knot}")
            walked = {int(m.group(1)) for c in walked_names if (m := pattern.fullmatch(c))}
            assert set(counts) == walked, (knot, counts, walked)

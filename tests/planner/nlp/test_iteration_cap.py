"""planner.nlp.config.iteration_cap: IPOPT's iteration cap follows the NLP's size (issue #14
item 4) unless `PlannerOptions.max_iter` sets it."""

from __future__ import annotations

import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import (
    BASE_ITERATION_CAP,
    MAX_ITERATION_CAP,
    REFERENCE_VARIABLES,
    PlannerOptions,
    iteration_cap,
)
from planner.nlp.spacetime import GaitPlanner, ipopt_options


def test_cap_grows_with_the_square_root_of_the_size_between_its_floor_and_ceiling() -> None:
    assert iteration_cap(REFERENCE_VARIABLES) == BASE_ITERATION_CAP
    assert iteration_cap(100) == BASE_ITERATION_CAP  # small problems keep the floor
    assert iteration_cap(4 * REFERENCE_VARIABLES) == 2 * BASE_ITERATION_CAP
    assert iteration_cap(10**9) == MAX_ITERATION_CAP
    caps = [iteration_cap(n) for n in range(1000, 60000, 1000)]
    assert caps == sorted(caps)
    with pytest.raises(PlannerConfigError):
        iteration_cap(0)


def test_an_explicit_cap_wins_and_is_bounded() -> None:
    assert PlannerOptions(max_iter=40).max_iter_for(10**6) == 40
    assert PlannerOptions().max_iter_for(4 * REFERENCE_VARIABLES) == 2 * BASE_ITERATION_CAP
    for bad in (0, MAX_ITERATION_CAP + 1):
        with pytest.raises(PlannerConfigError, match="max_iter"):
            PlannerOptions(max_iter=bad)


def test_the_planner_hands_ipopt_the_cap_of_its_own_size() -> None:
    bot = robots.load("hex18")
    planner = GaitPlanner(bot, 16)
    assert planner.options.max_iter == iteration_cap(planner.layout.size)
    assert ipopt_options(planner.options, warm=False)["max_iter"] == planner.options.max_iter
    assert GaitPlanner(bot, 16, PlannerOptions(max_iter=33)).options.max_iter == 33

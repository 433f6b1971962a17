"""Shared planners: the NLP is built once per robot for the whole planner test session."""

from __future__ import annotations

import os

import pytest

import robots
from planner.nlp.spacetime import GaitPlanner

os.environ.setdefault("OMP_NUM_THREADS", "1")


@pytest.fixture(scope="session")
def quad_planner() -> GaitPlanner:
    return GaitPlanner(robots.load("quad12"), n_knots=30)


@pytest.fixture(scope="session")
def hex_planner() -> GaitPlanner:
    return GaitPlanner(robots.load("hex18"), n_knots=30)

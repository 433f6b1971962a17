"""Shared fixtures of the sim tests: robots and synthetic gaits (the planner is not needed)."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import pytest

import robots
from robots.gait import Gait
from robots.robot import Robot
from sim.synthetic import kinematic_gait, standing_gait, trot_schedule


@pytest.fixture(scope="session")
def quad() -> Robot:
    return robots.load("quad12")


@pytest.fixture(scope="session")
def hex18() -> Robot:
    return robots.load("hex18")


@pytest.fixture(scope="session")
def hex_tripod(hex18: Robot) -> Gait:
    """A slow kinematic tripod on hex18 (0.1 m/s): walks at the commanded speed in MuJoCo."""
    return kinematic_gait(hex18, trot_schedule(hex18, 0.5, 0.6), 0.1)


@pytest.fixture(scope="session")
def quad_stand(quad: Robot) -> Gait:
    return standing_gait(quad)

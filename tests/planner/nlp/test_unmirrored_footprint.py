"""The mean-footprint rows for robots whose feet are not all in mirror pairs
(`PlannerOptions.unmirrored_mean_footprint_leg_lengths`)."""

from __future__ import annotations

from pathlib import Path

import pytest

import robots
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import _mean_footprint_groups, footprint_unheld_by_symmetry
from planner.nlp.model import RobotModel
from planner.nlp.variables import Layout, make_symbols

ZOO = Path(__file__).resolve().parents[2] / "zoo"
N = 6


def _groups(robot: robots.Robot, options: PlannerOptions) -> list[tuple[str, int]]:
    model = RobotModel(robot)
    sym = make_symbols(Layout(N, model.n_joints, model.n_feet, len(model.flat_feet)))
    return [(g.name, g.expr.shape[0]) for g in _mean_footprint_groups(model, sym, N, options)]


def test_only_a_robot_with_a_foot_out_of_mirror_pairs_is_unheld() -> None:
    assert footprint_unheld_by_symmetry(robots.load(ZOO / "star5"))  # leg_000 on the midline
    for name in ("quad12", "hex18", "biped"):
        assert not footprint_unheld_by_symmetry(robots.load(name))


def test_star5_gets_the_rows_by_default_and_mirror_pair_robots_do_not() -> None:
    star = robots.load(ZOO / "star5")
    assert _groups(star, PlannerOptions()) == [("mean footprint", 2 * 5)]
    assert _groups(star, PlannerOptions(unmirrored_mean_footprint_leg_lengths=None)) == []
    assert _groups(robots.load("quad12"), PlannerOptions()) == []
    # an explicit option wins (one group, not two)
    assert _groups(star, PlannerOptions(mean_footprint_leg_lengths=0.2)) == [
        ("mean footprint", 2 * 5)
    ]


def test_the_option_is_checked() -> None:
    with pytest.raises(Exception, match="unmirrored_mean_footprint"):
        PlannerOptions(unmirrored_mean_footprint_leg_lengths=0.0)

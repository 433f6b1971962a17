"""`gaitsmith plan ROBOT --speed 0 --simulate` end to end (real NLP, real MuJoCo): a stand on a
quadruped and a zoo robot, stepping in place on a quadruped (walk and trot), a hexapod and a zoo
hexapod — all pass the zero-command criteria (drift, heading, tilt, fall, slip, torque) — and
the in-place options (`planner.nlp.command.in_place_options`) chosen only for stepping at zero
command."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import robots
from gaitsmith.cli import main
from gaitsmith.gait_choice import in_place_choice, steps
from planner.nlp.command import (
    IN_PLACE_FOOTPRINT_LEG_LENGTHS,
    IN_PLACE_SWING_CLEARANCE_LEG_LENGTHS,
    in_place_options,
    stance_com_offset_m,
)
from planner.nlp.config import PlannerOptions
from planner.templates import default_gait_for, make_schedule
from tests.zoo.fixtures import ZOO

CASES = [
    pytest.param("quad12", [], id="quad12-stand"),
    pytest.param(str(ZOO / "star5"), [], id="star5-stand"),
    pytest.param("quad12", ["--gait", "walk"], id="quad12-walk-in-place"),
    # drifted 23.5 mm/s and 280 mm with the walking options (footprint free, 0.14 L clearance)
    pytest.param("quad12", ["--gait", "trot"], id="quad12-trot-in-place"),
    pytest.param("hex18", ["--gait", "tripod"], id="hex18-tripod-in-place"),
    pytest.param(str(ZOO / "phantomx18"), ["--gait", "tripod"],
                 id="phantomx18-tripod-in-place"),
]


@pytest.mark.slow
@pytest.mark.parametrize(("robot", "extra"), CASES)
def test_speed_zero_plans_pass_mujoco(robot: str, extra: list[str], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "g.json"
    code = main(["plan", robot, "--speed", "0", "--knots", "16", *extra, "-o", str(out),
                 "--simulate"])
    printed = " ".join(capsys.readouterr().out.split())
    assert code in (0, None), printed[-2000:]
    gait = json.loads(out.read_text())
    v = gait["validation"]
    assert v["passed"] is True, v["reasons"]
    checks = {c["name"]: c for c in v["checks"]}
    assert "speed" not in checks and checks["drift"]["ok"]
    duty = gait["schedule"]["duty_factor"]
    if "--gait" in extra:
        assert max(duty) < 1.0 and v["metrics"]["stances"] > 0  # it steps
        assert "simulation verdict (20 cycles)" in printed
        assert "stepping in place: each foot's cycle mean within 0.01 L" in printed
    else:
        assert set(duty) == {1.0} and gait["gait_label"] == "stand"
        assert v["metrics"]["duration_s"] >= 10.0  # a stand is judged over a duration
        assert "simulation verdict (standing 1" in printed


def test_in_place_options_anchor_footprint_and_height_under_the_centre_of_mass() -> None:
    quad = robots.load("quad12")
    leg_m = quad.leg_length_m
    got = in_place_options(PlannerOptions(mu=0.4), quad, centre_under_com=True)
    assert got.mean_footprint_leg_lengths == IN_PLACE_FOOTPRINT_LEG_LENGTHS
    assert got.swing_clearance_for(leg_m) == pytest.approx(
        IN_PLACE_SWING_CLEARANCE_LEG_LENGTHS * leg_m)
    assert got.swing_clearance_for(leg_m) < PlannerOptions().swing_clearance_for(leg_m)
    assert got.mu == 0.4  # the caller's options otherwise
    # quad12's centre of mass sits 17 mm behind its feet's centroid, on the centre line
    dx, dy = got.mean_footprint_offset_m
    assert dx == pytest.approx(-0.0167, abs=1e-3) and dy == pytest.approx(0.0, abs=1e-6)
    assert stance_com_offset_m(robots.load("hex18")) == pytest.approx((0.0, 0.0), abs=1e-6)
    trot = in_place_options(PlannerOptions(), quad, centre_under_com=False)
    assert trot.mean_footprint_offset_m == (0.0, 0.0)  # the nominal footprint
    # an explicit clearance and a tighter footprint are the caller's
    kept = in_place_options(PlannerOptions(swing_clearance_m=0.03,
                                           mean_footprint_leg_lengths=0.005), quad,
                            centre_under_com=True)
    assert kept.swing_clearance_m == 0.03 and kept.mean_footprint_leg_lengths == 0.005
    looser = in_place_options(PlannerOptions(mean_footprint_leg_lengths=0.05), quad,
                              centre_under_com=False)
    assert looser.mean_footprint_leg_lengths == IN_PLACE_FOOTPRINT_LEG_LENGTHS


@pytest.mark.parametrize(("robot", "on_a_line"),
                         [("quad12", True), ("hex18", False), (str(ZOO / "star5"), False)])
def test_in_place_choice_only_for_stepping_at_zero_command(robot: str, on_a_line: bool) -> None:
    bot = robots.load(robot)
    options = PlannerOptions()
    stand = make_schedule(bot, "stand")
    stepping = make_schedule(bot, default_gait_for(bot))  # trot, tripod, ripple
    assert not steps(stand) and steps(stepping)
    assert in_place_choice(bot, stand, 0.0, 0.0, 0.0, options) is None
    for moving in ((0.1, 0.0, 0.0), (0.0, 0.05, 0.0), (0.0, 0.0, 0.3)):
        assert in_place_choice(bot, stepping, *moving, options) is None
    chosen = in_place_choice(bot, stepping, 0.0, 0.0, 0.0, options)
    assert chosen == in_place_options(options, bot, centre_under_com=not on_a_line)


@pytest.mark.slow
def test_the_footprint_offset_shifts_the_mean_footprint_bounds() -> None:
    """`mean_footprint_offset_m` shifts the nominal footprint the constraint is centred on."""
    from planner.nlp.spacetime import GaitPlanner

    quad = robots.load("quad12")
    base = PlannerOptions(mean_footprint_leg_lengths=0.01)
    shifted = PlannerOptions(mean_footprint_leg_lengths=0.01,
                             mean_footprint_offset_m=(-0.02, 0.005))
    planners = [GaitPlanner(quad, n_knots=8, options=o) for o in (base, shifted)]
    nf = len(quad.legs)
    for bound in ("_lbg", "_ubg"):
        rows = [_footprint_rows(p, bound) for p in planners]
        delta = rows[1] - rows[0]
        assert delta[:nf] == pytest.approx(-0.02) and delta[nf:] == pytest.approx(0.005)


def _footprint_rows(planner: object, bound: str) -> np.ndarray:
    rows = [s for name, s in planner._slices if name == "mean footprint"]  # type: ignore[attr-defined]
    assert len(rows) == 1
    return np.asarray(getattr(planner, bound)[rows[0]])

"""The planner on robots nobody on the project built: any leg count and layout, any size.

Test robots come from `tests.planner.robot_factory`: a 5-leg star (no left/right pairs) and a
0.23 kg quadruped with 7.5 cm legs on XL330 servos.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import robots
from gaitsmith import cli
from planner.errors import PlannerConfigError, TemplateError
from planner.nlp import diagnostics
from planner.nlp.config import (
    SWING_CLEARANCE_LEG_LENGTHS,
    PlannerOptions,
    default_speed_m_s,
    speed_for_froude,
)
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import variable_scale
from planner.search.gait_search import TimingSpace, final_options, searchable_templates
from planner.templates import (
    azimuth_order,
    default_gait_for,
    label_gait,
    make_schedule,
    mirror_permutation,
    stance_foot_positions_m,
    templates_for,
)
from planner.user_schedule import command_schedule, load_schedule_file, parse_duty, parse_phases
from tests.planner.robot_factory import small_quadruped, star_robot
from tests.zoo.fixtures import ZOO


@pytest.fixture(scope="module")
def star5(tmp_path_factory: pytest.TempPathFactory) -> robots.Robot:
    return robots.load(star_robot(tmp_path_factory.mktemp("bots") / "star5", 5))


@pytest.fixture(scope="module")
def mini4(tmp_path_factory: pytest.TempPathFactory) -> robots.Robot:
    return robots.load(small_quadruped(tmp_path_factory.mktemp("bots") / "mini4", head=True))


# -- templates for any leg count ------------------------------------------------------------


def test_five_legs_get_azimuth_templates_and_a_default(star5: robots.Robot) -> None:
    names = templates_for(star5)
    assert names == ["wave", "ripple", "pronk", "stand"]
    assert default_gait_for(star5) == "ripple"
    with pytest.raises(TemplateError, match="try one of: wave, ripple, pronk, stand"):
        make_schedule(star5, "wave_xyz")
    with pytest.raises(TemplateError, match=r"'tripod' is not offered for star5 \(5 legs\)"):
        make_schedule(star5, "tripod")
    # wave: one foot after the other in azimuth order, a fifth of a cycle apart
    wave = make_schedule(star5, "wave")
    order = azimuth_order(star5)
    steps = np.diff([wave.touchdown_phase[f] for f in order])
    np.testing.assert_allclose(steps, 0.2, atol=1e-12)
    pos = stance_foot_positions_m(star5)
    az = (np.arctan2(pos[list(order), 1], pos[list(order), 0]) - math.pi) % (2 * math.pi)
    assert np.all(np.diff(az) > 0)
    # ripple: feet that swing one after the other are not neighbours around the body
    ripple = make_schedule(star5, "ripple")
    assert len(set(ripple.touchdown_phase)) == 5
    for gait in names:
        assert label_gait(make_schedule(star5, gait), star5) == gait


@pytest.mark.parametrize("n_knots", [10, 20, 30, 40, 60])  # fifths of a cycle on knots
def test_azimuth_templates_stand_every_foot_equally_long_on_knots(
        star5: robots.Robot, n_knots: int) -> None:
    """Equal duty factors give every foot the same number of stance knots, and the search's
    encoding (phases relative to the first foot) gives the same contact pattern up to a roll.
    The ripple's 2·3/5 mod 1 was 0.6000000000000001: at 30 knots that foot lost its touchdown
    knot (17 stance knots, the others 18), so the template planned a different NLP than the
    search re-solving the same timing (docs/results/zoo_gaits.md, Session 26: star5's search)."""
    space = TimingSpace.for_robot(star5, False)
    for name in ("wave", "ripple", "pronk"):
        sched = make_schedule(star5, name)
        contact = sched.contact_matrix(n_knots)
        assert len(set(contact.sum(axis=0).tolist())) == 1, name
        x = space.encode(sched)
        assert x is not None
        decoded = space.decode(x).contact_matrix(n_knots)
        assert any(np.array_equal(np.roll(contact, -k, axis=0), decoded)
                   for k in range(n_knots)), name


def test_other_leg_counts_never_have_an_empty_template_list(tmp_path: Path) -> None:
    star3 = robots.load(star_robot(tmp_path / "s3", 3, name="star3"))
    assert templates_for(star3) == ["wave", "pronk", "stand"]
    assert default_gait_for(star3) == "wave"
    # 4 legs at 0/90/180/270°: no left/right pairs, alternating = diagonal pairs (trot-like)
    plus = robots.load(star_robot(tmp_path / "s4", 4, name="plus4"))
    assert "trot" not in templates_for(plus) and default_gait_for(plus) == "alternating"
    alt = make_schedule(plus, "alternating")
    order = azimuth_order(plus)
    assert [alt.touchdown_phase[f] for f in order] == [0.0, 0.5, 0.0, 0.5]
    # the same legs turned by 45°: left/right pairs, so the named quadruped gaits apply
    cross = robots.load(star_robot(tmp_path / "x4", 4, first_azimuth_rad=math.pi / 4,
                                   name="cross4"))
    assert default_gait_for(cross) == "trot" and "alternating" not in templates_for(cross)
    six = robots.load(star_robot(tmp_path / "s6", 6, first_azimuth_rad=math.pi / 6, name="s6"))
    assert default_gait_for(six) == "tripod"
    seven = robots.load(star_robot(tmp_path / "s7", 7, name="s7"))
    assert default_gait_for(seven) == "ripple" and "wave" in templates_for(seven)


def test_held_joints_outside_the_legs_change_nothing_about_the_templates(tmp_path: Path) -> None:
    bot = robots.load(small_quadruped(tmp_path / "headed", head=True))
    assert bot.hold_joint_names == ("head_pan",) and len(bot.legs) == 4
    assert default_gait_for(bot) == "trot" and mirror_permutation(bot) == (1, 0, 3, 2)
    assert TimingSpace.for_robot(bot).symmetric


def test_builtin_robots_keep_their_named_defaults() -> None:
    assert default_gait_for(robots.load("quad12")) == "trot"
    assert default_gait_for(robots.load("hex18")) == "tripod"


@pytest.mark.parametrize("name", ["bittle8", "knee8"])
def test_hip_and_knee_quadrupeds_walk_by_default(name: str) -> None:
    # no hip roll: a trot's diagonal support has nothing holding the roll (templates docstring)
    bot = robots.load(ZOO / name)
    assert default_gait_for(bot) == "walk"
    assert default_gait_for(robots.load(ZOO / "spotmicro")) == "trot"  # hip roll: trots


# -- search without left/right roles ----------------------------------------------------------


def test_mirror_symmetry_is_detected_from_foot_positions(
    star5: robots.Robot, tmp_path: Path
) -> None:
    assert mirror_permutation(star5) == (0, 4, 3, 2, 1)  # l0 on the midline, pairs 1-4, 2-3
    space = TimingSpace.for_robot(star5, symmetric=True)
    assert space.symmetric and space.mirror == (4, 3) and space.searched == (1, 2, 0)
    x = np.array([0.8, 0.3, 0.6, 0.7, 0.65, 0.75])
    sched = space.decode(x)
    assert (sched.touchdown_phase[4] - sched.touchdown_phase[1]) % 1.0 == pytest.approx(0.5)
    assert sched.duty_factor[3] == sched.duty_factor[2]
    encoded = space.encode(sched)
    assert encoded is not None
    np.testing.assert_allclose(encoded, x)
    turned = robots.load(star_robot(tmp_path / "t5", 5, first_azimuth_rad=0.3, name="t5"))
    assert mirror_permutation(turned) is None
    space = TimingSpace.for_robot(turned, symmetric=True)
    assert not space.symmetric and space.dim == 1 + 4 + 5
    for gait in searchable_templates(turned):
        assert space.encode(make_schedule(turned, gait)) is not None
    assert "stand" not in searchable_templates(turned)


# -- feasible reported as feasible -------------------------------------------------------------


def test_status_mapping_accepts_a_feasible_point_with_a_documented_status() -> None:
    assert diagnostics.judge("Solve_Succeeded", 1e-8) == (True, True)
    assert diagnostics.judge("Maximum_Iterations_Exceeded", 1e-8) == (True, False)
    assert diagnostics.judge("Solved_To_Acceptable_Level", 5e-5) == (True, False)
    assert diagnostics.judge("Maximum_Iterations_Exceeded", 1e-3) == (False, False)
    assert diagnostics.judge("Infeasible_Problem_Detected", 1e-8) == (False, False)
    assert diagnostics.judge("Invalid_Number_Detected", math.nan) == (False, False)


# -- scaling with the body --------------------------------------------------------------------


def test_clearances_and_speeds_scale_with_the_leg(mini4: robots.Robot) -> None:
    o = PlannerOptions()
    assert o.swing_clearance_for(mini4.leg_length_m) == pytest.approx(
        SWING_CLEARANCE_LEG_LENGTHS * mini4.leg_length_m)
    assert o.swing_clearance_for(0.075) < 0.011  # not 25 mm = a third of the leg
    assert PlannerOptions(swing_clearance_m=0.02).swing_clearance_for(0.075) == 0.02
    assert o.body_clearance_for(0.075) == pytest.approx(0.17 * 0.075)
    assert default_speed_m_s(0.176) == pytest.approx(0.246, abs=0.002)
    froude = default_speed_m_s(0.075) ** 2 / (9.81 * 0.075)
    assert froude == pytest.approx(default_speed_m_s(0.3) ** 2 / (9.81 * 0.3))
    with pytest.raises(PlannerConfigError):
        speed_for_froude(-1.0, 0.1)


def test_joint_limit_margin_in_rad_or_fraction_of_range() -> None:
    lo, hi = np.array([-0.5, -2.4, -0.01]), np.array([0.5, 0.0, 0.01])
    m = PlannerOptions(joint_limit_margin_rad=0.02, joint_limit_margin_fraction=0.05)
    np.testing.assert_allclose(m.joint_limit_margins_rad(lo, hi), [0.05, 0.12, 0.005])
    with pytest.raises(PlannerConfigError, match="joint_limit_margin_fraction"):
        PlannerOptions(joint_limit_margin_fraction=0.3)


# -- user schedules ---------------------------------------------------------------------------


def test_phases_and_duty_from_the_command_line(star5: robots.Robot) -> None:
    assert parse_phases("0,0.2,0.4,0.6,0.8", star5) == (0.0, 0.2, 0.4, 0.6, 0.8)
    assert parse_duty("0.7", star5) == (0.7,) * 5
    assert parse_duty("0.7,0.7,0.8,0.8,0.8", star5)[2] == 0.8
    with pytest.raises(PlannerConfigError, match=r"--phases has 4 values, star5 has 5 legs"):
        parse_phases("0,0.5,0.25,0.75", star5)
    with pytest.raises(PlannerConfigError, match="--phases for leg l2 must be a touchdown phase"):
        parse_phases("0,0.2,1.4,0.6,0.8", star5)
    with pytest.raises(PlannerConfigError, match=r"--phases: value 2 \('x'\) is not a number"):
        parse_phases("0,x,0.4,0.6,0.8", star5)
    with pytest.raises(PlannerConfigError, match="--duty for leg l4 must be a duty factor"):
        parse_duty("0.7,0.7,0.8,0.8,0", star5)
    with pytest.raises(PlannerConfigError, match="--duty has 2 values"):
        parse_duty("0.7,0.7", star5)
    sched, label = command_schedule(star5, "ripple", phases="0,0.2,0.4,0.6,0.8", duty="0.75")
    assert label == "custom" and sched.duty_factor == (0.75,) * 5 and sched.period_s > 0
    sched, label = command_schedule(star5, "wave", duty="0.7,0.7,0.8,0.8,0.8", period_s=1.1)
    assert label == "wave" and sched.period_s == 1.1 and sched.duty_factor[4] == 0.8


def test_schedule_files_json_and_toml(star5: robots.Robot, tmp_path: Path) -> None:
    legs = {f"l{i}": {"touchdown_phase": i / 5, "duty_factor": 0.7} for i in range(5)}
    j = tmp_path / "s.json"
    j.write_text(json.dumps({"period_s": 0.9, "legs": legs}))
    s = load_schedule_file(j, star5)
    assert s.period_s == 0.9 and s.touchdown_phase[3] == pytest.approx(0.6)
    t = tmp_path / "s.toml"
    t.write_text("".join(f"[legs.l{i}]\ntouchdown_phase = {i / 5}\nduty_factor = 0.7\n"
                         for i in range(5)))
    assert load_schedule_file(t, star5).touchdown_phase == s.touchdown_phase
    bad = dict(legs)
    bad["leg9"] = {"touchdown_phase": 0.0, "duty_factor": 0.5}
    j.write_text(json.dumps({"legs": bad}))
    with pytest.raises(PlannerConfigError, match=r"legs\.leg9: star5 has no leg"):
        load_schedule_file(j, star5)
    del bad["leg9"], bad["l3"]
    j.write_text(json.dumps({"legs": bad}))
    with pytest.raises(PlannerConfigError, match=r"legs\.l3: missing"):
        load_schedule_file(j, star5)
    j.write_text(json.dumps({"legs": {**legs, "l1": {"touchdown_phase": 0.1, "duty": 0.5}}}))
    with pytest.raises(PlannerConfigError, match=r"legs\.l1\.duty: unknown field"):
        load_schedule_file(j, star5)
    j.write_text("{not json")
    with pytest.raises(PlannerConfigError, match="not valid JSON"):
        load_schedule_file(j, star5)
    with pytest.raises(PlannerConfigError, match="no such file"):
        load_schedule_file(tmp_path / "none.toml", star5)
    with pytest.raises(PlannerConfigError, match="drop --phases/--duty"):
        command_schedule(star5, "wave", phases="0,0,0,0,0", schedule_file=t)


def test_plan_command_rejects_a_bad_schedule_in_one_line(
    star5: robots.Robot, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    code = cli.main(["plan", str(star5.root_dir), "--gait", "wave", "--phases", "0,0.5",
                     "-o", str(out)])
    err = capsys.readouterr()
    assert code == 2 and not out.exists()
    text = (err.err + err.out).strip()
    assert "--phases has 2 values, star5 has 5 legs" in text and "Traceback" not in text


# -- nondimensional NLP -----------------------------------------------------------------------


def test_variable_scale_uses_leg_length_time_unit_and_weight(mini4: robots.Robot) -> None:
    from planner.nlp.model import RobotModel
    from planner.nlp.variables import Layout

    model = RobotModel(mini4)
    layout = Layout(12, model.n_joints, model.n_feet)
    scale = variable_scale(layout, model)
    assert scale.shape == (layout.size,) and np.all(scale > 0)
    length, t0 = mini4.leg_length_m, math.sqrt(mini4.leg_length_m / 9.81)
    assert scale[0] == pytest.approx(length) and scale[3] == 1.0  # base x, roll
    tau = scale[layout.block("tau").start]
    assert tau == pytest.approx(model.total_mass_kg * 9.81 * length)
    assert scale[-1] == pytest.approx(1 / t0)


# -- solves (small N) -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def star5_planner(star5: robots.Robot) -> GaitPlanner:
    # also the search's final planner: built as the search builds it (`final_options`)
    return GaitPlanner(star5, n_knots=12, options=final_options(PlannerOptions()))


@pytest.fixture(scope="module")
def mini4_planner(mini4: robots.Robot) -> GaitPlanner:
    return GaitPlanner(mini4, n_knots=12)


@pytest.mark.slow
def test_five_leg_star_plans_its_default_gait_with_limit_margins(
    star5_planner: GaitPlanner, tmp_path: Path
) -> None:
    robot = star5_planner.robot
    gait = default_gait_for(robot)
    result = star5_planner.solve(make_schedule(robot, gait), 0.1, warm_start=False)
    assert result.feasible and result.optimal, result.message
    gait_obj = star5_planner.to_gait(result, gait)
    path = tmp_path / "star5.json"
    robots.gait.save(gait_obj, path)
    meta = robots.gait.load(path, robot).planner
    clearance = meta["joint_limit_clearance"]
    assert set(clearance) == set(robot.joint_names)
    for row in clearance.values():
        assert row["closest_rad"] >= row["margin_rad"] - 1e-6
        assert row["closest_rad"] == min(row["to_lower_rad"], row["to_upper_rad"])
    assert meta["swing_clearance_m"] == pytest.approx(0.14 * robot.leg_length_m)
    assert "posture_rad2" in meta["objective_terms"]


@pytest.mark.slow
def test_a_feasible_point_at_the_iteration_cap_is_a_gait(mini4_planner: GaitPlanner) -> None:
    """The bug: a run that met every constraint to 1e-8 but stopped at IPOPT's iteration cap
    was reported as "no feasible gait". Same point, status Maximum_Iterations_Exceeded."""
    robot = mini4_planner.robot
    schedule = make_schedule(robot, "trot")
    speed = default_speed_m_s(robot.leg_length_m)
    done = mini4_planner.solve(schedule, speed, warm_start=False)
    assert done.feasible and done.optimal and done.max_violation < 1e-6, done.message
    p = np.asarray(mini4_planner._solver_parameters(schedule, speed))
    ws = done.warm_start
    capped = mini4_planner._result(
        schedule, speed, p,
        {"x": ws.x, "lam_x": ws.lam_x, "lam_g": ws.lam_g, "f": done.cost},
        {"return_status": "Maximum_Iterations_Exceeded", "iter_count": 150}, 1.0,
        mini4_planner._solve_bounds(schedule),
    )
    assert capped.feasible and not capped.optimal
    assert "Maximum_Iterations_Exceeded" in capped.message and "not proven" in capped.message
    mini4_planner.to_gait(capped, "trot")  # a gait file, not InfeasibleGaitError
    with pytest.raises(PlannerConfigError, match="foot fl never lifts off"):
        mini4_planner.solve(make_schedule(robot, "stand"), 0.1)
    assert mini4_planner.solve(make_schedule(robot, "stand"), 0.0, warm_start=False).feasible


@pytest.mark.slow
def test_search_runs_on_five_legs_without_left_right_roles(star5_planner: GaitPlanner) -> None:
    from planner.search.gait_search import search_gait

    robot = star5_planner.robot
    result = search_gait(robot, 0.1, n_knots=12, max_generations=1, popsize=3, seed=0,
                         planner=star5_planner, search_knots=12)
    assert set(result.template_costs) == {"wave", "ripple", "pronk"}
    assert result.best.feasible and result.label in templates_for(robot)
    # the star has mirror pairs (l1-l4, l2-l3) but none of its templates runs them half a
    # period apart, so every foot's timing is searched
    assert not result.symmetric and result.cma.n_local_solves >= 3


@pytest.mark.slow
def test_nondimensional_nlp_has_the_same_optimum(
    mini4: robots.Robot, mini4_planner: GaitPlanner
) -> None:
    scaled = GaitPlanner(mini4, n_knots=12, options=PlannerOptions(nondimensional=True))
    schedule = make_schedule(mini4, "pronk")
    a = mini4_planner.solve(schedule, 0.1, warm_start=False)
    b = scaled.solve(schedule, 0.1, warm_start=False)
    assert a.feasible and b.feasible, (a.message, b.message)
    assert b.cost == pytest.approx(a.cost, rel=1e-3)
    np.testing.assert_allclose(b.joint_angles_rad, a.joint_angles_rad, atol=2e-2)


@pytest.mark.slow
def test_plan_command_solves_a_schedule_file(
    mini4: robots.Robot, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sched = tmp_path / "walk.toml"
    sched.write_text("period_s = 0.5\n" + "".join(
        f"[legs.{leg}]\ntouchdown_phase = {ph}\nduty_factor = 0.75\n"
        for leg, ph in zip(mini4.foot_names, (0.25, 0.75, 0.0, 0.5), strict=True)))
    out = tmp_path / "walk.json"
    code = cli.main(["plan", str(mini4.root_dir), "--schedule", str(sched), "--speed", "0.1",
                     "--knots", "12", "-o", str(out)])
    assert code == 0, capsys.readouterr()
    gait = robots.gait.load(out, mini4)
    assert gait.gait_label == "custom" and gait.period_s == pytest.approx(0.5)
    assert "joint_limit_clearance" in gait.planner

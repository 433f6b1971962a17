"""`gaitsmith plan ROBOT --gait G`: a symmetric template is solved on half its knots by default
(`--half-cycle`, `PlannerOptions.half_cycle_solve`) and writes the gait of the full solve
(`--full-cycle`; real NLP); anything else — an asymmetric schedule, a turn, a body with no
mirror images — is solved in full, with or without the flag, and the gait file says which."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gaitsmith.cli import main


def _plan(tmp_path: Path, name: str, *extra: str, robot: str = "quad12",
          speed: str = "0.25") -> dict:
    out = tmp_path / f"{name}.json"
    assert main(["plan", robot, "--speed", speed, "--knots", "12", *extra, "-o", str(out)]) == 0
    gait: dict = json.loads(out.read_text())
    return gait


def test_a_trot_on_half_its_knots_by_default_is_the_full_solves_trot(tmp_path: Path) -> None:
    full = _plan(tmp_path, "full", "--gait", "trot", "--full-cycle")
    half = _plan(tmp_path, "half", "--gait", "trot")
    asked = _plan(tmp_path, "asked", "--gait", "trot", "--half-cycle")
    assert full["planner"]["solver"]["half_cycle"] is False
    assert half["planner"]["solver"]["half_cycle"] is True
    assert half["planner"]["objective"] == pytest.approx(full["planner"]["objective"], rel=1e-9)
    assert half["planner"]["solver"]["iterations"] == full["planner"]["solver"]["iterations"]
    assert asked["planner"]["objective"] == half["planner"]["objective"]


@pytest.mark.parametrize("flag", [[], ["--half-cycle"]])
@pytest.mark.parametrize("case", [
    ["--gait", "bound"],  # not half-cycle symmetric
    ["--phases", "0,0.25,0.5,0.75"],  # a given schedule that is not
    ["--gait", "trot", "--yaw-rate", "0.2"],  # a turn
])
def test_what_the_half_cycle_does_not_fit_is_solved_in_full(
        tmp_path: Path, case: list[str], flag: list[str]) -> None:
    gait = _plan(tmp_path, "g", *case, *flag)
    assert gait["planner"]["solver"]["half_cycle"] is False


def test_a_body_with_no_mirror_images_is_solved_in_full(tmp_path: Path) -> None:
    """A four-leg star turned 0.3 rad has no left–right foot images (`mirror_permutation` None):
    its trot plans in full under the default."""
    import robots
    from planner.templates import mirror_permutation
    from tests.planner.robot_factory import star_robot

    folder = star_robot(tmp_path / "star4", 4, first_azimuth_rad=0.3)
    assert mirror_permutation(robots.load(str(folder))) is None
    gait = _plan(tmp_path, "star", "--gait", "trot", robot=str(folder), speed="0.1")
    assert gait["planner"]["solver"]["half_cycle"] is False


def test_a_body_whose_masses_do_not_mirror_is_solved_in_full_and_says_why(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tests.planner.robot_factory import quad12_with_torso_inertial

    # a battery off to one side: the torso's centre of mass 5 mm to the left
    folder = quad12_with_torso_inertial(tmp_path / "lopsided", "lopsided",
                                        com_shift_m=(0.0, 0.005, 0.0))
    gait = _plan(tmp_path, "g", "--gait", "trot", robot=str(folder))
    solver = gait["planner"]["solver"]
    assert solver["half_cycle"] is False and "half_cycle_dropped_violation" not in solver
    assert solver["half_cycle_asymmetry"]["rows"] == "dynamics"
    out = " ".join(capsys.readouterr().out.split())
    assert "not used: the dynamics rows are not left–right mirror images" in out


def test_the_help_says_what_the_unset_flag_means() -> None:
    """Unset, --half-cycle/--full-cycle means half-cycle for the planned gait and (since session
    40) for --search's final re-solves too (`gaitsmith.plan_options.template_half_cycle`,
    `search_final_half_cycle`); given, it sets both."""
    import inspect

    from gaitsmith.plan_cmd import plan
    from gaitsmith.plan_options import search_final_half_cycle, template_half_cycle

    option = inspect.signature(plan).parameters["half_cycle"].default
    assert option.default is None
    assert "Default: half-cycle for the planned gait, the templates --search re-solves and the " \
        "searched candidates it re-solves (a candidate whose half-cycle plan fails the MuJoCo " \
        "check narrowly is re-solved on all knots); given, it sets both" \
        in " ".join(option.help.split())
    assert (template_half_cycle(None), search_final_half_cycle(None)) == (True, True)
    for given in (True, False):
        assert template_half_cycle(given) is search_final_half_cycle(given) is given

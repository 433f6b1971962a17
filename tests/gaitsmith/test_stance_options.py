"""`gaitsmith plan` applies the stance-compliance rule (`planner.compliant_stance`,
`gaitsmith.stance_options`) on the template and the search path: the options the user left
out take the rule's values, a flag wins, robots the rule does not cover are untouched."""

from __future__ import annotations

from typing import Any

import pytest

import planner.search.gait_search
import robots
from gaitsmith import plan_cmd
from gaitsmith.cli import main
from gaitsmith.stance_options import stance_shaped
from planner.nlp.config import CostWeights
from tests.gaitsmith.capture import captured_kwargs
from tests.zoo.fixtures import ZOO

H20 = str(ZOO / "humanoid20")


def _template_options(monkeypatch: pytest.MonkeyPatch, args: list[str]) -> Any:
    return captured_kwargs(monkeypatch, plan_cmd, "GaitPlanner", ["plan", *args])["options"]


def _search_kwargs(monkeypatch: pytest.MonkeyPatch, args: list[str]) -> dict[str, Any]:
    return captured_kwargs(monkeypatch, planner.search.gait_search, "search_gait",
                           ["plan", *args, "--search"])


def test_template_on_a_compliant_stance_gets_the_rule(monkeypatch: pytest.MonkeyPatch,
                                                      tmp_path: Any) -> None:
    o = _template_options(monkeypatch, [H20, "--speed", "0.215", "-o", str(tmp_path / "g")])
    assert o.normal_force_rate_weights_per_t0 == 10.0
    assert o.weights.bounce_s2_m2 == 30.0


def test_search_on_a_compliant_stance_gets_the_rule(monkeypatch: pytest.MonkeyPatch,
                                                    tmp_path: Any) -> None:
    kw = _search_kwargs(monkeypatch, [H20, "--speed", "0.215", "-o", str(tmp_path / "g")])
    assert kw["options"].normal_force_rate_weights_per_t0 == 10.0
    assert kw["options"].weights.bounce_s2_m2 == 30.0
    assert kw["acceptance"].entry_cycles == 3 and kw["final_acceptance"].entry_cycles == 3


def test_flags_override_the_rule(monkeypatch: pytest.MonkeyPatch, tmp_path: Any) -> None:
    """--force-rate 0 switches the rate rows off; --bounce-weight and --entry-cycles win."""
    kw = _search_kwargs(monkeypatch, [H20, "--speed", "0.215", "--force-rate", "0",
                                      "--bounce-weight", "12", "--entry-cycles", "1",
                                      "-o", str(tmp_path / "g")])
    assert kw["options"].normal_force_rate_weights_per_t0 is None
    assert kw["options"].weights.bounce_s2_m2 == 12.0
    assert kw["acceptance"].entry_cycles == 1


@pytest.mark.parametrize("robot", ["biped", "quad12"])
def test_stiff_or_point_footed_robots_are_untouched(robot: str, monkeypatch: pytest.MonkeyPatch,
                                                    tmp_path: Any) -> None:
    o = _template_options(monkeypatch, [robot, "--speed", "0.1", "-o", str(tmp_path / "g")])
    assert o.normal_force_rate_weights_per_t0 is None
    assert o.weights.bounce_s2_m2 == CostWeights().bounce_s2_m2
    kw = _search_kwargs(monkeypatch, [robot, "--speed", "0.1", "-o", str(tmp_path / "g")])
    assert kw["options"].normal_force_rate_weights_per_t0 is None
    assert kw["acceptance"].entry_cycles == 1


def test_the_record_says_what_was_used() -> None:
    shaped = stance_shaped(robots.load(ZOO / "humanoid20"), None, None, 20.0, None)
    assert (shaped.force_rate, shaped.bounce, shaped.entry) == (10.0, 20.0, 3)
    meta = shaped.metadata
    assert meta["applies"] and meta["user_set"] == ["bounce_weight"]
    assert meta["used"] == {"normal_force_rate_weights_per_t0": 10.0, "bounce_s2_m2": 20.0,
                            "entry_cycles": 3}
    assert meta["loop_gain"] == pytest.approx(0.61, abs=0.01)
    assert stance_shaped(robots.load("quad12"), None, None, None, None).metadata == {}


@pytest.mark.slow
def test_the_gait_file_records_the_rule(tmp_path: Any) -> None:
    """humanoid20's template with no flags: the file asks for the 3-cycle entry and records
    the figure and the values used (30-knot solve, no simulation)."""
    out = tmp_path / "g.json"
    assert main(["plan", H20, "--speed", "0.215", "-o", str(out)]) == 0
    gait = robots.gait.load(out)
    assert gait.planner["entry_blend_cycles"] == 3
    assert gait.planner["weights"]["bounce_s2_m2"] == 30.0
    assert gait.planner["stance_compliance"]["used"]["normal_force_rate_weights_per_t0"] == 10.0


@pytest.mark.parametrize(("robot", "compliant"), [(H20, True), ("biped", False)])
def test_sweep_applies_the_rule_like_plan(monkeypatch: pytest.MonkeyPatch, tmp_path: Any,
                                          robot: str, compliant: bool) -> None:
    """`gaitsmith sweep` plans and judges with the same rule as `plan`: the rule's force rate
    and bounce weight in the options, its entry cycles in the MuJoCo acceptance."""
    from gaitsmith import sweep_cmd

    seen = captured_kwargs(monkeypatch, sweep_cmd, "sweep_speeds",
                           ["sweep", robot, "--speeds", "0.1", "-o", str(tmp_path / "out")])
    options = seen["options"]
    if compliant:
        assert options.normal_force_rate_weights_per_t0 == 10.0
        assert options.weights.bounce_s2_m2 == 3 * CostWeights().bounce_s2_m2
        assert seen["acceptance"].entry_cycles == 3
        assert seen["final_acceptance"].entry_cycles == 3
    else:
        assert options.normal_force_rate_weights_per_t0 is None
        assert options.weights == CostWeights()
        assert seen["acceptance"].entry_cycles == 1

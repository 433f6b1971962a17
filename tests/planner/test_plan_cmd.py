"""`gaitsmith plan`: writes a gait file, or fails with a one-line PlannerError and no file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import robots
from gaitsmith import cli, plan_cmd
from planner.nlp.spacetime import GaitPlanner


@pytest.fixture()
def reuse_planner(monkeypatch: pytest.MonkeyPatch, quad_planner: GaitPlanner) -> None:
    """Reuse the session's quad12 NLP instead of building another (same default options)."""

    def factory(robot: robots.Robot, n_knots: int = 30, options: Any = None) -> GaitPlanner:
        assert robot.name == "quad12" and n_knots == quad_planner.n_knots
        return quad_planner

    monkeypatch.setattr(plan_cmd, "GaitPlanner", factory)


def test_plan_writes_a_gait_file(
    reuse_planner: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "trot.json"
    assert cli.main(["plan", "quad12", "--gait", "trot", "--speed", "0.25", "-o", str(out)]) == 0
    gait = robots.gait.load(out, robots.load("quad12"))
    assert gait.gait_label == "trot" and gait.velocity.vx_m_s == 0.25
    assert gait.planner["solver"]["iterations"] > 0
    assert "servo load" in capsys.readouterr().out


def test_infeasible_plan_exits_2_without_a_file(
    reuse_planner: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "fast.json"
    assert cli.main(["plan", "quad12", "--gait", "trot", "--speed", "2.0", "-o", str(out)]) == 2
    assert not out.exists()
    err = " ".join(capsys.readouterr().err.split())  # the CLI wraps long messages
    assert "binding limits" in err and "no gait file written" in err
    assert "try a lower --speed, another --gait, or --search" in err  # what to do


def test_unknown_gait_is_a_user_error(tmp_path: Path) -> None:
    assert cli.main(["plan", "hex18", "--gait", "trot", "-o", str(tmp_path / "x.json")]) == 2

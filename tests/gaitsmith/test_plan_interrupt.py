"""Ctrl-C during `gaitsmith plan`'s solve is an interruption (exit 130), not an infeasible gait."""

from __future__ import annotations

import signal
from typing import Any

import pytest

import robots
from gaitsmith import plan_cmd
from gaitsmith.cli import main
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule


def test_ctrl_c_inside_ipopt_raises_keyboard_interrupt(ctrl_c_during: Any) -> None:
    """CasADi catches the KeyboardInterrupt of a SIGINT and ends IPOPT with a failure status;
    the planner must turn that back into KeyboardInterrupt instead of an infeasible result."""
    bot = robots.load("quad12")
    # the full NLP's solver, which the test patches (the half-cycle solve's own Ctrl-C test:
    # tests/planner/nlp/test_half_cycle.py)
    planner = GaitPlanner(bot, n_knots=12, options=PlannerOptions(half_cycle_solve=False))
    solver = planner._solver

    def solve_with_ctrl_c(**kwargs: Any) -> Any:
        # 50 ms into a cold solve (≈ 0.5 s or more): Ctrl-C while IPOPT iterates
        return ctrl_c_during(solver, 0.05, **kwargs)

    planner._solver = solve_with_ctrl_c  # stats() is read from the real solver object below
    planner._solver.stats = solver.stats  # type: ignore[attr-defined]
    with pytest.raises(KeyboardInterrupt):
        planner.solve(make_schedule(bot, "trot"), 0.2, warm_start=False)
    # the planner still works afterwards, and SIGINT is back to Python's default handler
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    planner._solver = solver
    assert planner.solve(make_schedule(bot, "trot"), 0.2, warm_start=False).feasible


def test_plan_reports_an_interrupt_with_exit_130(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    def interrupted(*args: Any, **kwargs: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(plan_cmd, "GaitPlanner", interrupted)
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "-o", str(out)]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert not out.exists()

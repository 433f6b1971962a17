"""`gaitsmith plan ROBOT --half-cycle`: a symmetric template solved on half its knots writes the
gait of the full solve (real NLP); anything else is solved in full, and the gait file says which."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gaitsmith.cli import main


def _plan(tmp_path: Path, name: str, *extra: str) -> dict:
    out = tmp_path / f"{name}.json"
    main(["plan", "quad12", "--speed", "0.25", "--knots", "12", *extra, "-o", str(out)])
    gait: dict = json.loads(out.read_text())
    return gait


def test_a_trot_on_half_its_knots_is_the_full_solves_trot(tmp_path: Path) -> None:
    full = _plan(tmp_path, "full", "--gait", "trot")
    half = _plan(tmp_path, "half", "--gait", "trot", "--half-cycle")
    assert full["planner"]["solver"]["half_cycle"] is False
    assert half["planner"]["solver"]["half_cycle"] is True
    assert half["planner"]["objective"] == pytest.approx(full["planner"]["objective"], rel=1e-9)
    assert half["planner"]["solver"]["iterations"] == full["planner"]["solver"]["iterations"]


def test_a_bound_is_solved_in_full_with_the_flag(tmp_path: Path) -> None:
    bound = _plan(tmp_path, "bound", "--gait", "bound", "--half-cycle")
    assert bound["planner"]["solver"]["half_cycle"] is False  # not half-cycle symmetric

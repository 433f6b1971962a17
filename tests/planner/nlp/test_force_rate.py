"""planner.nlp.force_rate: a foot's normal force changes by at most ρ body weights per √(L/g)
between neighbouring knots, so the load builds after touchdown and fades before lift-off."""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import Group, _force_rate_groups, group_labels
from planner.nlp.force_rate import force_rate_bounds, force_rate_labels, force_rate_rows
from planner.nlp.model import RobotModel
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import Layout, make_symbols, time_unit_s
from planner.templates import make_schedule

BIPED = Path(__file__).parents[1] / "fixtures" / "biped12"


def test_rows_are_the_cyclic_force_change_per_leg_time() -> None:
    """Two feet, four knots: row (k, f) is (f_z,k+1 − f_z,k)·N/T·√(L/g), the last knot wrapping
    to the first; the order is knot-major like the labels."""
    fz = np.array([[0.0, 0.2, 0.6, 0.1], [0.5, 0.5, 0.0, 0.0]])
    inv_h, t0 = 4 / 0.8, 0.15
    rows = np.asarray(ca.DM(force_rate_rows(ca.DM(fz), inv_h, t0))).ravel()
    expected = ((np.roll(fz, -1, axis=1) - fz) * inv_h * t0).T.ravel()
    assert rows == pytest.approx(expected)
    labels = force_rate_labels(("l", "r"), 4)
    assert len(labels) == rows.size
    assert labels[1] == "foot r@knot 0" and labels[-1] == "foot r@knot 3"
    lb, ub = force_rate_bounds(2.5, 2, 4)
    assert ub == pytest.approx(np.full(8, 2.5)) and lb == pytest.approx(-ub)


def test_a_one_knot_touchdown_spike_violates_the_bound() -> None:
    """The humanoid20 plan measured in MuJoCo (zoo_gaits.md, session 24): 0 → 2.2 body weights
    in one 17 ms knot is a rate of ≈ 20 body weights per √(L/g) (L = 0.235 m)."""
    t0 = time_unit_s(0.235)
    rate = float(ca.DM(force_rate_rows(ca.DM([[0.0, 2.16]]), 36 / 0.627, t0))[0])
    assert rate == pytest.approx(2.16 * 36 / 0.627 * math.sqrt(0.235 / 9.81))
    assert rate > 15


def test_off_by_default_and_rows_with_labels_when_asked() -> None:
    model, n = RobotModel(robots.load(BIPED)), 8
    sym = make_symbols(Layout(n, model.n_joints, model.n_feet, len(model.flat_feet)))
    assert PlannerOptions().normal_force_rate_weights_per_t0 is None
    off = PlannerOptions(normal_force_rate_weights_per_t0=None)
    assert _force_rate_groups(model, sym, n, off, n / sym.period_s, 0.1) == []
    asked = PlannerOptions(normal_force_rate_weights_per_t0=4.0)
    (group,) = _force_rate_groups(model, sym, n, asked, n / sym.period_s, 0.1)
    assert isinstance(group, Group) and group.name == "normal force rate"
    assert group.expr.shape[0] == model.n_feet * n == group.ub.size
    assert len(group_labels(model, n)["normal force rate"]) == model.n_feet * n
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(PlannerConfigError, match="normal_force_rate_weights_per_t0"):
            PlannerOptions(normal_force_rate_weights_per_t0=bad)


@pytest.mark.slow
def test_a_planned_biped_walk_meets_the_rate_bound() -> None:
    """A 12-knot walk of the flat-footed test biped: every foot's normal force changes by at
    most ρ body weights per √(L/g) between knots, touchdown and lift-off included."""
    bot = robots.load(BIPED)
    rho = 4.0
    planner = GaitPlanner(bot, 12, PlannerOptions(normal_force_rate_weights_per_t0=rho))
    result = planner.solve(make_schedule(bot, "biped_walk"), 0.1)
    assert result.feasible
    weight_n = planner.model.total_mass_kg * 9.81
    fz = result.contact_forces_n[:, :, 2] / weight_n
    h = result.schedule.period_s / 12
    rate = np.abs(np.roll(fz, -1, axis=0) - fz) / h * time_unit_s(bot.leg_length_m)
    assert rate.max() <= rho * (1 + 1e-4)


@pytest.mark.parametrize("extra", [["--force-rate", "-1"], ["--force-rate", "-1", "--search"]],
                         ids=["negative", "search"])
def test_plan_refuses_a_force_rate_it_cannot_use(
    extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`gaitsmith plan --force-rate RHO`: a positive ρ, or 0 for no rows (since session 26: it
    overrides the stance-compliance rule; templates and, since session 25, `--search`:
    tests/gaitsmith/test_cli_options.py); refused before any work otherwise (one error line,
    exit 2, no gait file)."""
    from gaitsmith.cli import main

    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "--gait", "trot", "-o", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert "--force-rate" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()

"""The per-knot derivative path (`planner.nlp.solver_cache`, issue #16) against the expanded one."""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import knot_function
from planner.nlp.model import RobotModel
from planner.nlp.solver_cache import (
    directions_path,
    jacobian_and_hessian,
    knot_cache_key,
    knot_jacobian_and_hessian,
    load_directions,
    save_directions,
    with_knot_derivatives,
)
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule
from tests.planner.nlp.toy_knot import mapped_derivatives, toy_knot


def test_knot_derivatives_equal_casadi_ad() -> None:
    plain = toy_knot()
    custom = with_knot_derivatives(plain)
    rng = np.random.default_rng(3)
    args = rng.normal(size=(4, 5)), rng.normal(size=(2, 5)), rng.normal(size=(3, 5))
    reference = mapped_derivatives(plain, 5)(*args)
    ours = mapped_derivatives(custom.knot, 5)(*args)
    for ref, got in zip(reference, ours, strict=True):
        np.testing.assert_allclose(np.asarray(got), np.asarray(ref), rtol=1e-12, atol=1e-12)


def test_cache_key_follows_the_robot_and_the_directions_key_n_and_options() -> None:
    quad = knot_function(RobotModel(robots.load("quad12")))
    hexa = knot_function(RobotModel(robots.load("hex18")))
    # the same robot gives the same key in a new build; another robot another key
    assert knot_cache_key(quad) == knot_cache_key(knot_function(RobotModel(robots.load("quad12"))))
    assert knot_cache_key(quad) != knot_cache_key(hexa)
    base = directions_path(quad, 30, PlannerOptions())
    assert base == directions_path(quad, 30, PlannerOptions())
    assert base != directions_path(quad, 20, PlannerOptions())
    assert base != directions_path(quad, 30, PlannerOptions(mu=0.6))
    assert base != directions_path(hexa, 30, PlannerOptions())


def test_cache_key_follows_the_casadi_version(monkeypatch: pytest.MonkeyPatch) -> None:
    knot = toy_knot()
    key = knot_cache_key(knot)
    monkeypatch.setattr(ca.CasadiMeta, "version", staticmethod(lambda: "0.0.0-other"))
    assert knot_cache_key(knot) != key


def test_knot_path_builds_j_and_h_in_process_and_writes_no_sx_entry(tmp_path: Path) -> None:
    """Reading serialised SX J and H back took longer than building them (session 26): the
    "knot" path builds them, and only a compiled library is ever read from the cache."""
    knot = toy_knot()
    folder = tmp_path / "cache"
    jac, hess, outcome = knot_jacobian_and_hessian(knot, "knot", folder)
    assert outcome.status == "built" and outcome.path is None and not outcome.compiled
    assert not folder.exists() or not list(folder.glob("knot-*.casadi"))
    u, lam = np.arange(6.0), np.array([0.5, -1.0, 2.0])
    reference_jac, reference_hess = jacobian_and_hessian(knot)
    np.testing.assert_array_equal(np.asarray(jac(u)), np.asarray(reference_jac(u)))
    np.testing.assert_array_equal(np.asarray(hess(u, lam)), np.asarray(reference_hess(u, lam)))


def test_directions_file_round_trip_and_bad_files(tmp_path: Path) -> None:
    path = tmp_path / "d.json"
    assert load_directions(path) is None
    save_directions(path, (2, 25, 64), (25,))
    assert load_directions(path) == ((2, 25, 64), (25,))
    for bad in ("{", '{"forward": [0], "second": []}', '{"forward": ["2"], "second": []}', "[]"):
        path.write_text(bad)
        assert load_directions(path) is None


def test_unknown_derivative_path_is_a_config_error() -> None:
    with pytest.raises(PlannerConfigError, match="derivatives"):
        PlannerOptions(derivatives="fast")


@pytest.mark.slow
def test_knot_path_reaches_the_expanded_optimum(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("GAITSMITH_CACHE", str(tmp_path))
    robot = robots.load("quad12")
    schedule = make_schedule(robot, "trot")
    expanded = GaitPlanner(robot, 8, PlannerOptions(derivatives="expanded"))
    knot = GaitPlanner(robot, 8, PlannerOptions(derivatives="knot"))
    assert knot.derivative_cache is not None and knot.derivative_cache.status == "built"
    assert knot.directions_cached is False
    # full solves: a half-cycle one builds no full-NLP solver, so it records no directions
    a = expanded.solve(schedule, 0.2, warm_start=False, half_cycle=False)
    b = knot.solve(schedule, 0.2, warm_start=False, half_cycle=False)
    assert a.feasible and b.feasible
    assert b.cost <= a.cost * (1 + 1e-4)
    np.testing.assert_allclose(b.joint_angles_rad, a.joint_angles_rad, atol=1e-4)
    # the second build ("the second command") creates only the derivative directions the first
    # one used, and solves the same: same iterations, cost to 1e-9 relative
    again = GaitPlanner(robot, 8, PlannerOptions(derivatives="knot"))
    assert again.directions_cached is True
    assert load_directions(directions_path(knot_function(knot.model), 8, knot.options))
    c = again.solve(schedule, 0.2, warm_start=False, half_cycle=False)
    assert c.feasible and c.iterations == b.iterations
    assert abs(c.cost - b.cost) <= 1e-9 * abs(b.cost)


def test_plan_rejects_an_unknown_solver_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from gaitsmith.cli import main

    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "-o", str(out), "--solver", "fast"]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert lines == ["error: --solver 'fast': use one of knot, expanded, compiled"]
    assert not out.exists()

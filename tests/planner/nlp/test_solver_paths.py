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
    cache_path,
    cached_jacobian_and_hessian,
    directions_path,
    jacobian_and_hessian,
    knot_cache_key,
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


@pytest.mark.parametrize("damage", ["garbage", "truncated", "flipped"])
def test_a_corrupt_cache_entry_is_rebuilt(tmp_path: Path, damage: str) -> None:
    knot = toy_knot()
    _, _, first = cached_jacobian_and_hessian(knot, tmp_path)
    assert first.status == "built"
    assert cached_jacobian_and_hessian(knot, tmp_path)[2].status == "hit"
    path = cache_path(knot, tmp_path)
    data = path.read_bytes()
    if damage == "garbage":
        path.write_bytes(b"not a cache entry")
    elif damage == "truncated":
        path.write_bytes(data[: len(data) // 2])
    else:  # one payload byte changed: the checksum no longer matches
        path.write_bytes(data[:-10] + bytes([data[-10] ^ 0xFF]) + data[-9:])
    jac, hess, outcome = cached_jacobian_and_hessian(knot, tmp_path)
    assert outcome.status == "rebuilt"
    u, lam = np.arange(6.0), np.array([0.5, -1.0, 2.0])
    reference_jac, reference_hess = jacobian_and_hessian(knot)
    np.testing.assert_allclose(np.asarray(jac(u)), np.asarray(reference_jac(u)))
    np.testing.assert_allclose(np.asarray(hess(u, lam)), np.asarray(reference_hess(u, lam)))
    assert cached_jacobian_and_hessian(knot, tmp_path)[2].status == "hit"  # rewritten intact


def test_an_entry_of_another_knot_is_not_trusted(tmp_path: Path) -> None:
    knot = toy_knot()
    x = ca.SX.sym("x", 3)
    other = ca.Function("knot", [x], [x * x])
    cached_jacobian_and_hessian(other, tmp_path)
    # someone else's entry under this knot's name: wrong shapes, so rebuilt
    cache_path(knot, tmp_path).write_bytes(cache_path(other, tmp_path).read_bytes())
    assert cached_jacobian_and_hessian(knot, tmp_path)[2].status == "rebuilt"


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
    a = expanded.solve(schedule, 0.2, warm_start=False)
    b = knot.solve(schedule, 0.2, warm_start=False)
    assert a.feasible and b.feasible
    assert b.cost <= a.cost * (1 + 1e-4)
    np.testing.assert_allclose(b.joint_angles_rad, a.joint_angles_rad, atol=1e-4)
    # the second build reads J and H from the cache and creates only the directions used
    again = GaitPlanner(robot, 8, PlannerOptions(derivatives="knot"))
    assert again.derivative_cache is not None and again.derivative_cache.status == "hit"
    assert load_directions(directions_path(knot_function(knot.model), 8, knot.options))
    c = again.solve(schedule, 0.2, warm_start=False)
    assert c.feasible and abs(c.cost - b.cost) <= 1e-8 * abs(b.cost)


def test_plan_rejects_an_unknown_solver_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from gaitsmith.cli import main

    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "-o", str(out), "--solver", "fast"]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert lines == ["error: --solver 'fast': use one of knot, expanded, compiled"]
    assert not out.exists()

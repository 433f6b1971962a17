"""Compiled per-knot derivatives (`planner.nlp.compiled_knot`, issue #16) and how the planner
picks them up (`solver_cache.knot_jacobian_and_hessian`)."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import robots
from planner.nlp import compiled_knot
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import knot_function
from planner.nlp.model import RobotModel
from planner.nlp.solver_cache import (
    cache_dir,
    cache_folder,
    jacobian_and_hessian,
    knot_cache_key,
    knot_jacobian_and_hessian,
    with_knot_derivatives,
)
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule
from tests.planner.nlp.toy_knot import mapped_derivatives, toy_knot
from tests.zoo.fixtures import ZOO


def _assert_same_functions(
    ours: tuple[ca.Function, ca.Function], reference: tuple[ca.Function, ca.Function],
    n_points: int = 3,
) -> None:
    """Same output sparsity, same Jacobian sparsity and values within 1e-12 at random points."""
    rng = np.random.default_rng(7)
    for got, ref in zip(ours, reference, strict=True):
        assert got.sparsity_out(0) == ref.sparsity_out(0)
        assert got.jac_sparsity(0, 0) == ref.jac_sparsity(0, 0)
        for _ in range(n_points):
            args = [rng.normal(size=ref.size_in(i)) for i in range(ref.n_in())]
            np.testing.assert_allclose(
                np.asarray(got(*args)), np.asarray(ref(*args)), rtol=1e-12, atol=1e-12
            )


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("GAITSMITH_CACHE", str(tmp_path))
    monkeypatch.delenv("GAITSMITH_CC", raising=False)
    return tmp_path


def test_compiled_knot_derivatives_equal_the_sx_ones_and_casadi_ad(cache: Path) -> None:
    plain = toy_knot()
    jac, hess, outcome = knot_jacobian_and_hessian(plain, "compiled")
    assert outcome.compiled and outcome.status == "built" and outcome.path.parent == cache
    assert outcome.path.suffix == ".so" and outcome.path.with_suffix(".json").is_file()
    assert not [p for p in cache.iterdir() if p.name.startswith(".")]  # no temp folder left
    _assert_same_functions((jac, hess), jacobian_and_hessian(plain))
    # the NLP-level patterns CasADi derives through them are the SX path's (the Jacobian
    # sparsity in the library is what makes this so), and so are the values
    rng = np.random.default_rng(3)
    args = rng.normal(size=(4, 5)), rng.normal(size=(2, 5)), rng.normal(size=(3, 5))
    reference = mapped_derivatives(plain, 5)
    ours = mapped_derivatives(with_knot_derivatives(plain, jac, hess).knot, 5)
    for i in range(2):
        assert ours.sparsity_out(i) == reference.sparsity_out(i)
    for ref, got in zip(reference(*args), ours(*args), strict=True):
        np.testing.assert_allclose(np.asarray(got), np.asarray(ref), rtol=1e-12, atol=1e-12)


def test_knot_picks_up_a_compiled_entry_and_never_compiles(cache: Path) -> None:
    plain = toy_knot()
    _, _, outcome = knot_jacobian_and_hessian(plain, "knot")
    assert not outcome.compiled and outcome.status == "built"  # SX J and H built, nothing compiled
    assert not list(cache.glob("*.so"))
    _, _, compiled = knot_jacobian_and_hessian(plain, "compiled")
    assert compiled.compiled and compiled.status == "built"
    for derivatives in ("knot", "compiled"):
        _, _, again = knot_jacobian_and_hessian(plain, derivatives)
        assert again.compiled and again.status == "hit" and again.path == compiled.path


@pytest.mark.parametrize("damage", ["library bytes", "manifest key", "manifest missing",
                                    "manifest not json"])
def test_a_corrupt_or_foreign_compiled_entry_is_rebuilt_not_loaded(cache: Path,
                                                                   damage: str) -> None:
    plain = toy_knot()
    _, _, outcome = knot_jacobian_and_hessian(plain, "compiled")
    library, manifest = outcome.path, outcome.path.with_suffix(".json")
    good = library.read_bytes()
    if damage == "library bytes":  # a new file: this process has the old one mapped
        broken = library.with_name("broken.so")
        broken.write_bytes(good[: len(good) // 2] + b"\0garbage")  # would crash if opened
        os.replace(broken, library)
    elif damage == "manifest key":
        doc = json.loads(manifest.read_text())
        manifest.write_text(json.dumps({**doc, "key": "0" * 32}))
    elif damage == "manifest missing":
        manifest.unlink()
    else:
        manifest.write_text("{not json")
    _, _, knot_path = knot_jacobian_and_hessian(plain, "knot")
    assert not knot_path.compiled  # not trusted: SX J and H built instead
    jac, hess, rebuilt = knot_jacobian_and_hessian(plain, "compiled")
    assert rebuilt.compiled and rebuilt.status == "rebuilt"
    assert library.read_bytes() == good  # same compiler, same flags, same source
    _assert_same_functions((jac, hess), jacobian_and_hessian(plain), n_points=1)


def test_the_key_holds_the_compiler_and_its_flags() -> None:
    sx_key = knot_cache_key(toy_knot())
    gcc = compiled_knot.Compiler("/usr/bin/gcc", "gcc 12", ("-O1",))
    keys = {
        compiled_knot.compiled_key(sx_key, gcc),
        compiled_knot.compiled_key(sx_key, compiled_knot.Compiler("/usr/bin/gcc", "gcc 13",
                                                                  ("-O1",))),
        compiled_knot.compiled_key(sx_key, compiled_knot.Compiler("/usr/bin/clang", "gcc 12",
                                                                  ("-O1",))),
        compiled_knot.compiled_key(sx_key, compiled_knot.Compiler("/usr/bin/gcc", "gcc 12",
                                                                  ("-O2",))),
        compiled_knot.compiled_key("f" * 32, gcc),
    }
    assert len(keys) == 5
    assert compiled_knot.compiled_key(sx_key, gcc) == compiled_knot.compiled_key(sx_key, gcc)


def _fake_compiler(folder: Path, body: str) -> Path:
    script = folder / "fakecc"
    script.write_text("#!/bin/sh\nif [ \"$1\" = --version ]; then echo fakecc 1.0; exit 0; fi\n"
                      + body)
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return script


@pytest.mark.parametrize("compiler", ["missing", "fails"])
def test_no_or_a_failing_compiler_warns_once_and_uses_the_sx_path(
    cache: Path, tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str], compiler: str,
) -> None:
    bin_dir = tmp_path_factory.mktemp("bin")
    if compiler == "missing":
        monkeypatch.setenv("GAITSMITH_CC", str(bin_dir / "no-such-cc"))
    else:
        script = _fake_compiler(bin_dir, "echo 'fatal error: out of memory' >&2\nexit 4\n")
        monkeypatch.setenv("GAITSMITH_CC", str(script))
    plain = toy_knot()
    jac, hess, outcome = knot_jacobian_and_hessian(plain, "compiled")
    assert not outcome.compiled and outcome.path is None
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gaitsmith: warning: ")
    assert ("no C compiler" in lines[0]) if compiler == "missing" else (
        "exit 4" in lines[0] and "out of memory" in lines[0])
    assert not list(cache.glob("*.so")) and not list(cache.glob(".knot-compile-*"))
    _assert_same_functions((jac, hess), jacobian_and_hessian(plain), n_points=1)
    assert os.environ["GAITSMITH_CC"]  # the planner path "knot" stays silent about it
    knot_jacobian_and_hessian(plain, "knot")
    assert capsys.readouterr().err == ""


@pytest.mark.slow
def test_compiled_planner_on_the_smallest_zoo_robot_reaches_the_sx_optimum(cache: Path) -> None:
    """bittle8 (8 joints, the smallest knot in the zoo): compiled J and H equal the SX ones and
    a solve reaches the same optimum in the same iterations; the build after it loads the
    library."""
    robot = robots.load(ZOO / "bittle8")
    plain = knot_function(RobotModel(robot))
    reference = jacobian_and_hessian(plain)
    compiled = GaitPlanner(robot, 8, PlannerOptions(derivatives="compiled"))
    assert compiled.derivative_cache is not None and compiled.derivative_cache.compiled
    assert compiled.knot_derivatives is not None
    _assert_same_functions(
        (compiled.knot_derivatives.jacobian, compiled.knot_derivatives.hessian), reference
    )
    sx = GaitPlanner(robot, 8, PlannerOptions(derivatives="knot"))  # picks the library up
    assert sx.derivative_cache is not None and sx.derivative_cache.status == "hit"
    assert sx.derivative_cache.compiled
    plain_planner = _sx_planner(robot, cache)
    for name in ("nlp_jac_g", "nlp_hess_l"):  # the same NLP patterns as the SX path's
        assert (compiled._solver.get_function(name).sparsity_out(0)
                == plain_planner._solver.get_function(name).sparsity_out(0))
    schedule = make_schedule(robot, "trot")
    speed = 0.1
    got = compiled.solve(schedule, speed, warm_start=False)
    ref = plain_planner.solve(schedule, speed, warm_start=False)
    assert got.feasible == ref.feasible and got.iterations == ref.iterations
    assert got.cost == pytest.approx(ref.cost, rel=1e-8)
    np.testing.assert_allclose(got.warm_start.x, ref.warm_start.x, rtol=1e-6, atol=1e-8)


def _sx_planner(robot: robots.Robot, cache: Path) -> GaitPlanner:
    """A "knot" planner on SX J and H: a cache folder without the compiled library."""
    folder = cache / "sx-only"
    folder.mkdir()
    previous = os.environ["GAITSMITH_CACHE"]
    os.environ["GAITSMITH_CACHE"] = str(folder)
    try:
        planner = GaitPlanner(robot, 8, PlannerOptions(derivatives="knot"))
    finally:
        os.environ["GAITSMITH_CACHE"] = previous
    assert planner.derivative_cache is not None and not planner.derivative_cache.compiled
    return planner


def test_cache_folder_sets_and_restores_the_cache(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """`cache_folder`: `cache_dir` is the given folder inside the block and what it was after
    (an unset variable stays unset, also when the block raises); None leaves it alone."""
    monkeypatch.delenv("GAITSMITH_CACHE", raising=False)
    with pytest.raises(RuntimeError), cache_folder(tmp_path / "a"):
        assert cache_dir() == tmp_path / "a"
        raise RuntimeError
    assert "GAITSMITH_CACHE" not in os.environ
    monkeypatch.setenv("GAITSMITH_CACHE", str(tmp_path / "own"))
    with cache_folder(None):
        assert cache_dir() == tmp_path / "own"
    with cache_folder(tmp_path / "b"):
        assert cache_dir() == tmp_path / "b"
    assert cache_dir() == tmp_path / "own"

"""`benchmarks/gait_search_bench.py --compact-rows`: parsed and validated before any search, and
handed to the searches' `PlannerOptions.compact_rows`."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

import planner.search.gait_search
from planner.nlp.config import COMPACT_ROWS, DEFAULT_COMPACT_ROWS
from tests.benchmarks import load_script
from tests.gaitsmith.capture import Started, captured_kwargs
from tests.zoo.fixtures import ZOO

bench = load_script("gait_search_bench")


def test_compact_rows_values_parse_none_single_and_joined_names() -> None:
    assert bench.compact_rows_values("none,torque envelope") == [(), ("torque envelope",)]
    assert bench.compact_rows_values(" joint speed + swing force ") == [
        ("joint speed", "swing force")]
    # the option's default and every label round-trip
    for rows in [(), DEFAULT_COMPACT_ROWS, COMPACT_ROWS]:
        assert bench.compact_rows_values(bench._rows_label(rows)) == [rows]


@pytest.mark.parametrize("text", ["", "none,", "torque", "all",
                                  "torque envelope+torque envelope", "none+joint speed"])
def test_compact_rows_values_refuse_what_planner_options_would(text: str) -> None:
    with pytest.raises(SystemExit, match=r"--compact-rows: expected .*got"):
        bench.compact_rows_values(text)


def test_a_bad_compact_rows_stops_main_before_any_search(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_search(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a search ran before --compact-rows was validated")

    monkeypatch.setattr(bench, "run", no_search)
    monkeypatch.setattr(sys, "argv", ["gait_search_bench.py", "--compact-rows", "none,bogus"])
    with pytest.raises(SystemExit, match="--compact-rows"):
        bench.main()


def test_run_hands_compact_rows_to_the_search_and_labels_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen: list[Any] = []

    def fake_search(robot: Any, speed: float, **kwargs: Any) -> str:
        seen.append(kwargs["options"])
        return "result"

    monkeypatch.setattr(bench, "search_gait", fake_search)
    before = bench.run("quad12", 0.25, 1, 1, 0, False, "knot", "serial", 30, compact_rows=())
    after = bench.run("quad12", 0.25, 1, 1, 0, False, "knot", "serial", 30)
    assert [o.compact_rows for o in seen] == [(), DEFAULT_COMPACT_ROWS]
    assert (before.derivatives, after.derivatives) == ("knot+rows-none", "knot")
    assert before.result == "result"


def test_run_hands_the_coarse_knots_to_the_search_and_labels_them(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen: list[tuple[int, int]] = []

    def fake_search(robot: Any, speed: float, **kwargs: Any) -> str:
        seen.append((kwargs["search_knots"], kwargs["n_knots"]))
        return "result"

    monkeypatch.setattr(bench, "search_gait", fake_search)
    coarse = bench.run("quad12", 0.25, 1, 1, 0, False, "knot", "serial", 30, search_knots=10)
    default = bench.run("quad12", 0.25, 1, 1, 0, False, "knot", "serial", 30)
    assert seen == [(10, 30), (bench.DEFAULT_SEARCH_KNOTS, 30)]
    assert (coarse.derivatives, default.derivatives) == ("knot+knots10", "knot")


def test_run_loosens_the_coarse_checks_speed_tolerance_only(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`coarse_speed_tol`: the coarse MuJoCo check's `speed_rel_tol`; the final check and every
    other criterion as the command gives them."""
    seen: list[dict[str, Any]] = []

    def fake_search(robot: Any, speed: float, **kwargs: Any) -> str:
        seen.append(kwargs)
        return "result"

    monkeypatch.setattr(bench, "search_gait", fake_search)
    loose = bench.run("quad12", 0.25, 1, 1, 0, True, "knot", "serial", 30, coarse_speed_tol=0.2)
    default = bench.run("quad12", 0.25, 1, 1, 0, True, "knot", "serial", 30)
    assert (loose.derivatives, default.derivatives) == ("knot+speed0.2", "knot")
    coarse, base = seen[0]["acceptance"], seen[1]["acceptance"]
    assert coarse.criteria.speed_rel_tol == 0.2 != base.criteria.speed_rel_tol
    assert replace(coarse.criteria, speed_rel_tol=base.criteria.speed_rel_tol) == base.criteria
    assert seen[0]["final_acceptance"] == seen[1]["final_acceptance"]


@pytest.mark.parametrize("robot, speed, sim_accept", [
    ("quad12", "0.25", True),  # the README search
    ("hex18", "0.15", False),
    (str(ZOO / "humanoid20"), "0.215", True),  # the stance-compliance rule fills three options
    (str(ZOO / "knee8"), "0.182", False),  # the servo-limited timing: its options and seed
])
@pytest.mark.parametrize("solver", ["knot", "expanded"])
def test_run_searches_with_the_command_lines_options_and_checks(
    robot: str, speed: str, sim_accept: bool, solver: str, monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
) -> None:
    """`run` gives `search_gait` the `PlannerOptions` and MuJoCo checks that `gaitsmith plan
    ROBOT --search --solver S` gives it with no other flag: a default changed on either side
    fails here."""
    argv = ["plan", robot, "--speed", speed, "--search", "--solver", solver,
            "--sim-accept" if sim_accept else "--no-sim-accept", "-o", str(tmp_path / "g.json")]
    command = captured_kwargs(monkeypatch, planner.search.gait_search, "search_gait", argv)
    bench_kw = captured_kwargs_of(monkeypatch, lambda: bench.run(
        robot, float(speed), 1, 2, 0, sim_accept, solver, "process", 30))
    keys = {"options", "acceptance", "final_acceptance"}
    assert keys & set(command) == keys & set(bench_kw) == (
        keys if sim_accept else {"options"})
    # the servo-limited seed (knee8 only): the command's timing, under the command's name
    assert bench_kw.get("seed_schedules") == command.get("seed_schedules")
    assert ("knee8" in robot) == (command.get("seed_schedules") is not None)
    for key in keys & set(command):
        assert bench_kw[key] == command[key], key


def captured_kwargs_of(monkeypatch: pytest.MonkeyPatch, call: Any) -> dict[str, Any]:
    """The keyword arguments `call()` gives the benchmark's `search_gait` (which then stops)."""
    seen: dict[str, Any] = {}

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.update(kwargs)
        raise Started

    monkeypatch.setattr(bench, "search_gait", record)
    with pytest.raises(Started):
        call()
    return seen

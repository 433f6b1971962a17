"""`benchmarks/gait_search_bench.py --compact-rows`: parsed and validated before any search, and
handed to the searches' `PlannerOptions.compact_rows`."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import pytest

from planner.nlp.config import COMPACT_ROWS, DEFAULT_COMPACT_ROWS

# the benchmark is a script beside the packages, not an installed module: load it from its file
_BENCH_PY = Path(__file__).resolve().parents[2] / "benchmarks" / "gait_search_bench.py"
_SPEC = importlib.util.spec_from_file_location("gait_search_bench", _BENCH_PY)
assert _SPEC is not None and _SPEC.loader is not None
bench = importlib.util.module_from_spec(_SPEC)
sys.modules[_SPEC.name] = bench  # dataclasses resolve their module by name
_SPEC.loader.exec_module(bench)


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

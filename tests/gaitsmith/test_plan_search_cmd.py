"""`gaitsmith plan ROBOT --search` end to end: a gait file, its search log, the gait it names."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest


def test_plan_search_writes_the_gait_and_its_log(tmp_path: Path) -> None:
    out = tmp_path / "best.json"
    argv = [sys.executable, "-m", "gaitsmith.cli", "plan", "quad12", "--speed", "0.2", "--search",
            "--generations", "1", "--popsize", "4", "--executor", "serial", "--knots", "20",
            "--simulate", "--cycles", "8", "-o", str(out)]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=900, check=False, env=env)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "best gait:" in proc.stdout and "gen   0" in proc.stdout
    gait = json.loads(out.read_text())
    search = gait["planner"]["search"]
    assert search["search_knots"] == 12 and search["sim_accepted"] is True  # --sim-accept default
    assert search["symmetric"] is True  # quad12 has left/right pairs: the space searched
    # the final phase's candidates by the rule (planner.search.budget): 4 when a sample passed
    # the coarse check, 8 when none did
    assert (search["final_candidates"], search["final_candidates_reason"]) in (
        (4, "a sample passed the coarse check"), (8, "the coarse check accepted no sample"))
    assert gait["validation"]["passed"] is True  # --simulate: the written gait walks
    finite = [c for c in search["template_costs"].values() if c is not None]  # null: rejected
    assert finite and search["search_cost"] <= min(finite) + 1e-9
    assert gait["gait_label"] in search["template_costs"] or gait["gait_label"] in (
        "bound", "gallop_rotary", "gallop_transverse", "pronk")
    log = out.with_suffix(".search.csv").read_text().splitlines()
    assert log[0].startswith("generation,best_cost") and log[1].startswith("0,")
    # the final re-solves: the candidates half-cycle unless --full-cycle is given
    # (FINAL_HALF_CYCLE, since session 40), a narrow MuJoCo failure re-solved full
    # (FINAL_RETRY_FULL "narrow"), a template as the template path plans it (half-cycle where
    # it fits); the gait file and the search log say which the written plan was
    assert search["final_half_cycle"] is True and search["final_retry_full"] == "narrow"
    half = gait["planner"]["solver"]["half_cycle"]
    assert half is True or search["final_retried"] or search["fallback_template"] is not None
    how = ("(a symmetric timing on the first half of them" if half else
           "(full cycle, a retry: its half-cycle plan failed, narrow" if search["final_retried"]
           else "(full cycle)")
    assert any(line.startswith(f"# final solve: 20 knots {how}") for line in log)
    assert any(line.startswith(f"# final phase: up to {search['final_candidates']} searched")
               for line in log)


def test_plan_search_rejects_a_bad_executor(tmp_path: Path) -> None:
    argv = [sys.executable, "-m", "gaitsmith.cli", "plan", "quad12", "--search", "--executor",
            "gpu", "-o", str(tmp_path / "x.json")]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode != 0 and "--executor must be serial, process or ray" in (
        proc.stdout + proc.stderr)
    assert not (tmp_path / "x.json").exists()


class _Recorded(Exception):
    pass


def test_the_search_acceptance_gets_the_asked_gain_or_the_rule(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`plan --search --attitude-gain G` judges every sample and candidate at G; without it the
    acceptance applies the robot's rule per gait (None), as `--simulate` does."""
    from gaitsmith import plan_search
    from gaitsmith.cli import main

    seen: list[float | None] = []

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.append(args[4] if len(args) > 4 else kwargs.get("attitude_gain"))
        raise _Recorded

    monkeypatch.setattr(plan_search, "sim_acceptance", record)
    for extra, expected in ((["--attitude-gain", "0.7"], 0.7), ([], None)):
        with pytest.raises(_Recorded):
            main(["plan", "biped", "--speed", "0.2", "--search", "--simulate", *extra,
                  "-o", str(tmp_path / "g.json")])
        assert seen[-1] == expected


def test_the_coarse_swing_wrench_is_the_searchs_default_or_the_one_asked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`plan --search` gives `search_gait` the coarse solves' swing wrench: the search's default
    (`SEARCH_SWING_WRENCH`, "bounds" since session 40; docs/results/planner_speed_search.md),
    or the one --search-swing-wrench asks; the options (the templates') keep the template
    path's default (`DEFAULT_SWING_WRENCH`, "bounds" since session 42) either way."""
    import planner.search.gait_search as gs
    from gaitsmith.cli import main
    from planner.nlp.config import DEFAULT_SWING_WRENCH
    from planner.search.defaults import SEARCH_SWING_WRENCH

    seen: list[tuple[str | None, str]] = []

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.append((kwargs.get("search_swing_wrench"), kwargs["options"].swing_wrench))
        raise _Recorded

    monkeypatch.setattr(gs, "search_gait", record)
    assert SEARCH_SWING_WRENCH == "bounds"
    for extra, expected in (([], SEARCH_SWING_WRENCH),
                            (["--search-swing-wrench", "rows"], "rows"),
                            (["--search-swing-wrench", "bounds"], "bounds")):
        with pytest.raises(_Recorded):
            main(["plan", "quad12", "--speed", "0.25", "--search", *extra,
                  "-o", str(tmp_path / "g.json")])
        assert seen[-1] == (expected, DEFAULT_SWING_WRENCH)


def test_the_final_swing_wrench_is_the_searchs_default_or_the_one_asked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`plan --search` gives `search_gait` the candidates' final re-solves' swing wrench:
    `planner.search.defaults.FINAL_SWING_WRENCH` ("bounds" since session 40) by default,
    "bounds" or "rows" with --final-swing-wrench; the options (the templates') keep the
    template path's default either way."""
    import planner.search.gait_search as gs
    from gaitsmith.cli import main
    from planner.nlp.config import DEFAULT_SWING_WRENCH
    from planner.search.defaults import FINAL_SWING_WRENCH

    seen: list[tuple[str | None, str]] = []

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.append((kwargs.get("final_swing_wrench"), kwargs["options"].swing_wrench))
        raise _Recorded

    monkeypatch.setattr(gs, "search_gait", record)
    for extra, expected in (([], FINAL_SWING_WRENCH),
                            (["--final-swing-wrench", "bounds"], "bounds"),
                            (["--final-swing-wrench", "rows"], "rows")):
        with pytest.raises(_Recorded):
            main(["plan", "quad12", "--speed", "0.25", "--search", *extra,
                  "-o", str(tmp_path / "g.json")])
        assert seen[-1] == (expected, DEFAULT_SWING_WRENCH)


def test_the_coarse_half_cycle_solve_follows_its_flag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`plan --search` hands `search_gait` the coarse solves' half-cycle switch: the default
    (`planner.search.defaults.SEARCH_HALF_CYCLE`), on with --search-half-cycle, off with
    --search-full-cycle; the final re-solves follow their own default (`final_half_cycle`)."""
    import planner.search.gait_search as gs
    from gaitsmith.cli import main
    from planner.search.defaults import SEARCH_HALF_CYCLE

    seen: list[tuple[bool, bool]] = []

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.append((kwargs["search_half_cycle"], kwargs["final_half_cycle"]))
        raise _Recorded

    monkeypatch.setattr(gs, "search_gait", record)
    for extra, expected in (([], SEARCH_HALF_CYCLE), (["--search-half-cycle"], True),
                            (["--search-full-cycle"], False)):
        with pytest.raises(_Recorded):
            main(["plan", "quad12", "--speed", "0.25", "--search", *extra,
                  "-o", str(tmp_path / "g.json")])
        assert seen[-1] == (expected, True)


def test_the_final_re_solves_are_half_cycle_unless_the_flag_is_given(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`plan --search` re-solves its final candidates on half the knots by default
    (`planner.search.defaults.FINAL_HALF_CYCLE`, on since session 40, was off), a candidate
    failing the check narrowly re-solved on all of them (`FINAL_RETRY_FULL` "narrow", was every
    failed one, "all"); --half-cycle / --full-cycle given set the final re-solves too."""
    import inspect

    import planner.search.gait_search as gs
    from gaitsmith.cli import main
    from planner.search.defaults import FINAL_HALF_CYCLE, FINAL_RETRY_FULL

    assert FINAL_HALF_CYCLE is True and FINAL_RETRY_FULL == "narrow"
    assert inspect.signature(gs.search_gait).parameters["final_retry_full"].default == "narrow"
    seen: list[bool] = []

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.append(kwargs["final_half_cycle"])
        raise _Recorded

    monkeypatch.setattr(gs, "search_gait", record)
    for extra, expected in (([], True), (["--half-cycle"], True), (["--full-cycle"], False)):
        with pytest.raises(_Recorded):
            main(["plan", "quad12", "--speed", "0.25", "--search", *extra,
                  "-o", str(tmp_path / "g.json")])
        assert seen[-1] is expected


def test_the_templates_compete_only_when_asked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`plan --search` hands `search_gait` `--final-templates` (default
    `planner.search.defaults.DEFAULT_FINAL_TEMPLATES`)."""
    import planner.search.gait_search as gs
    from gaitsmith.cli import main
    from planner.search.defaults import DEFAULT_FINAL_TEMPLATES

    seen: list[str] = []

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.append(kwargs["final_templates"])
        raise _Recorded

    monkeypatch.setattr(gs, "search_gait", record)
    for extra, expected in (([], DEFAULT_FINAL_TEMPLATES),
                            (["--final-templates", "compete"], "compete"),
                            (["--final-templates", "fallback"], "fallback")):
        with pytest.raises(_Recorded):
            main(["plan", "quad12", "--speed", "0.25", "--search", *extra,
                  "-o", str(tmp_path / "g.json")])
        assert seen[-1] == expected

"""`benchmarks/search_outcomes.py`: setting tokens parsed and validated before any search, handed
to the search; `replay` truncates a recording after generation k and runs its final phase."""

from __future__ import annotations

import math
import sys
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import robots
from planner.search.final_phase import FinalOutcome
from planner.search.gait_search import TimingResult, TimingSpace
from planner.templates import make_schedule
from tests.benchmarks import load_script

so = load_script("search_outcomes")  # imports gait_search_bench from beside it


def test_cap_tol_and_gen_tokens_set_the_coarse_options_and_generations() -> None:
    s = so.parse_setting("coarse-bounds+cap40+tol1e-4+gen4")
    assert (s.search_swing_wrench, s.search_max_iter, s.search_tol, s.generations) == (
        "bounds", 40, 1e-4, 4)
    base = so.parse_setting("base")
    assert (base.search_max_iter, base.search_tol, base.generations) == (60, None, None)


def test_final_swing_tokens_set_the_candidates_final_re_solves_only() -> None:
    s = so.parse_setting("coarse-bounds+finalbounds")
    assert (s.swing_wrench, s.search_swing_wrench, s.final_swing_wrench) == (
        so.DEFAULT_SWING_WRENCH, "bounds", "bounds")
    assert so.parse_setting("finalrows").final_swing_wrench == "rows"
    base = so.parse_setting("base")
    assert (base.swing_wrench, base.search_swing_wrench, base.final_swing_wrench) == (
        so.DEFAULT_SWING_WRENCH, so.SEARCH_SWING_WRENCH, so.FINAL_SWING_WRENCH) == (
        "bounds", "bounds", "bounds")
    old = so.parse_setting("coarse-rows+finalrows")  # the defaults before session 40
    assert (old.search_swing_wrench, old.final_swing_wrench) == ("rows", "rows")
    with pytest.raises(SystemExit, match="sets final_swing_wrench twice"):
        so.parse_setting("finalrows+finalbounds")
    with pytest.raises(SystemExit, match="sets search_swing_wrench twice"):
        so.parse_setting("coarse-rows+coarse-bounds")
    # a recording made before session 40 has no final_swing_wrench: its finals took the
    # options' own (None), not today's default
    recorded = {k: v for k, v in asdict(so.parse_setting("base")).items()
                if k != "final_swing_wrench"}
    assert so.recorded_setting({"setting": recorded}).final_swing_wrench is None


def test_knots_token_sets_the_coarse_knots_only() -> None:
    assert so.parse_setting("base").search_knots == so.DEFAULT_SEARCH_KNOTS == 12
    s = so.parse_setting("knots10+gen4")
    assert (s.search_knots, s.generations, s.search_max_iter) == (10, 4, 60)
    assert so.parse_setting("knots8").search_knots == 8


def test_speed_token_sets_the_coarse_checks_speed_tolerance_only() -> None:
    assert so.parse_setting("base").coarse_speed_tol is None
    s = so.parse_setting("speed0.2+knots10")
    assert (s.coarse_speed_tol, s.search_knots) == (0.2, 10)


def test_half_tokens_set_the_coarse_and_final_half_cycle_solves() -> None:
    base = so.parse_setting("base")
    assert (base.search_half_cycle, base.final_half_cycle) == (so.SEARCH_HALF_CYCLE, True)
    assert base.final_retry_full == "narrow"  # the defaults since session 40
    assert so.parse_setting("half").search_half_cycle is True
    assert so.parse_setting("full").search_half_cycle is False
    s = so.parse_setting("half+halffinal")
    assert (s.search_half_cycle, s.final_half_cycle) == (True, True)
    with pytest.raises(SystemExit, match="sets search_half_cycle twice"):
        so.parse_setting("half+full")
    assert so.parse_setting("base").final_templates == so.DEFAULT_FINAL_TEMPLATES == "compete"
    assert so.parse_setting("fallback").final_templates == "fallback"
    assert so.parse_setting("half+compete").final_templates == "compete"
    with pytest.raises(SystemExit, match="sets final_templates twice"):
        so.parse_setting("compete+fallback")


@pytest.mark.parametrize(("text", "match"), [
    ("cap0", r"'cap0' in 'cap0' needs an integer ≥ 1 after 'cap'"),
    ("capx", r"needs an integer ≥ 1 after 'cap'"),
    ("tol1", r"'tol1' .* needs a number in \(0, 1\) after 'tol'"),
    ("tol-", r"needs a number in \(0, 1\)"),
    ("gen0", r"needs an integer ≥ 1 after 'gen'"),
    ("knots7", r"'knots7' in 'knots7' needs an integer in \[8, 200\] after 'knots'"),
    ("knots201", r"needs an integer in \[8, 200\] after 'knots' \(e.g. knots10\)"),
    ("knots", r"needs an integer in \[8, 200\] after 'knots'"),
    ("knots10+knots8", r"sets search_knots twice"),
    ("cap40+cap50", r"sets search_max_iter twice"),
    ("speed0", r"'speed0' in 'speed0' needs a number in \(0, 1\) after 'speed'"),
    ("speed1.5", r"needs a number in \(0, 1\) after 'speed'"),
    ("fast", r"unknown token 'fast'.*capN, tolX, genK, knotsN, speedX, half, full, "
             r"none, reciprocal, sepunitX, fullfinal, halffinal, halfretry, halfnarrow, "
             r"finalrows, finalbounds, fallback or compete"),
])
def test_bad_tokens_are_one_line(text: str, match: str) -> None:
    with pytest.raises(SystemExit, match=match) as err:
        so.parse_setting(text)
    assert "\n" not in str(err.value)


def test_run_hands_the_tokens_to_the_search(monkeypatch: pytest.MonkeyPatch,
                                            tmp_path: Path) -> None:
    seen: list[tuple[Any, ...]] = []

    def fake_run(robot: str, speed: float, generations: int, *args: Any, **kwargs: Any) -> str:
        seen.append((generations, kwargs["search_max_iter"], kwargs["search_tol"],
                     kwargs["search_knots"], kwargs["coarse_speed_tol"]))
        return "run"

    monkeypatch.setattr(so, "run", fake_run)
    monkeypatch.setattr(so, "record", lambda search, setting, r, load: {
        "search": search.key, "setting": setting.name, "cpu_s": 1.0, "iterations": 1,
        "solves": 1, "winner": "trot", "fallback_template": None, "search_cost": 1.0,
        "final_cost": 1.0, "verdict": "MuJoCo pass", "utc": "2026-12-05 08:00:00",
        "load_start": 0.0, "load_end": 0.0})
    out = tmp_path / "runs.jsonl"
    monkeypatch.setattr(sys, "argv", ["so", "run", "--searches", "quad12@0.25:0", "--settings",
                                      "base,cap40+tol1e-4+gen4,knots10,speed0.2", "--out",
                                      str(out)])
    so.main()
    assert seen == [(6, 60, None, 12, None), (4, 40, 1e-4, 12, None), (6, 60, None, 10, None),
                    (6, 60, None, 12, 0.2)]
    assert len(out.read_text().splitlines()) == 4


def test_save_needs_an_existing_directory(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(so, "run", lambda *a, **k: pytest.fail("a search ran"))
    monkeypatch.setattr(sys, "argv", ["so", "run", "--searches", "quad12@0.25:0", "--out",
                                      str(tmp_path / "r.jsonl"), "--save", str(tmp_path / "no")])
    with pytest.raises(SystemExit, match=r"--save: .*no is not a directory"):
        so.main()


@pytest.mark.parametrize("text", ["", "0,2", "two"])
def test_bad_replay_generations_are_one_line(text: str) -> None:
    with pytest.raises(SystemExit, match=r"--generations: expected comma-separated integers"):
        so._generations(text)
    with pytest.raises(SystemExit, match=r"--final-candidates: expected comma-separated"):
        so._integers("--final-candidates", text, "4,8")
    assert so._integers("--final-candidates", "4,8", "4,8") == [4, 8]


class _Plan:
    def __init__(self, schedule: Any, cost: float) -> None:
        self.schedule, self.cost, self.feasible = schedule, cost, True


def _recording() -> tuple[robots.Robot, TimingSpace, list[np.ndarray], dict[str, Any]]:
    """A quad12 recording: the trot and walk templates' encodings, then two generations of two
    samples each (coarse costs 0.9, 0.8, then 0.5, 0.2)."""
    robot = robots.load("quad12")
    space = TimingSpace.for_robot(robot)
    names = ["trot", "walk"]
    encoded = [space.encode(make_schedule(robot, n)) for n in names]
    xs = [x for x in encoded if x is not None]
    assert len(xs) == 2
    lo, hi = space.bounds()
    gen = [lo + f * (hi - lo) for f in (0.2, 0.4, 0.6, 0.8)]
    cost = {0: 0.9, 1: 0.8, 2: 0.5, 3: 0.2}  # generation 0: samples 0-1, generation 1: 2-3
    records = [(x, TimingResult(x, c, True, 11, 0.0, True, cpu_s=1.0))
               for x, c in zip(xs, (0.7, 0.6), strict=True)]
    records += [(x, TimingResult(x, cost[i], True, 21, 0.0, True, cpu_s=2.0, accept_cpu_s=0.5))
                for i, x in enumerate(gen)]
    row = {"search": "quad12@0.25:0", "setting": "base", "cpu_s": 50.0, "iterations": 100,
           "solves": 6}
    rec = {"records": records, "templates": names, "symmetric": True, "generations": 2,
           "lam": 2, "final_cpu_s": 3.0, "row": row, "knots": 30}
    return robot, space, gen, rec


def test_replay_with_the_full_cycle_retry_hands_it_to_the_candidates_and_counts_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`FinalReplayer(half_cycle=True, retry_full="all")` ("halfretry"): every candidate task
    asks for the retry, no template task does; a retried outcome is counted in the row
    ("retries", the CPU of both attempts) and the written plan is marked as one; the row's CPU
    estimate takes both attempts' CPU."""
    _, space, gen, rec = _recording()
    seen: list[tuple[str | None, str]] = []

    def retried_sample_1(planner: Any, check: Any, task: Any) -> FinalOutcome:
        seen.append((task.template, task.retry_full))
        passes = math.isclose(task.schedule.period_s, space.decode(gen[1]).period_s)
        out = FinalOutcome(_Plan(task.schedule, 0.4), 0.0, passes, solve_cpu_s=1.0,  # type: ignore[arg-type]
                           check_cpu_s=0.25)
        if not (passes and task.retry_full == "all"):
            return out
        half = FinalOutcome(_Plan(task.schedule, 0.3), 0.0, False, solve_cpu_s=0.5,  # type: ignore[arg-type]
                            check_cpu_s=0.25, excess=(("heading", 0.004),))
        return replace(out, solve_cpu_s=1.5, check_cpu_s=0.5, half_tried=half,
                       half_failure="narrow")

    monkeypatch.setattr(so, "GaitPlanner", lambda *a: None)
    monkeypatch.setattr(so, "evaluate_task", retried_sample_1)
    replayer = so.FinalReplayer(so.Search("quad12", 0.25, 0), "rows", 30, half_cycle=True,
                                retry_full="all")
    row = replayer.truncated(rec, 1, templates="compete")
    assert seen and all((retry == "all") == (template is None) for template, retry in seen)
    # sample 1 (the second candidate, coarse 0.8) failed on half the knots, passed full
    assert (row["search_cost"], row["verdict"], row["retries"]) == (0.8, "MuJoCo pass", 1)
    assert row["final_retried"] is True
    assert (row["retry_half_cpu_s"], row["retry_full_cpu_s"]) == (0.75, 1.25)
    # how it failed on half the knots, retried, by how much, and the retry's verdict
    assert row["half_failed"] == [["narrow", True, [["heading", 0.004]], True]]
    # the final phase's CPU: every outcome read at 1.25 CPU-s, the retried one at 2.0
    assert row["cpu_s"] == pytest.approx(50.0 - 5.0 - 3.0 + 1.25 * (row["final_solves"] - 1)
                                         + 2.0)
    # "halffinal" (no retry): no task asks for it, sample 1 fails as solved on half the knots
    seen.clear()
    plain = so.FinalReplayer(so.Search("quad12", 0.25, 0), "rows", 30, half_cycle=True,
                             retry_full="off").truncated(rec, 1, templates="compete")
    assert all(retry == "off" for _, retry in seen) and plain["retries"] == 0
    assert plain["final_retried"] is False


def test_final_solve_tokens_name_the_four_policies() -> None:
    assert (so.parse_setting("halfretry").final_half_cycle,
            so.parse_setting("halfretry").final_retry_full) == (True, "all")
    assert (so.parse_setting("halffinal").final_half_cycle,
            so.parse_setting("halffinal").final_retry_full) == (True, "off")
    assert (so.parse_setting("halfnarrow").final_half_cycle,
            so.parse_setting("halfnarrow").final_retry_full) == (True, "narrow")
    assert so.parse_setting("fullfinal").final_half_cycle is False
    assert [so.final_solve_token(h, r) for h, r in so.FINAL_SOLVE_TOKENS.values()] == [
        "+fullfinal", "+halffinal", "+halfretry", "+halfnarrow"]
    assert so.REPLAY_FINAL_SOLVES["narrow"] == "halfnarrow"
    # a recording made before session 40 holds the retry as a bool
    assert so.Setting("old", final_retry_full=True).final_retry_full == "all"  # type: ignore[arg-type]
    assert so.Setting("old", final_retry_full=False).final_retry_full == "off"  # type: ignore[arg-type]
    with pytest.raises(SystemExit, match="sets final_half_cycle twice"):
        so.parse_setting("halffinal+halfretry")


def test_replay_truncates_the_record_and_runs_its_final_phase(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Generation k's record is the templates + k·λ samples; its final phase re-solves the
    truncated record's candidates (each schedule once) and the row carries its iterations and
    the CPU estimate; the template fallback follows when no candidate passes."""
    robot, space, gen, rec = _recording()
    solved: list[float] = []

    def fake_evaluate(planner: Any, check: Any, task: Any) -> FinalOutcome:
        schedule = task.schedule
        solved.append(schedule.period_s)
        passes = math.isclose(schedule.period_s, space.decode(gen[1]).period_s)
        return FinalOutcome(_Plan(schedule, 0.4), 0.0, passes, solve_cpu_s=1.0,  # type: ignore[arg-type]
                            check_cpu_s=0.25)

    monkeypatch.setattr(so, "GaitPlanner", lambda *a: None)
    monkeypatch.setattr(so, "evaluate_task", fake_evaluate)
    replayer = so.FinalReplayer(so.Search("quad12", 0.25, 0), "rows", 30)
    one = replayer.truncated(rec, 1, templates="fallback")
    # candidates after generation 0: walk template (0.6), trot (0.7), sample 1 (0.8), sample 0
    assert one["solves"] == 4 and one["iterations"] == 2 * 10 + 2 * 20
    assert one["setting"] == "base+gen1" and one["verdict"] == "MuJoCo pass"
    assert one["search_cost"] == 0.8  # the first candidate that passes: sample 1
    assert len(solved) == 3 and one["final_solves"] == 3
    # dropped: generation 1's two samples (2.5 CPU-s each); final phase 3 → 3 × 1.25
    assert one["cpu_s"] == pytest.approx(50.0 - 5.0 - 3.0 + 3.75)
    two = replayer.truncated(rec, 2, templates="fallback")
    # candidates: generation 1's samples (0.2, 0.5), the walk's and the trot's encodings; none
    # passes, nor does the fallback (the walk's own schedule; the trot's is its encoding), so
    # the first candidate is written, failed; sample 1 (0.8) is no longer a candidate
    assert (two["search_cost"], two["verdict"], two["iterations"]) == (0.2, "MuJoCo FAIL", 100)
    assert two["final_solves"] == 5 and len(solved) == 3 + 3  # the encodings were solved before
    assert np.isclose(two["cpu_s"], 50.0 - 3.0 + 5 * 1.25)
    # with 5 final candidates sample 1 (0.8) is one again, and passes
    five = replayer.truncated(rec, 2, 5, templates="fallback")
    assert (five["setting"], five["search_cost"], five["verdict"]) == (
        "base+gen2+final5", 0.8, "MuJoCo pass")
    assert len(solved) == 6  # every schedule it read was solved before
    # "cheapest" reads every candidate (4 after generation 0) and names its row
    cheap = replayer.truncated(rec, 1, 4, "cheapest", "fallback")
    assert (cheap["setting"], cheap["final_choice"], cheap["final_solves"]) == (
        "base+gen1+cheapest", "cheapest", 4)
    assert cheap["search_cost"] == 0.8 and cheap["final_total"] >= cheap["final_cost"] == 0.4
    # "compete": sample 1 passes, then the walk's own schedule (the first template task, the
    # trot's is its encoding) is read; it passes and is cheaper, so it is written
    own_walk = make_schedule(robot, "walk")

    def cheap_walk(planner: Any, check: Any, task: Any) -> FinalOutcome:
        schedule = task.schedule
        walk = np.allclose(schedule.touchdown_phase, own_walk.touchdown_phase)  # not encoded
        passes = walk or math.isclose(schedule.period_s, space.decode(gen[1]).period_s)
        return FinalOutcome(_Plan(schedule, 0.01 if walk else 0.4), 0.0, passes)  # type: ignore[arg-type]

    monkeypatch.setattr(so, "evaluate_task", cheap_walk)
    rival = so.FinalReplayer(so.Search("quad12", 0.25, 0), "rows", 30)
    fallback = rival.truncated(rec, 1, templates="fallback")
    assert (fallback["fallback_template"], fallback["beaten_search_total"]) == (None, None)
    compete = rival.truncated(rec, 1, templates="compete")
    assert (compete["fallback_template"], compete["final_templates"]) == ("walk", "compete")
    assert compete["beaten_search_total"] == fallback["final_total"] > compete["final_total"]
    assert compete["final_solves"] == fallback["final_solves"] + 1
    assert replayer.options.half_cycle_solve is True  # the default since session 40
    full = so.FinalReplayer(so.Search("quad12", 0.25, 0), "rows", 30, half_cycle=False)
    assert full.options.half_cycle_solve is False  # "fullfinal": the final re-solves' option
    with pytest.raises(SystemExit, match=r"--final-choice must be a comma-separated list of "
                                         r"first, cheapest-of-2, cheapest, got 'best'"):
        monkeypatch.setattr(sys, "argv", ["search_outcomes.py", "replay", "x.pkl",
                                          "--final-choice", "best", "--out", "o.jsonl"])
        so.main()


def _rule_recording(dim: int, accepted_after: int | None) -> dict[str, Any]:
    """A recording of 2 templates + 6 generations of λ 2 samples in a `dim`-variable space;
    samples from index `accepted_after` on passed the coarse check (None: none did)."""
    records = []
    for i in range(2 + 6 * 2):
        ok = accepted_after is not None and i >= accepted_after
        x = np.full(dim, float(i))
        records.append((x, TimingResult(x, 1.0, ok, 1, 0.0 if ok else 1e-9, True)))
    row = {"search": f"r{dim}@0.2:0", "setting": "base"}
    return {"records": records, "templates": ["a", "b"], "generations": 6, "lam": 2,
            "row": row}


@pytest.mark.parametrize(("dim", "accepted_after", "generations", "picked"), [
    (4, 3, None, "base+gen6"),  # a sample of generation 0 accepted: 4 candidates
    (4, None, None, "base+gen6+final8"),
    (6, 13, None, "base+gen6"),  # the last sample of generation 5 accepted
    (4, 3, 4, "base+gen4"),
    (4, 11, 4, "base+gen4+final8"),  # accepted only in generation 4, after the cut
    (10, None, 4, "base+gen4+final8"),
])
def test_rule_picks_the_replayed_row_the_final_candidate_rule_names(
    dim: int, accepted_after: int | None, generations: int | None, picked: str,
) -> None:
    rec = _rule_recording(dim, accepted_after)
    rows = {(rec["row"]["search"], name): {"search": rec["row"]["search"], "setting": name,
                                           "final_cost": 1.0}
            for name in ("base+gen4", "base+gen4+final8", "base+gen6", "base+gen6+final8")}
    row, line = so.rule_row(rec, rows, generations)
    assert row["rule"] == picked and row["dim"] == dim
    assert row["setting"] == ("base+rule" if generations is None else "base+gen4+rule")
    assert picked in line and f"dimension {dim}" in line
    assert row["rule_final_candidates"] == (8 if picked.endswith("final8") else 4)
    del rows[(rec["row"]["search"], picked)]
    with pytest.raises(SystemExit, match=r"no row .* make it with `replay RECORDING"):
        so.rule_row(rec, rows, generations)
    with pytest.raises(SystemExit, match=r"recorded with 6 generations, --generations asks"):
        so.rule_row(rec, rows, 7)


def test_centrality_and_separation_unit_tokens_set_planner_fields() -> None:
    s = so.parse_setting("bounds+reciprocal+sepunit0.2")
    assert (s.swing_wrench, s.cold_mu_centrality, s.separation_unit_leg_lengths) == (
        "bounds", "reciprocal", 0.2)
    assert so.option_fields(s) == (("cold_mu_centrality", "reciprocal"),
                                   ("separation_unit_leg_lengths", 0.2))
    assert so.option_fields(so.parse_setting("base")) == ()
    # a recording made before session 42 was planned with the separation rows in metres
    recorded = {k: v for k, v in asdict(so.parse_setting("base")).items()
                if k not in ("cold_mu_centrality", "separation_unit_leg_lengths")}
    old = so.recorded_setting({"setting": recorded})
    assert so.option_fields(old) == (("separation_unit_leg_lengths", None),)
    with pytest.raises(SystemExit, match=r"needs a number in \(0, 1\) after 'sepunit'"):
        so.parse_setting("sepunit2")
    with pytest.raises(SystemExit, match="sets cold_mu_centrality twice"):
        so.parse_setting("none+reciprocal")

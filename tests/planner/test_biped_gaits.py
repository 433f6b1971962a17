"""The built-in biped's gaits, end to end through `gaitsmith plan … --simulate`: the `--speed 0`
stand holds 10 s in MuJoCo, a walk at a small N passes every simulator check, and the templates
offered for two legs are the walk (double support) and the run (a flight phase)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import robots
from gaitsmith.cli import main
from planner.templates import default_gait_for, make_schedule, templates_for
from robots import ContactSchedule
from robots.gait import load as load_gait
from robots.ramp import run_speed_up_cycles
from sim.robustness import knife_edge_check
from sim.validate import simulate


def _flight_fraction(schedule: ContactSchedule) -> float:
    """Share of the cycle with no foot on the ground (sampled at 1000 phases)."""
    samples = [p / 1000 for p in range(1000)]
    return sum(not any(schedule.in_stance(f, p) for f in range(schedule.n_feet))
               for p in samples) / len(samples)


def _double_support_fraction(schedule: ContactSchedule) -> float:
    samples = [p / 1000 for p in range(1000)]
    return sum(all(schedule.in_stance(f, p) for f in range(schedule.n_feet))
               for p in samples) / len(samples)


def test_biped_templates_walk_with_double_support_and_run_with_flight() -> None:
    bot = robots.load("biped")
    assert default_gait_for(bot) == "biped_walk"
    assert {"biped_walk", "biped_run", "stand"} <= set(templates_for(bot))
    walk, run = make_schedule(bot, "biped_walk"), make_schedule(bot, "biped_run")
    assert _double_support_fraction(walk) > 0.1 and _flight_fraction(walk) == 0
    assert _flight_fraction(run) > 0.2 and _double_support_fraction(run) == 0


def _validation(path: Path) -> dict:
    doc = json.loads(path.read_text())
    assert doc["validation"]["passed"], doc["validation"]["reasons"]
    return dict(doc["validation"])


@pytest.mark.slow
def test_biped_stands_10_s_from_its_speed_0_plan(tmp_path: Path) -> None:
    out = tmp_path / "stand.json"
    assert main(["plan", "biped", "--speed", "0", "--knots", "12", "-o", str(out),
                 "--simulate"]) == 0
    doc = json.loads(out.read_text())
    assert doc["gait_label"] == "stand"
    assert all(d == 1.0 for d in doc["schedule"]["duty_factor"])
    validation = _validation(out)
    metrics = validation["metrics"]
    # 10 s of the stand's cycles after the ramp-in (the whole run is longer), none of it falling
    assert metrics["cycles_run"] * doc["period_s"] >= 10.0 and not metrics["fell"]
    assert metrics["tilt_max_rad"] < 0.02


@pytest.mark.slow
def test_biped_walks_at_a_low_froude_number_in_mujoco(tmp_path: Path) -> None:
    """0.1 m/s: Fr = v²/(g·L) = 0.004 on the biped's 0.25 m legs; N = 16.

    At N = 12 this walk is on a knife edge: two plans of the same cost (0.173933) that differ
    by 5.6e-5 rad — the knot and expanded derivative paths, or the same path on two machines —
    one passes and the other falls at ≈5 s, and `knife_edge_check` finds its +1 % speed re-plan
    falling at 4.96 s (docs/results/biped_walk_robustness.md). At N = 16 the plan passes, and
    still passes with 5 and 10 ms of stream latency (checked here) and over 30 cycles, but it
    is a knife edge too: its −1 % speed re-plan falls at 5.32 s (the results file)."""
    out = tmp_path / "walk.json"
    assert main(["plan", "biped", "--speed", "0.1", "--knots", "16", "-o", str(out),
                 "--simulate"]) == 0
    doc = json.loads(out.read_text())
    assert doc["gait_label"] == "biped_walk"
    metrics = _validation(out)["metrics"]
    assert metrics["stances"] >= 20 and metrics["peak_torque_fraction"] < 0.8
    late = knife_edge_check(load_gait(out), robots.load("biped"), latencies_s=(0.005, 0.01))
    assert late.robust, late.summary()


@pytest.mark.slow
def test_biped_run_with_flight_passes_mujoco(tmp_path: Path) -> None:
    """Issue #14: a clear run (0.5 m/s, Fr 0.10, duty 0.42: 16 % planned flight) passes every
    simulator check over 30 cycles once the entry builds its speed up over k ≥ v/(a·T) cycles
    (it fell 0.5 s after a one-cycle blend), and both feet are off the ground for part of its
    steady cycles in MuJoCo's contact record. Planned at 20 knots: at 12 (this test until
    session 38) the heading was a knife edge — +4.57° against ±5°, and 10 of 20 full solves from
    a start moved by 1e-6 turned +5.1° (docs/results/half_cycle_verdicts.md, 37b). At 20 knots
    the full solve, the half-cycle solve (the default) and 20 such re-draws all pass, heading
    +2.8 … +3.6°, peak torque 60 % of stall (docs/results/planner_speed_template_half.md,
    session 38)."""
    out = tmp_path / "run.json"
    assert main(["plan", "biped", "--speed", "0.5", "--gait", "biped_run", "--duty", "0.42",
                 "--knots", "20", "-o", str(out), "--simulate", "--cycles", "30"]) == 0
    doc = json.loads(out.read_text())
    metrics = _validation(out)["metrics"]
    assert not metrics["fell"] and metrics["cycles_run"] == 30
    gait = load_gait(out)
    assert _flight_fraction(gait.schedule) > 0.1 and run_speed_up_cycles(gait) > 1
    _, traj = simulate(gait, robots.load("biped"), 30)
    assert not traj.stopped_early and traj.ramp.cycles == run_speed_up_cycles(gait)
    assert traj.flight_fraction() > 0.0, "no step of the steady run had both feet in the air"
    assert doc["velocity"]["vx_m_s"] == pytest.approx(0.5)


@pytest.mark.slow
def test_biped_flying_run_at_20_knots_passes_mujoco(tmp_path: Path) -> None:
    """Issue #14 item 6: the sweep's 0.5 m/s winner (duty 0.405, T 0.319 s) planned at 20
    knots (2 airborne) flies in MuJoCo — both feet off the ground for ≈14 % of the steady
    steps — and passes every check over 20 cycles: peak torque 75 % of stall (92 % at 12
    knots, at the ankle on touchdown), heading −2.1° (cycle mean; its body yaws ±12° a cycle)."""
    out = tmp_path / "fly.json"
    assert main(["plan", "biped", "--speed", "0.5", "--phases", "0,0.5", "--duty", "0.40512",
                 "--period", "0.319442", "--knots", "20", "-o", str(out), "--simulate"]) == 0
    assert not _validation(out)["metrics"]["fell"]
    gait = load_gait(out)
    _, traj = simulate(gait, robots.load("biped"), 20)
    assert traj.flight_fraction() > 0.05, "the run did not fly in MuJoCo"

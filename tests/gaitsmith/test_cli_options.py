"""Bad option values and unusable output paths fail at once — one line naming the option and
what it accepts, exit 2 — before the NLP build, the search, the sweep or the simulation."""

from __future__ import annotations

import errno
import os
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

import planner.search.gait_search
import robots
from gaitsmith import plan_cmd, simulate_cmd, sweep_cmd
from gaitsmith.cli import main
from gaitsmith.gait_choice import check_gait_fits, default_gait
from gaitsmith.sweep_cmd import SweepClock, format_duration
from planner.errors import TemplateError
from planner.nlp.config import COP_SOLE_FRACTION
from robots import files
from tests.gaitsmith.capture import captured_kwargs


class ExpensiveWorkStarted(Exception):
    """Raised by the stand-ins of the NLP build / search / sweep / simulation."""


def _too_late(*args: Any, **kwargs: Any) -> Any:
    raise ExpensiveWorkStarted


@pytest.fixture(autouse=True)
def no_expensive_work(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(plan_cmd, "GaitPlanner", _too_late)
    monkeypatch.setattr(planner.search.gait_search, "search_gait", _too_late)
    monkeypatch.setattr(sweep_cmd, "sweep_speeds", _too_late)
    monkeypatch.setattr(simulate_cmd, "simulate", _too_late)


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


PLAN_MISTAKES = [
    (["--speed", "-11"], "--speed must be a number in [-10, 10] m/s"),  # backwards allowed
    (["--speed", "nan"], "--speed must be"),
    (["--speed", "1e9"], "--speed must be"),
    (["--knots", "3"], "--knots must be an integer in [8, 200]"),
    (["--duty", "1.5"], "--duty must be a number in (0, 1)"),
    (["--period", "0"], "--period must be a number in (0, 60] s"),
    (["--mu", "inf"], "--mu must be"),
    (["--simulate", "--cycles", "0"], "--cycles must be an integer in [3, "),
    (["--search", "--speed", "0"], "--speed must be a number in (0, 10] m/s"),
    (["--search", "--generations", "0"], "--generations must be an integer in [1, "),
    (["--search", "--popsize", "1"], "--popsize must be an integer in [2, "),
    (["--search", "--workers", "0"], "--workers must be"),
    (["--search", "--search-knots", "500"], "--search-knots must be an integer in [8, 200]"),
    (["--search", "--tipping-weight", "-1"], "--tipping-weight must be"),
    (["--search", "--executor", "gpu"], "--executor must be serial, process or ray"),
    (["--search", "--search-swing-wrench", "free"],
     "--search-swing-wrench must be rows or bounds, got 'free'"),
    (["--search", "--final-swing-wrench", "free"],
     "--final-swing-wrench must be rows or bounds, got 'free'"),
    (["--search", "--final-choice", "best"],
     "--final-choice must be one of first, cheapest-of-2, cheapest, got 'best'"),
    (["--search", "--final-templates", "always"],
     "--final-templates must be one of fallback, compete, got 'always'"),
    (["--search", "--cycles", "1"], "--cycles must be"),  # --sim-accept is on by default
    (["--entry-cycles", "0"], "--entry-cycles must be an integer in [1, 20], got 0"),
    (["--search", "--entry-cycles", "21"], "--entry-cycles must be an integer in [1, 20]"),
    (["--bounce-weight", "-1"], "--bounce-weight must be a number in [0, 1e+06], got -1"),
    (["--bounce-weight", "nan"], "--bounce-weight must be a number in [0, 1e+06], got nan"),
    (["--search", "--bounce-weight", "inf"], "--bounce-weight must be a number in [0, 1e+06]"),
    (["--force-rate", "-1"], "--force-rate must be a number in [0, 100] body weights"),
    (["--force-rate", "1e9"], "--force-rate must be a number in [0, 100] body weights"),
    (["--rotor-reserve", "2.5"], "--rotor-reserve must be a number in (0, 2], got 2.5"),
    (["--swing-clearance", "1"], "--swing-clearance must be a number in (0, 1) m, got 1"),
    (["--line-capture-margin", "-0.1"], "--line-capture-margin must be a number in [0, 1) leg"),
    (["--search", "--line-capture-margin", "1"], "--line-capture-margin must be a number in"),
    (["--cop-sole-fraction", "0"], "--cop-sole-fraction must be a number in (0, 1], got 0"),
    (["--cop-sole-fraction", "1.5"], "--cop-sole-fraction must be a number in (0, 1], got 1.5"),
    (["--search", "--cop-sole-fraction", "nan"], "--cop-sole-fraction must be a number in"),
    (["--cop-sole-fraction", "0.5"], "--cop-sole-fraction: quad12 has point feet"),
]


@pytest.mark.parametrize(("extra", "expected"), PLAN_MISTAKES)
def test_plan_rejects_bad_values_before_building_the_nlp(
    extra: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "-o", str(out), *extra]) == 2
    assert expected in _error_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize(("extra", "expected"), [
    (["--speeds", "0.1,nan"], "--speeds must be a number in (0, 10] m/s, got nan"),
    (["--speeds", "0.1,fast"], "--speeds must be numbers separated by commas"),
    (["--speeds", ","], "--speeds needs at least one speed"),
    (["--knots", "3"], "--knots must be"),
    (["--generations", "0"], "--generations must be"),
    (["--simulate", "--cycles", "2"], "--cycles must be an integer in [3, "),
])
def test_sweep_rejects_bad_values_before_sweeping(
    extra: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["sweep", "quad12", "-o", str(tmp_path / "s"), *extra]) == 2
    assert expected in _error_line(capsys)


@pytest.mark.parametrize(("extra", "expected"), [
    (["--cycles", "0"], "--cycles must be an integer in [3, "),
    (["--rate-hz", "0"], "--rate-hz must be a number in [1, 10000] Hz"),
    (["--latency-ms", "-5"], "--latency-ms must be a number in [0, 1000] ms"),
    (["--friction", "0"], "--friction must be a number in (0, 10]"),
    (["--payload-kg", "nan"], "--payload-kg must be"),
    (["--strength", "0"], "--strength must be"),
    (["--video-seconds", "0"], "--video-seconds must be"),
    (["--video", "v.avi"], "must end in .mp4 or .gif"),
])
def test_simulate_rejects_bad_values_before_simulating(
    extra: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", str(tmp_path / "g.json"), *extra]) == 2
    assert expected in _error_line(capsys)


def _unwritable(tmp_path: Path) -> list[Path]:
    """Output folders that fail even for root (permission bits do not stop root)."""
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    return [blocker / "out", Path("/proc/gaitsmith-test")]


@pytest.mark.parametrize("search", [False, True])
def test_plan_checks_the_output_path_first(
    search: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for folder in _unwritable(tmp_path):
        argv = ["plan", "quad12", "-o", str(folder / "g.json")] + (["--search"] if search else [])
        assert main(argv) == 2
        line = _error_line(capsys)
        assert line.startswith(f"error: --output {folder / 'g.json'}"), line


def test_sweep_and_simulate_check_their_output_paths_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for folder in _unwritable(tmp_path):
        assert main(["sweep", "quad12", "--speeds", "0.1", "-o", str(folder)]) == 2
        assert "--output" in _error_line(capsys)
        for option in ("--video", "--report"):
            name = "v.mp4" if option == "--video" else "r.html"
            assert main(["simulate", str(tmp_path / "g.json"), option, str(folder / name)]) == 2
            assert option in _error_line(capsys)
    assert main(["sweep", "quad12", "-o", str(tmp_path / "a-file")]) == 2  # a file, not a folder
    assert "expected a folder" in _error_line(capsys)


def test_a_full_disk_is_refused_before_the_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(files.shutil, "disk_usage", lambda path: SimpleNamespace(free=4096))
    assert main(["plan", "quad12", "-o", str(tmp_path / "g.json")]) == 2
    assert "is full" in _error_line(capsys)


def test_default_gait_follows_the_leg_count(tmp_path: Path) -> None:
    assert default_gait(robots.load("quad12")) == "trot"
    assert default_gait(robots.load("hex18")) == "tripod"
    # any other leg count gets an azimuth template (planner.templates.default_gait_for)
    from tests.planner.robot_factory import star_robot

    assert default_gait(robots.load(star_robot(tmp_path / "star5", 5))) == "ripple"


def test_plan_hex18_without_gait_plans_a_tripod(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(ExpensiveWorkStarted):  # got as far as building the NLP
        main(["plan", "hex18", "-o", str(tmp_path / "g.json")])
    assert "planning tripod for hex18" in capsys.readouterr().out


@pytest.mark.parametrize("gait", ["trot", "moonwalk"])
def test_an_unsuitable_gait_lists_the_gaits_that_fit(
    gait: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["plan", "hex18", "--gait", gait, "-o", str(tmp_path / "g.json")]) == 2
    line = _error_line(capsys)
    assert f"--gait {gait}" in line and "gaits that fit: tripod, ripple, wave" in line
    with pytest.raises(TemplateError):
        check_gait_fits(robots.load("quad12"), "tripod")


def test_sweep_clock_says_which_speed_and_estimates_the_rest() -> None:
    now = [0.0]
    clock = SweepClock(4, clock=lambda: now[0])
    speeds = [0.05, 0.15, 0.25, 0.35]
    now[0] = 5.0  # the NLP build
    assert clock.start_speed(speeds) == (
        "speed 1/4: 0.050 m/s — 5 s elapsed, ETA after the first speed")
    now[0] = 65.0
    clock.finish_speed()
    assert clock.start_speed(speeds) == "speed 2/4: 0.150 m/s — 1 min 05 s elapsed, ETA 3 min 00 s"
    now[0] = 95.0
    assert clock.eta_s() == pytest.approx(150.0)  # 3 speeds × 60 s − 30 s into this one
    assert format_duration(3725) == "1 h 02 min"


def test_plan_onto_a_full_disk_fails_cleanly_after_the_solve(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The disk fills up during the run: the gait file is not written, no temp file is left,
    one line says why (a real 12-knot solve: ≈ 6 s)."""
    from planner.nlp.spacetime import GaitPlanner

    monkeypatch.setattr(plan_cmd, "GaitPlanner", GaitPlanner)

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files.os, "fsync", full)
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "--knots", "12", "--speed", "0.2", "-o", str(out)]) == 2
    line = _error_line(capsys)
    assert str(out) in line and "No space left on device" in line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("extra", "expected"), [
    # (search_half_cycle, final_templates, final_half_cycle, the templates' half_cycle_solve)
    ([], (True, "compete", True, True)),
    (["--search-full-cycle", "--final-templates", "fallback", "--full-cycle"],
     (False, "fallback", False, False)),  # session 37's search exactly
    (["--half-cycle"], (True, "compete", True, True)),
])
def test_sweep_searches_with_plans_search_options(
    extra: list[str], expected: tuple[bool, str, bool, bool], tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`gaitsmith sweep` takes `plan --search`'s `--search-half-cycle/--search-full-cycle`,
    `--final-templates` and `--half-cycle/--full-cycle` with the same defaults."""
    seen = captured_kwargs(monkeypatch, sweep_cmd, "sweep_speeds",
                           ["sweep", "quad12", "--speeds", "0.1", "-o", str(tmp_path / "s"),
                            *extra])
    assert (seen["search_half_cycle"], seen["final_templates"], seen["final_half_cycle"],
            seen["options"].half_cycle_solve) == expected


def test_sweep_refuses_an_unknown_final_templates_before_sweeping(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["sweep", "quad12", "--final-templates", "best", "-o",
                 str(tmp_path / "s")]) == 2
    assert "--final-templates must be one of fallback, compete" in _error_line(capsys)


def test_sweep_write_failure_after_the_sweep_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(sweep_cmd, "sweep_speeds", lambda *args, **kwargs: ())

    def read_only(*args: Any) -> Any:
        raise PermissionError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(sweep_cmd, "write_sweep", read_only)
    out = tmp_path / "s"
    assert main(["sweep", "quad12", "--speeds", "0.1", "--no-sim-accept", "-o", str(out)]) == 2
    assert "cannot write the sweep: Read-only file system" in _error_line(capsys)


def test_plan_search_takes_the_template_options(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--force-rate, --bounce-weight, --rotor-reserve, --swing-clearance, --line-capture-margin
    and --entry-cycles reach the search: its NLP options and both MuJoCo acceptance checks
    (which judge every gait with the longer entry blend)."""
    seen = captured_kwargs(
        monkeypatch, planner.search.gait_search, "search_gait",
        ["plan", "quad12", "--speed", "0.2", "--search", "--force-rate", "10",
         "--bounce-weight", "30", "--rotor-reserve", "0.15", "--swing-clearance", "0.018",
         "--entry-cycles", "3", "--line-capture-margin", "0.16",
         "-o", str(tmp_path / "g.json")])
    options = seen["options"]
    assert options.line_capture_margin_leg_lengths == 0.16
    assert options.normal_force_rate_weights_per_t0 == 10
    assert options.weights.bounce_s2_m2 == 30
    assert options.rotor_reserve == 0.15 and options.swing_clearance_m == 0.018
    assert seen["acceptance"].entry_cycles == 3 and seen["final_acceptance"].entry_cycles == 3


def test_plan_cop_sole_fraction_reaches_the_flat_foot_nlp(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--cop-sole-fraction becomes `PlannerOptions.cop_sole_fraction` of the template path's
    NLP and of the search's; without it the planner's default (the whole sole) stays."""
    out = str(tmp_path / "g.json")
    seen = captured_kwargs(monkeypatch, plan_cmd, "GaitPlanner",
                           ["plan", "biped", "--speed", "0.222", "--yaw-rate", "0.3",
                            "--cop-sole-fraction", "0.5", "-o", out])
    assert seen["options"].cop_sole_fraction == 0.5
    seen = captured_kwargs(monkeypatch, planner.search.gait_search, "search_gait",
                           ["plan", "biped", "--speed", "0.2", "--search",
                            "--cop-sole-fraction", "0.7", "-o", out])
    assert seen["options"].cop_sole_fraction == 0.7
    seen = captured_kwargs(monkeypatch, plan_cmd, "GaitPlanner",
                           ["plan", "biped", "--speed", "0.222", "-o", out])
    assert seen["options"].cop_sole_fraction == COP_SOLE_FRACTION == 1.0


def test_plan_search_seeds_from_the_users_schedule(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--period/--duty (and --phases/--schedule) with --search are no longer silently ignored:
    the schedule they make seeds the search beside the templates."""
    seen: dict[str, Any] = {}

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.update(kwargs)
        raise ExpensiveWorkStarted

    monkeypatch.setattr(planner.search.gait_search, "search_gait", record)
    out = str(tmp_path / "g.json")
    with pytest.raises(ExpensiveWorkStarted):
        main(["plan", "quad12", "--speed", "0.2", "--search", "--period", "1.3", "--duty", "0.6",
              "-o", out])
    (schedule,) = seen["seed_schedules"].values()
    assert schedule.period_s == 1.3 and schedule.duty_factor == (0.6,) * 4
    seen.clear()
    with pytest.raises(ExpensiveWorkStarted):
        main(["plan", "quad12", "--speed", "0.2", "--search", "-o", out])
    assert seen["seed_schedules"] is None

"""The sweep table's flight column: the planned share of the cycle with no foot down."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from planner.search.speed_sweep import (
    SweepRow,
    airborne_knots,
    flight_fraction,
    flight_label,
    measured_label,
    plot,
    to_markdown,
)
from robots import ContactSchedule

FEET = ("left", "right")


@pytest.mark.parametrize(("duty", "expected"), [(0.6, 0.0), (0.5, 0.0), (0.45, 0.1), (0.35, 0.3)])
def test_flight_fraction_of_a_half_period_biped_schedule(duty: float, expected: float) -> None:
    schedule = ContactSchedule(0.5, FEET, (0.0, 0.5), (duty, duty))
    assert flight_fraction(schedule) == pytest.approx(expected, abs=2e-3)


def test_flight_fraction_of_a_pronk_and_a_stand() -> None:
    assert flight_fraction(ContactSchedule(0.5, FEET, (0.0, 0.0), (0.4, 0.4))) == \
        pytest.approx(0.6, abs=2e-3)
    assert flight_fraction(ContactSchedule(0.5, FEET, (0.0, 0.0), (1.0, 1.0))) == 0.0


def test_the_table_shows_the_flight_fraction() -> None:
    row = SweepRow(0.5, 0.1, "biped_run", "biped_run", 0.48, 0.42, 1.0, 1.0, 0.5, True, 10,
                   60.0, flight_fraction=0.16)
    table = to_markdown([row])
    assert "| flight |" in table.splitlines()[0]
    assert "| 0.42 | 0.16 | 0.480 |" in table
    assert math.isnan(SweepRow(0.5, 0.1, "w", "w", 1, 1, 1, 1, 1, True, 1, 1).flight_fraction)


@pytest.mark.parametrize(("duty", "label"), [(0.6, "biped_walk"), (0.5, "biped_walk"),
                                             (0.48, "biped_run"), (0.35, "biped_run")])
def test_a_biped_gait_with_flight_is_labelled_a_run(duty: float, label: str) -> None:
    """Issue #14: duty 0.48 (4 % flight) is nearer the walk template's 0.60, but it is a run."""
    schedule = ContactSchedule(0.5, FEET, (0.0, 0.5), (duty, duty))
    assert flight_label("biped_walk", schedule) == label
    assert flight_label("biped_run", schedule) == label


def test_flight_labels_leave_other_robots_to_their_template() -> None:
    feet = ("LF", "RF", "LH", "RH")
    bound = ContactSchedule(0.4, feet, (0.5, 0.5, 0.0, 0.0), (0.4,) * 4)  # 20 % flight
    assert flight_label("bound", bound) == "bound"
    trot = ContactSchedule(0.4, feet, (0.0, 0.5, 0.5, 0.0), (0.6,) * 4)
    assert flight_label("trot", trot) == "trot"


@pytest.mark.parametrize(("flight", "double", "label"), [
    (0.267, 0.0, "run"), (0.004, 0.006, "run"), (0.0, 0.03, "walk"), (0.0, 0.0, "grounded"),
    (math.nan, math.nan, "-")])
def test_the_measured_label_is_what_mujoco_recorded(flight: float, double: float,
                                                    label: str) -> None:
    """Issue #14: a planned run may walk in MuJoCo (duty 0.47, 6 % planned flight, 0 % measured,
    3 % double support); the row says what the simulation did beside what was planned."""
    assert measured_label(flight, double) == label
    row = SweepRow(0.1, 0.004, "biped_run", "biped_run", 0.52, 0.47, 0.2, 0.2, 0.9, True, 18,
                   60.0, flight_fraction=0.064, sim_passed=True, sim_speed_m_s=0.1,
                   sim_flight_fraction=flight, sim_double_support_fraction=double)
    assert row.sim_gait == label


def test_the_table_shows_the_measured_flight_and_double_support() -> None:
    row = SweepRow(0.1, 0.004, "biped_run", "biped_run", 0.52, 0.47, 0.2, 0.2, 0.9, True, 18,
                   60.0, flight_fraction=0.064, sim_passed=True, sim_speed_m_s=0.1,
                   sim_flight_fraction=0.0, sim_double_support_fraction=0.0301)
    table = to_markdown([row])
    assert "MuJoCo: flight / double support" in table.splitlines()[0]
    assert "| pass 0.100 m/s | walk: 0.0 % / 3.0 % |" in table
    unsimulated = SweepRow(0.1, 0.004, "w", "w", 0.5, 0.6, 0.2, 0.2, 0.9, True, 1, 1.0)
    assert "| - | - |" in to_markdown([unsimulated])


def test_the_plot_adds_the_measured_panel_for_simulated_rows(tmp_path: Path) -> None:
    walk = SweepRow(0.1, 0.004, "biped_walk", "biped_walk", 0.6, 0.6, 0.2, 0.2, 0.7, True, 18,
                    60.0, flight_fraction=0.0, sim_passed=True, sim_speed_m_s=0.1,
                    sim_flight_fraction=0.0, sim_double_support_fraction=0.2)
    run = SweepRow(0.5, 0.102, "biped_run", "biped_run", 0.32, 0.4, 1.0, 1.0, 1.2, True, 18,
                   60.0, flight_fraction=0.19, sim_passed=False, sim_speed_m_s=0.5,
                   sim_flight_fraction=0.267, sim_double_support_fraction=0.0)
    plot([walk, run], tmp_path / "measured.png", "biped")
    plot([SweepRow(0.1, 0.004, "w", "w", 0.6, 0.6, 0.2, 0.2, 0.7, True, 1, 1.0)],
         tmp_path / "planned.png", "quad")
    sizes = [png_size(tmp_path / name) for name in ("measured.png", "planned.png")]
    assert sizes[0][1] > sizes[1][1]  # the measured panel makes the figure taller


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) of a PNG from its IHDR chunk."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


@pytest.mark.parametrize(("duty", "n_knots", "expected"), [
    (0.42, 12, 0), (0.40, 12, 2), (0.35, 12, 2), (0.49, 16, 0), (0.6, 16, 0)])
def test_airborne_knots_count_the_flight_the_nlp_plans(duty: float, n_knots: int,
                                                       expected: int) -> None:
    """Duty 0.42 at N = 12: 16 % flight in the schedule, but every knot has a foot down."""
    schedule = ContactSchedule(0.48, FEET, (0.0, 0.5), (duty, duty))
    assert airborne_knots(schedule, n_knots) == expected
    row = SweepRow(0.5, 0.1, "biped_run", "biped_run", 0.48, duty, 1.0, 1.0, 0.5, True, 10,
                   60.0, flight_fraction=flight_fraction(schedule), airborne_knots=expected,
                   n_knots=n_knots)
    assert f"({expected}/{n_knots} knots) |" in to_markdown([row])


def test_the_table_says_which_rows_were_judged_closed_loop() -> None:
    row = SweepRow(0.2, 0.02, "biped_walk", "biped_walk", 0.6, 0.6, 0.2, 0.2, 0.9, True, 18,
                   60.0, sim_passed=True, sim_speed_m_s=0.2, sim_attitude_gain=0.5)
    assert "| pass 0.200 m/s, closed loop G 0.5 |" in to_markdown([row])
    opened = SweepRow(0.4, 0.08, "biped_run", "biped_run", 0.5, 0.4, 0.2, 0.2, 0.9, True, 18,
                      60.0, sim_passed=True, sim_speed_m_s=0.4, sim_attitude_gain=0.0)
    assert "| pass 0.400 m/s |" in to_markdown([opened])


def test_every_speed_searches_with_the_sweeps_search_settings(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """`sweep_speeds` hands `search_half_cycle`, `final_templates` and `final_half_cycle` to
    every speed's `search_gait`, with the final planner built for `final_half_cycle`."""
    import robots
    from planner.search import speed_sweep

    built: list[bool] = []
    seen: list[dict[str, object]] = []

    class Stop(Exception):
        pass

    def planner(robot: object, n_knots: int, options: object) -> object:
        built.append(options.half_cycle_solve)  # type: ignore[attr-defined]
        return object()

    def search(robot: object, speed: float, **kwargs: object) -> object:
        seen.append(kwargs)
        raise Stop

    monkeypatch.setattr(speed_sweep, "GaitPlanner", planner)
    monkeypatch.setattr(speed_sweep, "search_gait", search)
    with pytest.raises(Stop):
        speed_sweep.sweep_speeds(robots.load("quad12"), [0.1], search_half_cycle=False,
                                 final_templates="fallback", final_half_cycle=True)
    assert built == [True]
    assert {k: seen[0][k] for k in ("search_half_cycle", "final_templates",
                                     "final_half_cycle")} == {
        "search_half_cycle": False, "final_templates": "fallback", "final_half_cycle": True}

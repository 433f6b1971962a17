"""`benchmarks/inactive_rows_bench.py`: its IPOPT log files and the cases it measures."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import robots
from planner.templates import default_gait_for
from tests.benchmarks import load_script
from tests.zoo.fixtures import ZOO

bench = load_script("inactive_rows_bench")


def test_log_path_of_a_robot_given_as_a_folder_stays_in_the_work_folder(tmp_path: Path) -> None:
    """A robot loaded from a path (`tests/zoo/star5`) names its log by the robot's name, so the
    log lies directly in the work folder (IPOPT refused the path the name used to put there)."""
    star5 = robots.load(str(ZOO / "star5"))
    path = bench.log_path(tmp_path, star5, 30, "free point")
    assert path.parent == tmp_path
    assert path.name == "star5_30_free_point.log"
    path.write_text("")  # a file IPOPT can open


def test_log_path_replaces_separators(tmp_path: Path) -> None:
    quad = robots.load("quad12")
    assert bench.log_path(tmp_path, quad, 12, "a/b c").name == "quad12_12_a_b_c.log"


def test_case_keeps_the_measured_robots_and_gives_the_zoo_its_default_template() -> None:
    assert bench.case(robots.load("quad12")) == ("trot", 0.25)
    assert bench.case(robots.load("biped")) == ("biped_walk", 0.2)
    star5 = robots.load(str(ZOO / "star5"))
    gait, speed = bench.case(star5)
    assert gait == default_gait_for(star5)
    assert speed == pytest.approx((0.02 * 9.81 * star5.leg_length_m) ** 0.5, abs=1e-3)


def test_an_unknown_robot_is_refused_before_any_solve(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(sys, "argv", ["inactive_rows_bench.py", "--robot", "quad12,nosuch"])
    with pytest.raises(SystemExit):
        bench.main()
    assert "--robot 'nosuch'" in capsys.readouterr().err

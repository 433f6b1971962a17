"""`gaitsmith robots show` on a robot with flat feet."""

from pathlib import Path

import pytest

from gaitsmith.cli import main


def test_robots_show_names_flat_feet_and_their_sole(capsys: pytest.CaptureFixture[str]) -> None:
    folder = Path(__file__).parents[1] / "planner" / "fixtures" / "biped12"
    assert main(["robots", "show", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "left (l_foot, flat sole 110 × 70 mm)" in out


def test_robots_show_says_the_imu_and_its_default_gain(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "show", "biped"]) == 0
    out = capsys.readouterr().out
    assert "imu: OpenCR on-board MPU9250, torso; attitude feedback gain 0.5" in out
    assert main(["robots", "show", "quad12"]) == 0
    assert "imu:" not in capsys.readouterr().out

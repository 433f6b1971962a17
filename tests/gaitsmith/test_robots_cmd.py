import subprocess
import sys

import pytest

from gaitsmith.cli import main


def test_robots_lists_both_builtins(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert "quad12" in out and "hex18" in out and "STS3215_7V4" in out and "XL430_W250" in out


def test_robots_show_prints_joints_limits_and_servos(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "show", "quad12"]) == 0
    out = capsys.readouterr().out
    for text in ("fl_hip_roll", "hr_knee", "-149.0", "STS3215_7V4", "fingerprint"):
        assert text in out


def test_unknown_robot_is_one_clear_line_not_a_traceback() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "gaitsmith.cli", "robots", "show", "nobot"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert "no such robot folder" in proc.stderr and "nobot" in proc.stderr


def test_robots_show_a_users_robot_with_held_joints(capsys: pytest.CaptureFixture[str]) -> None:
    from pathlib import Path

    folder = Path(__file__).parents[1] / "robots" / "fixtures" / "heldquad"
    assert main(["robots", "show", str(folder)]) == 0  # before: KeyError on the held head
    out = capsys.readouterr().out
    assert "head_pan" in out and "(held)" in out and "MY_STS" in out
    assert "removed its 2 actuator(s)" in out and "gs_floor" in out

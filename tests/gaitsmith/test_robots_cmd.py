import subprocess
import sys
from pathlib import Path

import pytest

from gaitsmith.cli import main
from tests.zoo.fixtures import ZOO, heavy_copy


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


def test_robots_show_lists_held_joints(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "show", str(ZOO / "humanoid20")]) == 0
    out = capsys.readouterr().out
    assert "l_elbow" in out and "(held)" in out


def test_robots_init_then_check(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_dir = tmp_path / "spot"
    urdf = str(ZOO / "urdf" / "spotmicro.urdf")
    assert main(["robots", "init", urdf, "-o", str(out_dir), "--servo", "STS3215_12V"]) == 0
    out = capsys.readouterr().out
    assert "front_left" in out and "fl_hip_roll" in out and "robots check" in out
    assert main(["robots", "check", str(out_dir)]) == 0
    out = capsys.readouterr().out
    assert "stands" in out and "least margin" in out and "% of stall" in out


def test_robots_init_without_servo_and_yes_is_one_line(tmp_path: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gaitsmith.cli",
            "robots",
            "init",
            str(ZOO / "urdf" / "spotmicro.urdf"),
            "-o",
            str(tmp_path / "x"),
            "--yes",
        ],
        capture_output=True,
        text=True,
        check=False,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "pass --servo" in proc.stderr
    assert not (tmp_path / "x").exists()


def test_robots_init_bad_limit_option_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["robots", "init", str(ZOO / "urdf" / "spotmicro.urdf"), "-o", "/tmp/never"]
    assert main([*argv, "--servo", "STS3215_12V", "--limit", "tail=abc"]) == 2
    assert "JOINT=LOWER,UPPER" in capsys.readouterr().err


def test_robots_check_exits_non_zero_when_it_does_not_stand(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["robots", "check", str(heavy_copy(tmp_path, 12.0))]) == 1
    out = capsys.readouterr().out
    assert "does not stand" in out and "✗" in out


def test_robots_check_warns_about_double_counted_damping(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["robots", "check", str(ZOO / "phantomx18")]) == 0
    out = capsys.readouterr().out
    assert "warning:" in out and "[joints.lf_coxa]" in out


def test_robots_init_asks_for_the_servo_on_a_terminal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import io

    import gaitsmith.robots_cmd as cmd

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    prompts: list[str] = []

    def prompt(text: str) -> str:
        prompts.append(text)
        return "STS3215_12V"

    monkeypatch.setattr(cmd.sys, "stdin", Terminal())
    monkeypatch.setattr(cmd.typer, "prompt", prompt)
    urdf = str(ZOO / "urdf" / "spotmicro.urdf")
    assert main(["robots", "init", urdf, "-o", str(tmp_path / "s")]) == 0
    assert prompts == ["which servo drives the joints?"]
    assert "STS3215_12V" in capsys.readouterr().out
    # --yes never asks, even on a terminal
    assert main(["robots", "init", urdf, "-o", str(tmp_path / "t"), "--yes"]) == 2
    assert len(prompts) == 1

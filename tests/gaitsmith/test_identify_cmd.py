"""`gaitsmith-play identify` on the lifted twin, then `gaitsmith identify`, then the fitted file
in `gaitsmith simulate --servo-params` (and a broken file refused in one line)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import robots
from gaitsmith.cli import main
from hardware.cli import app as play_app
from robots import servo_params
from robots.gait import save
from sim.synthetic import standing_gait


@pytest.fixture(autouse=True)
def _calibration_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))


@pytest.mark.slow
def test_record_fit_and_simulate_with_the_fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    true = tmp_path / "true.toml"
    true.write_text(
        'schema = "gaitsmith.servo_params/1"\nrobot = "quad12"\n'
        "[joints.fl_knee]\ngain_scale = 1.3\nlatency_ms = 9.0\nstrength = 0.8\n"
    )
    record = tmp_path / "ident.csv"
    res = CliRunner().invoke(
        play_app,
        ["identify", "--robot", "quad12", "--virtual", "sim", "--no-realtime", "--yes",
         "-o", str(record), "--joints", "fl_knee", "--duration-s", "4",
         "--twin-servo-params", str(true)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    fitted, plot = tmp_path / "servo_params.toml", tmp_path / "fit.png"
    code = main(["identify", str(record), "--robot", "quad12", "-o", str(fitted),
                 "--plot", str(plot)])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    assert plot.stat().st_size > 10_000
    knee = servo_params.load(fitted).joints["fl_knee"]
    assert set(servo_params.load(fitted).joints) == {"fl_knee"}
    assert knee.gain_scale == pytest.approx(1.3, rel=0.05)
    assert knee.latency_ms == pytest.approx(9.0, rel=0.05)
    assert knee.strength == pytest.approx(0.8, rel=0.1)
    gait = tmp_path / "stand.json"
    save(standing_gait(robots.load("quad12")), gait)
    capsys.readouterr()
    code = main(["simulate", str(gait), "--cycles", "3", "--servo-params", str(fitted)])
    out = capsys.readouterr().out
    assert code in (0, 1) and "as identified in" in out


def test_a_bad_servo_params_file_is_one_line_naming_file_joint_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(
        'schema = "gaitsmith.servo_params/1"\nrobot = "quad12"\n[joints.fl_knee]\nstrength = 0\n'
    )
    gait = tmp_path / "stand.json"
    save(standing_gait(robots.load("quad12")), gait)
    for argv in (
        ["simulate", str(gait), "--cycles", "3", "--servo-params", str(bad)],
        ["plan", "quad12", "-o", str(tmp_path / "g.json"), "--servo-params", str(bad)],
    ):
        assert main(argv) == 2
        err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
        assert len(err) == 1 and "Traceback" not in err[0]
        assert f"{bad}: joints.fl_knee.strength: must be a number in (0, 5]" in err[0]
    assert main(["identify", str(tmp_path / "none.csv"), "--robot", "quad12",
                 "-o", str(tmp_path / "p.toml")]) == 2  # fmt: skip
    text = capsys.readouterr().err
    assert "none.csv: cannot read it" in text and not (tmp_path / "p.toml").exists()

"""`gaitsmith-play report`: planned vs measured after a run (in-process virtual bus)."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import robots
from hardware.cli import app
from hardware.play.errors import RunReportError
from hardware.play.run_report import DepartureRule, analyse, first_departure, load_inputs
from hardware.play.virtual_rig import bringup_gait
from robots.gait import save
from robots.thermal import joint_heating, thermal_model

runner = CliRunner()
ROBOT = "quad12"


def _validation(robot: robots.Robot) -> dict[str, object]:
    """A validation block shaped like `gaitsmith simulate --write-validation`'s (sim's
    per-joint metrics and `ThermalPrediction.to_dict`), from a constant 0.5 N·m per joint."""
    heat = [
        joint_heating(j.name, thermal_model(j.servo), np.full(40, 0.5)).to_dict()
        for j in robot.joints
    ]
    return {
        "passed": False,
        "reasons": ["speed: achieved 0.000 m/s"],
        "joints": [
            {"name": j.name, "peak_torque_fraction": 0.3, "rms_torque_fraction": 0.1,
             "tracking_rms_rad": 0.004, "tracking_max_rad": 0.01, "peak_speed_rad_s": 2.0}
            for j in robot.joints
        ],
        "thermal": {"schema": "gaitsmith.thermal/1", "bout_s": 600.0, "ambient_c": 25.0,
                    "joints": heat, "unmodelled": []},
    }


@pytest.fixture(autouse=True)
def _calibration_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))


@pytest.fixture(scope="module")
def _played(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """One short run of the bring-up gait on the virtual bus, shared by the module's tests."""
    root = tmp_path_factory.mktemp("played")
    robot = robots.load(ROBOT)
    gait_path, tel = root / "bringup.json", root / "tel.csv"
    save(bringup_gait(robot).with_validation(_validation(robot)), gait_path)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GAITSMITH_CALIBRATION_DIR", str(root / "cal"))
        res = runner.invoke(app, [
            "run", str(gait_path), "--robot", ROBOT, "--virtual", "--force", "--no-realtime",
            "--ramp-s", "0.5", "--cycles", "2", "--telemetry", str(tel),
        ])  # fmt: skip
    assert res.exit_code == 0, res.output
    return gait_path, tel


@pytest.fixture
def gait_file(_played: tuple[Path, Path]) -> Path:
    return _played[0]


@pytest.fixture
def telemetry(_played: tuple[Path, Path]) -> Path:
    return _played[1]


def _report(*args: str) -> tuple[int, str]:
    res = runner.invoke(app, ["report", *args])
    return res.exit_code, res.output


def test_report_of_a_virtual_run(telemetry: Path, gait_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.html"
    code, text = _report(str(telemetry), str(gait_file), "-o", str(out), "--robot", ROBOT)
    assert code == 0, text
    assert "never departed from the plan" in text
    page = out.read_text(encoding="utf-8")
    assert '<table class="tracking">' in page and 'id="departure"' in page
    assert "never departed from the plan" in page
    assert page.count("data:image/png;base64,") == 5
    assert 'src="http' not in page and "<script" not in page  # self-contained
    for name in robots.load(ROBOT).joint_names:
        assert f"<td>{name}</td>" in page
    assert "FAIL — speed: achieved" in page  # the MuJoCo verdict beside the run
    # the thermal prediction came from the validation block
    tel, gait, robot = load_inputs(telemetry, gait_file, ROBOT)
    rep = analyse(tel, gait, robot)
    assert all(j.thermal_source == "sim" and j.predicted_rise_k is not None for j in rep.joints)
    assert all(j.sim_tracking_rms_rad == pytest.approx(0.004) for j in rep.joints)
    # the virtual servo follows its goal closely: measured tracking well under the thresholds
    assert all(j.plan_max_rad < j.threshold_rad for j in rep.joints)
    assert rep.timing.rate_hz == pytest.approx(100.0, rel=1e-3) and rep.timing.overruns == 0


def _shift_present(src: Path, dst: Path, joint: str, from_gait_tick: int, by_rad: float) -> float:
    """Copy a telemetry file, pushing `joint`'s present position off by `by_rad` from the
    `from_gait_tick`-th gait tick on; returns that tick's t_sched_s."""
    with src.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    col = rows[0].index(f"{joint}_present_rad")
    gait_rows = [r for r in rows[1:] if r[1] == "gait"]
    for r in gait_rows[from_gait_tick:]:
        r[col] = f"{float(r[col]) + by_rad:.6g}"
    with dst.open("w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows(rows)
    return float(gait_rows[from_gait_tick][2])


def test_report_names_the_joint_and_time_of_the_departure(
    telemetry: Path, gait_file: Path, tmp_path: Path
) -> None:
    bad = tmp_path / "bad.csv"
    t_dep = _shift_present(telemetry, bad, "hl_knee", 60, 0.15)
    out = tmp_path / "run.html"
    code, text = _report(str(bad), str(gait_file), "-o", str(out))
    assert code == 0, text
    line = f"departed from the plan at t = {t_dep:.3f} s"
    assert line in text and "joint hl_knee" in text
    page = out.read_text(encoding="utf-8")
    assert line in page and "hl_knee ← departed" in page


def test_a_single_glitch_is_not_a_departure(
    telemetry: Path, gait_file: Path, tmp_path: Path
) -> None:
    tel, gait, _ = load_inputs(telemetry, gait_file)
    present = tel.present_rad.copy()
    k = [i for i, p in enumerate(tel.phase) if p == "gait"][30]
    present[k, 2] += 0.5  # one bad read
    from dataclasses import replace

    rep = analyse(replace(tel, present_rad=present), gait)
    assert rep.departure is None
    rep = analyse(replace(tel, present_rad=present), gait, rule=DepartureRule(ticks=1))
    assert rep.departure is not None and rep.departure.joint == tel.joint_names[2]


def test_first_departure_needs_consecutive_ticks_and_ignores_missed_reads() -> None:
    t = np.arange(10) * 0.01
    err = np.zeros((10, 2))
    err[2, 0] = err[4, 0] = 1.0  # isolated
    err[5:8, 0] = np.nan  # missed reads
    err[6:9, 1] = 1.0  # three in a row from tick 6
    dep = first_departure(t, np.arange(10), t, 0.05, err, [0.1, 0.1], ["a", "b"], 3)
    assert dep is not None and dep.joint == "b" and dep.tick == 6
    assert dep.cycle == 1 and dep.gait_phase == pytest.approx(0.2)


def test_wrong_speed_scale_is_flagged(telemetry: Path, gait_file: Path) -> None:
    tel, gait, _ = load_inputs(telemetry, gait_file)
    assert not analyse(tel, gait).warnings
    rep = analyse(tel, gait, speed_scale=0.5)
    assert any("do not follow this gait at speed scale 0.5" in w for w in rep.warnings)


@pytest.mark.parametrize(
    "content",
    [b"not,a,telemetry\nfile\n", b"\xff\xfe\x00garbage", b"tick,phase,t_sched_s\n"],
)
def test_garbled_telemetry_is_one_line_exit_2(
    content: bytes, gait_file: Path, tmp_path: Path
) -> None:
    bad = tmp_path / "garbled.csv"
    bad.write_bytes(content)
    out = tmp_path / "run.html"
    code, text = _report(str(bad), str(gait_file), "-o", str(out))
    assert code == 2, text
    assert text.strip().count("\n") == 0 and "garbled.csv" in text
    assert "Traceback" not in text and not out.exists()


def test_truncated_row_missing_files_and_mismatched_gait(
    telemetry: Path, gait_file: Path, tmp_path: Path
) -> None:
    cut = tmp_path / "cut.csv"
    lines = telemetry.read_text(encoding="utf-8").splitlines()
    cut.write_text("\n".join([*lines[:40], lines[40][:30]]) + "\n", encoding="utf-8")
    out = tmp_path / "run.html"
    for args, needle in [
        ((str(cut), str(gait_file)), "malformed row"),
        ((str(tmp_path / "none.csv"), str(gait_file)), "no such telemetry file"),
        ((str(telemetry), str(tmp_path / "none.json")), "none.json"),
        ((str(telemetry), str(gait_file), "--robot", "hex18"), "robot_fingerprint"),
        ((str(telemetry), str(gait_file), "--speed-scale", "0"), "--speed-scale 0"),
        ((str(telemetry), str(gait_file), "--departure-rad", "nan"), "--departure-rad nan"),
    ]:
        code, text = _report(*args, "-o", str(out))
        assert code == 2, (args, text)
        assert needle in text and text.strip().count("\n") == 0, text
        assert not out.exists()
    hex_gait = tmp_path / "hex.json"
    save(bringup_gait(robots.load("hex18")), hex_gait)
    code, text = _report(str(telemetry), str(hex_gait), "-o", str(out))
    assert code == 2 and "do not match the gait's" in text


def test_the_report_never_imports_mujoco_or_sim(
    telemetry: Path, gait_file: Path, tmp_path: Path
) -> None:
    """Without --robot nothing but files is read: no mujoco, casadi or sim in the process.
    (With --robot, `robots.load` parses the robot's MJCF with mujoco, as every player
    command that loads a robot does.)"""
    out = tmp_path / "run.html"
    code = (
        "import sys\n"
        "from hardware.play.run_report import write_report\n"
        f"write_report({str(telemetry)!r}, {str(gait_file)!r}, {str(out)!r})\n"
        "heavy = sorted(m for m in sys.modules if m.split('.')[0] in ('mujoco', 'casadi', 'sim'))\n"
        "assert not heavy, heavy\n"
        "print('ok')\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "ok" and out.is_file()


def test_departure_rule_rejects_nonsense() -> None:
    with pytest.raises(RunReportError, match="factor"):
        DepartureRule(factor=0.0)
    with pytest.raises(RunReportError, match="floor_rad"):
        DepartureRule(abs_rad=0.01, floor_rad=0.02)


def test_a_run_stopped_in_the_ramp_is_reported_without_a_departure(
    telemetry: Path, gait_file: Path, tmp_path: Path
) -> None:
    """A log cut short in ramp_in (no gait ticks, no stop row) still gives a page saying so."""
    short = tmp_path / "ramp.csv"
    short.write_text(
        "\n".join(telemetry.read_text(encoding="utf-8").splitlines()[:31]) + "\n",
        encoding="utf-8",
    )
    out = tmp_path / "run.html"
    code, text = _report(str(short), str(gait_file), "-o", str(out))
    assert code == 0, text
    assert "no departure can be judged" in text
    assert "no stop row" in out.read_text(encoding="utf-8")

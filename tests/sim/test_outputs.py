"""Offscreen video (GIF, MP4), the HTML report, the robustness sweep and `gaitsmith simulate`."""

from __future__ import annotations

import json
import re
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
from typer.testing import CliRunner

import robots.gait as gait_io
from gaitsmith.cli import app
from robots.gait import Gait
from robots.robot import Robot
from sim.errors import RenderError
from sim.render import render_video
from sim.report import write_report
from sim.robustness import robustness_sweep
from sim.validate import evaluate, simulate


@pytest.fixture(scope="module")
def tripod_run(hex18: Robot, hex_tripod: Gait):  # type: ignore[no-untyped-def]
    sim, traj = simulate(hex_tripod, hex18, cycles=4)
    return sim, traj


def test_gif_and_mp4_render_offscreen(tripod_run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    sim, traj = tripod_run
    gif = render_video(tmp_path / "a.gif", sim, traj, width=96, height=72, fps=10, duration_s=2.0)
    frames = iio.imread(gif, index=None)
    assert frames.shape == (21, 72, 96, 3)
    assert frames.std() > 5  # not a blank image
    assert not np.array_equal(frames[0], frames[-1])  # the robot (and camera) moved
    mp4 = render_video(tmp_path / "a.mp4", sim, traj, width=128, height=96, fps=15, duration_s=1.0)
    assert mp4.stat().st_size > 1000
    assert iio.improps(mp4).shape[-3:] == (96, 128, 3)
    assert not list(tmp_path.glob(".*"))  # no temp files left behind
    with pytest.raises(RenderError):
        render_video(tmp_path / "a.avi", sim, traj, width=32, height=32, duration_s=0.1)


def test_report_is_self_contained(tripod_run, hex_tripod: Gait, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    sim, traj = tripod_run
    res = evaluate(traj, hex_tripod, sim)
    path = write_report(tmp_path / "r.html", res, hex_tripod, sim)
    text = path.read_text(encoding="utf-8")
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', text)
    assert len(images) == 4
    assert "Hildebrand" in text and ("PASS" in text or "FAIL" in text)
    assert 'src="http' not in text and "<script" not in text


def test_robustness_sweep(quad: Robot, quad_stand: Gait) -> None:
    res = robustness_sweep(
        quad_stand,
        quad,
        cycles=3,
        frictions=(0.5,),
        payloads_kg=(5.0,),
        latencies_s=(0.02,),
        strengths=(0.9,),
    )
    assert [r.factor for r in res.runs] == ["friction", "payload_kg", "latency_s", "strength"]
    by = {r.factor: r for r in res.runs}
    assert by["friction"].passed and by["latency_s"].passed and by["strength"].passed
    assert not by["payload_kg"].passed  # 5 kg on a 1.9 kg robot overloads the knees
    assert res.pass_fraction == pytest.approx(0.75)
    json.dumps(res.to_dict(), allow_nan=False)


def test_cli_simulate_pass_and_fail(
    hex18: Robot, hex_tripod: Gait, quad: Robot, tmp_path: Path
) -> None:
    runner = CliRunner()
    good = tmp_path / "tripod.json"
    gait_io.save(hex_tripod, good)
    report, video = tmp_path / "r.html", tmp_path / "v.gif"
    out = runner.invoke(
        app,
        [
            "simulate",
            str(good),
            "--cycles",
            "4",
            "--report",
            str(report),
            "--video",
            str(video),
            "--video-seconds",
            "1",
            "--write-validation",
        ],
    )
    assert out.exit_code == 0, out.output
    assert "PASS" in out.output and "cost of transport" in out.output
    assert report.is_file() and video.is_file()
    assert gait_io.load(good).validation["passed"] is True  # type: ignore[index]
    from sim.synthetic import kinematic_gait, trot_schedule

    bad = tmp_path / "fast.json"
    gait_io.save(kinematic_gait(hex18, trot_schedule(hex18, 0.3, 0.6), 0.3, lift_m=0.04), bad)
    out = runner.invoke(app, ["simulate", str(bad), "--cycles", "5"])
    assert out.exit_code == 1 and "peak torque" in out.output
    out = runner.invoke(app, ["simulate", str(good), "--robot", "quad12"])
    assert out.exit_code != 0  # fingerprint mismatch: a GaitFileError, not a traceback
    assert isinstance(out.exception, Exception) and "fingerprint" in str(out.exception)


def test_cli_main_turns_errors_into_exit_2(tmp_path: Path) -> None:
    from gaitsmith.cli import main

    assert main(["simulate", str(tmp_path / "missing.json")]) == 2
    (tmp_path / "x.json").write_text("{}")
    assert main(["simulate", str(tmp_path / "x.json"), "--video", str(tmp_path / "v.avi")]) == 2

"""Offscreen video (GIF, MP4), the HTML report, the robustness sweep and `gaitsmith simulate`."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

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


def _dead_pid() -> int:
    pid = 4_000_000  # above Linux's pid_max default: no such process
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    return pid


def test_frames_are_lit_and_the_camera_glides_along(tripod_run) -> None:  # type: ignore[no-untyped-def]
    """The video was very dark (mean ≈ 26/255 on quad12) with a tracking camera glued to the
    body; now a brighter headlight and floor, distance marks, and a camera at fixed height that
    follows the body's smoothed x."""
    from sim.render import camera_lookat, distance_marks, iter_frames

    sim, traj = tripod_run
    frames = list(iter_frames(sim, traj, width=160, height=120, fps=5, start_s=1.0,
                              duration_s=2.0))
    assert np.mean([f.mean() for f in frames]) > 45
    idx = np.clip(np.searchsorted(traj.time_s, np.arange(1.0, 3.0, 0.2)), 0, traj.n_steps - 1)
    lookat = camera_lookat(sim, traj, idx, fps=5)
    assert np.all(np.diff(lookat[:, 0]) > 0)  # moves forward with the robot (0.1 m/s)
    assert np.ptp(lookat[:, 2]) == 0  # fixed height: no bobbing
    y = traj.qpos[idx, int(sim.model.jnt_qposadr[0]) + 1]
    assert np.ptp(lookat[:, 1]) <= np.ptp(y) + 1e-12  # sway smoothed, not copied
    marks = distance_marks(0.2, 0.7)
    assert [label for _, label in marks][:3] == ["-0.25 m", "0 m", "0.25 m"]
    assert marks[-1][0] >= 0.7


def test_a_truncated_mp4_is_an_error_not_a_video(  # type: ignore[no-untyped-def]
    tripod_run, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """imageio does not check ffmpeg's exit status: on a full disk the encoder's output is cut
    short but the write "succeeds". The frames are counted before the rename."""
    import sim.render as render

    real_get_writer = render.imageio.get_writer

    class CutShort:
        def __init__(self, path: Path, **kwargs: Any) -> None:
            self.path, self.writer = Path(path), real_get_writer(path, **kwargs)

        def __enter__(self) -> CutShort:
            return self

        def append_data(self, frame: np.ndarray) -> None:
            self.writer.append_data(frame)

        def __exit__(self, *exc: object) -> None:
            self.writer.close()
            data = self.path.read_bytes()
            self.path.write_bytes(data[: len(data) // 3])  # what a full disk leaves

    monkeypatch.setattr(render.imageio, "get_writer", CutShort)
    sim, traj = tripod_run
    stale = tmp_path / f".v.mp4.{_dead_pid()}.abcd.tmp.mp4"  # a SIGKILLed earlier run's litter
    stale.write_bytes(b"junk")
    past = time.time() - 3600
    os.utime(stale, (past, past))
    with pytest.raises(RenderError, match="of 15 frames"):
        render_video(tmp_path / "v.mp4", sim, traj, width=64, height=48, fps=15, duration_s=0.95)
    assert list(tmp_path.iterdir()) == []  # no video, no temp, the stale temp cleaned up


def test_video_onto_a_full_disk_fails_and_leaves_nothing(tmp_path: Path) -> None:
    """A real encoder failing mid-write: ffmpeg's output file size is capped (RLIMIT_FSIZE, with
    SIGXFSZ ignored writes fail as on a full disk) in a subprocess."""
    code = (
        "import resource, signal, sys\n"
        "import numpy as np\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))\n"
        "from sim.errors import RenderError\n"
        "from sim.render import write_video\n"
        "rng = np.random.default_rng(0)\n"
        "frames = (rng.integers(0, 255, (240, 320, 3), dtype=np.uint8) for _ in range(40))\n"
        "try:\n"
        "    write_video(sys.argv[1], frames, fps=10)\n"
        "except RenderError as exc:\n"
        "    print(exc)\n"
        "    sys.exit(3)\n"
    )
    target = tmp_path / "v.mp4"
    proc = subprocess.run([sys.executable, "-c", code, str(target)], capture_output=True,
                          text=True, timeout=300, check=False)
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "cannot write video" in proc.stdout or "frames" in proc.stdout
    assert len(proc.stdout.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_report_has_the_robustness_table(tripod_run, hex_tripod: Gait, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from sim.report import render_html
    from sim.robustness import RobustnessResult, SweepRun

    sim, traj = tripod_run
    res = evaluate(traj, hex_tripod, sim)
    sweep = RobustnessResult((
        SweepRun("friction", 0.3, True, (), 0.098, 0.41, False),
        SweepRun("payload_kg", 2.0, False, ("peak torque 130% > 80% of stall",), 0.05, 1.3, True),
    ))
    text = render_html(res, hex_tripod, sim, robustness=sweep)
    assert "<h2>Robustness</h2>" in text and "50% of 2 perturbed runs pass" in text
    assert "<td>payload_kg</td><td>2</td><td class='fail'>FAIL</td>" in text
    assert "peak torque 130% &gt; 80% of stall" in text
    assert "Robustness" not in render_html(res, hex_tripod, sim)


def test_cli_simulate_robustness_goes_into_the_report(  # type: ignore[no-untyped-def]
    hex_tripod: Gait, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sim.robustness
    from gaitsmith.cli import main
    from sim.robustness import RobustnessResult, SweepRun

    calls = []

    def small_sweep(*args: Any, **kwargs: Any) -> RobustnessResult:  # the real one: ~1 min
        calls.append(args)
        return RobustnessResult((SweepRun("latency_s", 0.02, True, (), 0.1, 0.4, False),))

    monkeypatch.setattr(sim.robustness, "robustness_sweep", small_sweep)
    good = tmp_path / "tripod.json"
    gait_io.save(hex_tripod, good)
    report = tmp_path / "r.html"
    assert main(["simulate", str(good), "--cycles", "4", "--robustness",
                 "--report", str(report)]) == 0
    assert calls and "<td>latency_s</td><td>0.02</td>" in report.read_text(encoding="utf-8")


def test_report_shows_each_joints_closest_approach_to_its_limits(  # type: ignore[no-untyped-def]
    tripod_run, hex_tripod: Gait
) -> None:
    import dataclasses
    import math

    from sim.report import render_html

    sim, traj = tripod_run
    res = evaluate(traj, hex_tripod, sim)
    lower = np.array([j.lower_rad for j in sim.robot.joints])
    upper = np.array([j.upper_rad for j in sim.robot.joints])
    from sim.metrics import steady_mask

    q = traj.q_rad[steady_mask(traj, 2)]  # the steady cycles, as the metrics use them
    for j, (jm, lo, hi) in enumerate(zip(res.joints, lower, upper, strict=True)):
        assert jm.name == sim.robot.joint_names[j]
        assert jm.limit_clearance_rad == pytest.approx(min(q[:, j].min() - lo, hi - q[:, j].max()))
        assert jm.limit_clearance_fraction == pytest.approx(jm.limit_clearance_rad / (hi - lo))
    # the planner's closest approach and margin from the gait's metadata, and a simulated
    # approach inside that margin is marked
    first = res.joints[0].name
    meta = {"joint_limit_clearance": {first: {"closest_rad": 0.5, "margin_rad": 10.0}}}
    text = render_html(res, dataclasses.replace(hex_tripod, planner=meta), sim)
    row = next(r for r in text.split("<tr>") if r.startswith(f"<td>{first}</td>"))
    assert f"{math.degrees(0.5):.1f} ({math.degrees(10.0):.1f})" in row
    assert "class='fail'" in row
    plain = render_html(res, hex_tripod, sim)
    assert "closest to limit, simulated" in plain and "— (—)" in plain

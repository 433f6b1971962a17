"""`gaitsmith drive-sim`: option and input errors are one line, exit 2, before any simulation;
one short end-to-end run writes every output."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import robots
from gaitsmith import drive_sim_cmd
from gaitsmith.cli import main
from robots import library as library_io
from tests.sim.path.kinematic_library import kinematic_library


@pytest.fixture(scope="module")
def hex_library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    lib = kinematic_library(robots.load("hex18"), (0.0, 0.05, 0.1), (-0.4, 0.0, 0.4))
    out = tmp_path_factory.mktemp("lib") / "hex18_kin.json"
    library_io.save(lib, out)
    return out


class SimulationStarted(Exception):
    pass


def _too_late(*args: Any, **kwargs: Any) -> Any:
    raise SimulationStarted


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    return err


@pytest.mark.parametrize("extra, match", [
    (["--path", "circle:abc"], "--path 'circle:abc': radius 'abc' is not a number"),
    (["--path", "circle:0.05"], "below 0.213 m"),
    (["--path", "spiral:1"], "unknown path kind"),
    (["--path", "0,0;1,0", "--laps", "2"], "--laps 2: '0,0;1,0' is an open path"),
    (["--path", "circle:1", "--laps", "0"], "--laps must be an integer in [1, 100]"),
    (["--path", "circle:1", "--lookahead", "0.1"], "--lookahead must be a number in"),
    (["--path", "circle:1", "--video", "x.avi"], "must end in .mp4 or .gif"),
    (["--path", "circle:1", "--plot", "x.jpg"], "must end in .png"),
    (["--path", "circle:1", "--robot", "quad12"], "fingerprint"),
    (["--path", "circle:1", "--attitude-gain", "2.5"], "--attitude-gain must be a number in"),
    (["--path", "circle:1", "--imu-noise-deg", "-1"], "--imu-noise-deg must be a number in"),
])
def test_bad_input_is_one_line_exit_2(hex_library: Path, extra: list[str], match: str,
                                      capsys: pytest.CaptureFixture[str],
                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(drive_sim_cmd, "follow", _too_late)
    assert main(["drive-sim", str(hex_library), *extra]) == 2
    assert match in _error_line(capsys)


def test_missing_library_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["drive-sim", str(tmp_path / "nope.json"), "--path", "circle:1"]) == 2
    assert "nope.json" in _error_line(capsys)


@pytest.mark.slow
def test_short_drive_writes_every_output(hex_library: Path, tmp_path: Path) -> None:
    out = {k: tmp_path / f"run.{k}" for k in ("png", "html", "json", "gif")}
    code = main(["drive-sim", str(hex_library), "--path", "0,0;0.5,0;0.8,0.2",
                 "--plot", str(out["png"]), "--report", str(out["html"]),
                 "--json", str(out["json"]), "--video", str(out["gif"]),
                 "--video-speed", "20"])
    assert code == 0
    doc = json.loads(out["json"].read_text())
    assert doc["passed"] and doc["metrics"]["arrived"] and not doc["metrics"]["fell"]
    assert doc["metrics"]["cross_track_mean_m"] < 0.02
    assert out["png"].read_bytes()[:4] == b"\x89PNG"
    assert "PASS" in out["html"].read_text() and "data:image/png;base64" in out["html"].read_text()
    assert out["gif"].read_bytes()[:3] == b"GIF"

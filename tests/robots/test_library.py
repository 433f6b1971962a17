"""The gait library file: round trip, one-line errors naming file and field, fingerprint refusal."""

import copy
import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import robots
from robots import Velocity
from robots import library as libfile
from robots.errors import GaitFileError, LibraryFileError
from tests.robots.library_fixture import make_library


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


@pytest.fixture(scope="module")
def doc(quad: robots.Robot) -> dict[str, Any]:
    return libfile.to_dict(make_library(quad))


def test_round_trip(tmp_path: Path, quad: robots.Robot) -> None:
    lib = make_library(quad)
    path = tmp_path / "lib.json"
    libfile.save(lib, path)
    assert json.loads(path.read_text())["schema"] == "gaitsmith.library/1"
    back = libfile.load(path, quad)
    assert back.family == "trot" and back.joint_names == quad.joint_names
    assert [e.command for e in back.entries] == [e.command for e in lib.entries]
    assert [e.achieved for e in back.entries] == [e.achieved for e in lib.entries]
    for a, b in zip(back.entries, lib.entries, strict=True):
        np.testing.assert_allclose(a.gait.joint_angles_rad, b.gait.joint_angles_rad)
        assert a.gait.period_s == b.gait.period_s and a.gait.validation == b.gait.validation
    np.testing.assert_allclose(back.stand.joint_angles_rad, lib.stand.joint_angles_rad)
    assert back.built == lib.built
    assert [p.name for p in tmp_path.iterdir()] == ["lib.json"]  # no temp file left


def test_command_bounds(quad: robots.Robot) -> None:
    lo, hi = make_library(quad).command_bounds()
    assert lo == Velocity(0.0, 0.0, -0.5) and hi == Velocity(0.2, 0.0, 0.5)


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def edit(d: dict[str, Any]) -> None:
        keys: list[Any] = [int(k) if k.isdigit() else k for k in path.split("/")]
        for k in keys[:-1]:
            d = d[k]
        if value is _DELETE:
            del d[keys[-1]]
        else:
            d[keys[-1]] = value

    return edit


_DELETE = object()

BAD = [
    ("schema", _set("schema", "gaitsmith.gait/1"), "schema"),
    ("unknown", _set("extra", 1), "extra"),
    ("names", _set("joint_names", []), "joint_names"),
    ("no stand", _set("stand", _DELETE), "stand"),
    ("stand moving", _set("stand/velocity/vx_m_s", 0.1), "stand.velocity"),
    ("stand lifts", _set("stand/schedule/duty_factor/0", 0.6), "stand.schedule.duty_factor"),
    ("stand sample", _set("stand/joint_angles_rad/2/1", "x"), "stand.joint_angles_rad[2][1]"),
    ("no entries", _set("entries", []), "entries"),
    ("entry keys", _set("entries/1/achieved", _DELETE), "entries[1]"),
    ("sample", _set("entries/1/gait/joint_angles_rad/2/3", None),
     "entries[1].gait.joint_angles_rad[2][3]"),
    ("command", _set("entries/2/command/vx_m_s", 0.15), "entries[2].command"),
    ("achieved", _set("entries/2/achieved/yaw_rate_rad_s", "fast"),
     "entries[2].achieved.yaw_rate_rad_s"),
    ("not validated", _set("entries/3/gait/validation", None), "entries[3].gait.validation"),
    ("failed", _set("entries/3/gait/validation/passed", False), "entries[3].gait.validation"),
    ("schedule", _set("entries/4/gait/schedule/duty_factor/0", 0.7), "entries[4].gait.schedule"),
    ("family", _set("entries/4/gait/gait_label", "walk"), "entries[4].gait.gait_label"),
    ("fingerprint", _set("entries/5/gait/robot_fingerprint", "0123"),
     "entries[5].gait.robot_fingerprint"),
    ("built", _set("built", [1]), "built"),
]


@pytest.mark.parametrize(("name", "edit", "field"), BAD, ids=[b[0] for b in BAD])
def test_bad_file_names_file_and_field(
    tmp_path: Path, doc: dict[str, Any], name: str, edit: Callable[[dict[str, Any]], None],
    field: str,
) -> None:
    d = copy.deepcopy(doc)
    edit(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(LibraryFileError) as info:
        libfile.load(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: {field}:"), msg
    assert "\n" not in msg
    assert isinstance(info.value, GaitFileError)  # CLIs that refuse bad gaits refuse these too


def test_duplicate_command(tmp_path: Path, doc: dict[str, Any]) -> None:
    d = copy.deepcopy(doc)
    d["entries"].append(copy.deepcopy(d["entries"][0]))
    path = tmp_path / "dup.json"
    path.write_text(json.dumps(d))
    with pytest.raises(LibraryFileError, match=r"entries\[9\]\.command: .* repeats entries\[0\]"):
        libfile.load(path)


@pytest.mark.parametrize("text", ["", "{", "[1, 2]", "1" * 40])
def test_not_a_library(tmp_path: Path, text: str) -> None:
    path = tmp_path / "x.json"
    path.write_text(text)
    with pytest.raises(LibraryFileError, match=rf"^{path}: <(json|root)>: "):
        libfile.load(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(LibraryFileError, match="<file>: cannot read"):
        libfile.load(tmp_path / "none.json")


def test_refuses_another_build(tmp_path: Path, quad: robots.Robot, quad_copy: Path) -> None:
    path = tmp_path / "lib.json"
    libfile.save(make_library(quad), path)
    toml = quad_copy / "robot.toml"
    toml.write_text(toml.read_text() + "\n# a different build\n")
    other = robots.load(quad_copy)
    assert other.fingerprint != quad.fingerprint
    with pytest.raises(LibraryFileError, match=r"robot_fingerprint: library was built for quad12@"):
        libfile.load(path, other)
    with pytest.raises(LibraryFileError, match="robot_fingerprint"):
        libfile.load(path, robots.load("hex18"))


def test_robot_for_finds_the_builtin(tmp_path: Path, quad: robots.Robot) -> None:
    path = tmp_path / "lib.json"
    libfile.save(make_library(quad), path)
    assert libfile.robot_for(libfile.load(path), path).fingerprint == quad.fingerprint


def test_save_refuses_an_unvalidated_entry(tmp_path: Path, quad: robots.Robot) -> None:
    lib = make_library(quad)
    bad = libfile.LibraryEntry(lib.entries[0].command, lib.entries[0].gait.with_validation(
        {"passed": False, "reasons": ["fell"]}), lib.entries[0].achieved)
    lib = replace(lib, entries=(bad, *lib.entries[1:]))
    path = tmp_path / "lib.json"
    with pytest.raises(LibraryFileError, match=r"entries\[0\]\.gait\.validation"):
        libfile.save(lib, path)
    assert not path.exists() and list(tmp_path.iterdir()) == []

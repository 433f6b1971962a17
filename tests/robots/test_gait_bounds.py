"""Gait files: bounded sizes, magnitudes and types (issue #12) and the robot folder they remember
(issue #13: a gait for a user's robot works from any working directory)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import robots
from robots import ContactSchedule, Gait, GaitFileError, Velocity
from robots import gait as gaitfile


def _gait(robot: robots.Robot, n: int = 8) -> Gait:
    return Gait.create(
        robot=robot,
        knots_rad=np.tile(robot.nominal_stance_rad, (n, 1)),
        schedule=ContactSchedule(0.5, robot.foot_names, (0.0, 0.5, 0.5, 0.0), (0.6,) * 4),
        velocity=Velocity(0.1),
        gait_label="trot",
    )


@pytest.fixture(scope="module")
def doc() -> dict:
    return gaitfile.to_dict(_gait(robots.load("quad12")))


def _loads(d: dict | str) -> Gait:
    return gaitfile.loads(d if isinstance(d, str) else json.dumps(d), "g.json")


def test_huge_integers_are_refused_by_name(doc: dict) -> None:
    text = json.dumps(doc).replace('"period_s": 0.5', '"period_s": ' + "1" + "0" * 400)
    with pytest.raises(GaitFileError, match="more than 30 digits"):
        _loads(text)
    d = json.loads(json.dumps(doc))
    d["velocity"]["vx_m_s"] = 10**25
    with pytest.raises(GaitFileError) as info:
        _loads(d)
    assert info.value.field == "velocity.vx_m_s"


def test_too_many_knots_is_refused_before_any_element_is_read(
    doc: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The count is checked before the per-element checks and the N × N spline (not a timing:
    a timed unit test failed at 10.5 s on a loaded 2-core machine for 0.7 s of work)."""
    d = json.loads(json.dumps(doc))
    d["joint_angles_rad"] = [d["joint_angles_rad"][0]] * 100_001
    text = json.dumps(d)

    def element_checked(*args: object) -> None:
        raise AssertionError("the knots were read one by one before their count was checked")

    monkeypatch.setattr(gaitfile, "_check_numeric", element_checked)
    with pytest.raises(GaitFileError, match="100000 knots; at most 1000"):
        _loads(text)


@pytest.mark.parametrize("period", [1e3, 1e300, 61.0])
def test_absurd_periods_are_refused(doc: dict, period: float) -> None:
    d = json.loads(json.dumps(doc))
    d["period_s"] = period
    with pytest.raises(GaitFileError) as info:
        _loads(d)
    assert info.value.field == "period_s"


@pytest.mark.parametrize(
    ("path", "value"),
    [
        (("period_s",), "0.5"),
        (("velocity", "vx_m_s"), "0.1"),
        (("joint_angles_rad", 2, 3), "0.1"),
        (("joint_angles_rad", 1, 0), True),
        (("schedule", "duty_factor", 0), "0.6"),
        (("joint_angles_rad", 1, 1), 1e6),
    ],
)
def test_numbers_must_be_json_numbers_of_plausible_size(
    doc: dict, path: tuple, value: object
) -> None:
    d = json.loads(json.dumps(doc))
    node = d
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    with pytest.raises(GaitFileError) as info:
        _loads(d)
    assert info.value.field.startswith(path[0])


def test_deep_metadata_is_refused(doc: dict) -> None:
    d = json.loads(json.dumps(doc))
    deep: dict = {}
    node = deep
    for _ in range(100):
        node["x"] = {}
        node = node["x"]
    d["planner"] = deep
    with pytest.raises(GaitFileError, match="planner: nested more than 32"):
        _loads(d)
    with pytest.raises(GaitFileError, match="<json>"):
        _loads("[" * 100_000 + "]" * 100_000)


@pytest.mark.parametrize("bad", ["3", 0, 21, 10**9, 2.5, True, None])
def test_a_bad_entry_blend_request_is_refused_by_name(doc: dict, bad: object) -> None:
    """planner.entry_blend_cycles (written by `plan --entry-cycles`) is checked on loading: a
    huge one would have the player allocate the blend's samples (1e9 cycles: 349 GiB)."""
    d = json.loads(json.dumps(doc))
    d["planner"] = {gaitfile.ENTRY_CYCLES_KEY: bad}
    with pytest.raises(GaitFileError, match=r"planner\.entry_blend_cycles: must be a whole number"):
        _loads(d)
    d["planner"] = {gaitfile.ENTRY_CYCLES_KEY: gaitfile.MAX_ENTRY_CYCLES}
    assert _loads(d).planner[gaitfile.ENTRY_CYCLES_KEY] == gaitfile.MAX_ENTRY_CYCLES


def test_old_gait_files_without_robot_dir_still_load(doc: dict) -> None:
    assert "robot_dir" not in doc  # built-in robots store no folder
    g = _loads(doc)
    assert g.robot_dir is None
    assert gaitfile.robot_for(g, "g.json").name == "quad12"


def test_a_gait_finds_its_users_robot_from_anywhere(
    quad_copy: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    toml = quad_copy / "robot.toml"
    toml.write_text(toml.read_text().replace('name = "quad12"', 'name = "myquad"'))
    bot = robots.load(quad_copy)
    gaits = tmp_path / "gaits"
    path = gaits / "trot.json"
    gaitfile.save(_gait(bot), path)
    stored = json.loads(path.read_text())["robot_dir"]
    assert stored == {"absolute": str(quad_copy.resolve()), "relative": "../myquad"}
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # no folder named after the robot here
    g = gaitfile.load(path)
    assert gaitfile.robot_for(g, path).fingerprint == bot.fingerprint  # relative
    moved = tmp_path / "a" / "b" / "trot.json"  # ../myquad no longer leads to it: absolute does
    moved.parent.mkdir(parents=True)
    shutil.move(path, moved)
    assert gaitfile.robot_for(gaitfile.load(moved), moved).root_dir == quad_copy.resolve()
    # robot and gait moved together: the relative path still works, the absolute one does not
    shutil.move(quad_copy, tmp_path / "moved_bot")
    both = tmp_path / "c" / "trot.json"
    gaitfile.save(gaitfile.load(moved), both)
    data = json.loads(both.read_text())
    data["robot_dir"]["relative"] = "../moved_bot"
    both.write_text(json.dumps(data))
    found = gaitfile.robot_for(gaitfile.load(both), both)
    assert found.root_dir == (tmp_path / "moved_bot").resolve()
    # the --robot override wins, and the fingerprint still refuses another build
    with pytest.raises(GaitFileError, match="robot_fingerprint"):
        gaitfile.robot_for(gaitfile.load(both), both, robot="quad12")
    toml = tmp_path / "moved_bot" / "robot.toml"
    toml.write_text(toml.read_text().replace("stance_deg = 40.0", "stance_deg = 41.0", 1))
    with pytest.raises(GaitFileError, match="robot_fingerprint"):
        gaitfile.robot_for(gaitfile.load(both), both)
    shutil.rmtree(tmp_path / "moved_bot")
    with pytest.raises(GaitFileError, match="--robot FOLDER"):
        gaitfile.robot_for(gaitfile.load(both), both)

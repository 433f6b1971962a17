"""Hypothesis-fuzzed gait files and robot.toml files: only the typed errors ever escape."""

import copy
import json
import os
import shutil
import sys
from pathlib import Path
from typing import Any

import hypothesis.strategies as st
import numpy as np
from hypothesis import HealthCheck, given, settings

import robots
from robots import ContactSchedule, Gait, GaitFileError, RobotConfigError, Velocity
from robots import gait as gaitfile

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

QUAD = robots.load("quad12")


def _examples(default: int) -> int:
    """Hypothesis examples per test: GAITSMITH_FUZZ_EXAMPLES=N for a longer fuzzing run."""
    return int(os.environ.get("GAITSMITH_FUZZ_EXAMPLES", default))


_N = 8
_BASE_GAIT = gaitfile.to_dict(
    Gait.create(
        robot=QUAD,
        knots_rad=np.tile(QUAD.nominal_stance_rad, (_N, 1)),
        schedule=ContactSchedule(0.5, QUAD.foot_names, (0.0, 0.5, 0.5, 0.0), (0.6,) * 4),
        velocity=Velocity(0.2),
        gait_label="trot",
        base_pose=np.zeros((_N, 6)),
    )
)

json_leaf = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.integers(-(10**400), 10**400),  # issue #12: 10**400 → OverflowError
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e3, 1e300, 5e-324, -0.0]),  # issue #12: period_s 1e3…1e300
    st.text(max_size=8),
    st.sampled_from(["0.1", "1", "1e3", "nan"]),  # issue #12: numbers given as strings
)
json_value = st.recursive(
    json_leaf,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=4)
    ),
    max_leaves=12,
)


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node[:3]):
            out += _paths(v, (*prefix, i))
    return out


def _mutate(doc: Any, path: tuple, action: str, value: Any) -> Any:
    if not path:
        return value
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    key = path[-1]
    if action == "delete":
        del parent[key]
    else:
        parent[key] = value
    return doc


@settings(max_examples=_examples(300), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_fuzzed_gait_files_raise_only_gait_file_error(data: st.DataObject) -> None:
    doc = copy.deepcopy(_BASE_GAIT)
    for _ in range(data.draw(st.integers(1, 3))):
        paths = _paths(doc)
        path = data.draw(st.sampled_from(paths))
        action = data.draw(st.sampled_from(["replace", "delete"])) if path else "replace"
        doc = _mutate(doc, path, action, data.draw(json_value))
    rows = 0
    if isinstance(doc, dict) and data.draw(st.integers(0, 19)) == 0:
        rows = data.draw(st.sampled_from([1001, 5000, 100_000]))  # issue #12: 74.5 GiB spline
        doc["joint_angles_rad"] = "@ROWS@"
    text = json.dumps(doc)
    if rows:  # spliced as text: json.dumps of 100 000 rows would dominate the test's time
        row = json.dumps(list(QUAD.nominal_stance_rad))
        text = text.replace('"@ROWS@"', "[" + ",".join([row] * rows) + "]")
    if text.endswith("}") and data.draw(st.integers(0, 19)) == 0:  # deep nesting
        depth = data.draw(st.integers(30, 100_000))
        text = text[:-1] + ', "planner": ' + "[" * depth + "]" * depth + "}"
    if data.draw(st.booleans()):
        cut = data.draw(st.integers(0, len(text)))
        text = text[:cut] + data.draw(st.text(max_size=3)) + text[cut:]
    try:
        g = gaitfile.loads(text, "fuzz.json")
    except GaitFileError:
        return
    g.joint_targets(0.1)  # whatever loads must be usable
    try:
        g.check_robot(QUAD)
    except GaitFileError:
        pass


_BASE_TOML = tomllib.loads((robots.robot.BUILTIN_DIR / "quad12" / "robot.toml").read_text())
toml_leaf = st.one_of(
    st.booleans(),
    st.integers(-5000, 5000),
    st.floats(allow_nan=True),
    st.text(max_size=8),
    st.lists(st.integers(-400, 400), max_size=3),
)


def _to_toml(node: dict) -> str:
    import tomli_w

    return tomli_w.dumps(node)


@settings(
    max_examples=_examples(120),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_fuzzed_robot_toml_raises_only_robot_config_error(
    tmp_path: Path, data: st.DataObject
) -> None:
    folder = tmp_path / "fuzzbot"
    if not folder.exists():
        shutil.copytree(robots.robot.BUILTIN_DIR / "quad12", folder)
    doc = copy.deepcopy(_BASE_TOML)
    for _ in range(data.draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        path = data.draw(st.sampled_from(paths))
        action = data.draw(st.sampled_from(["replace", "delete"]))
        value = data.draw(toml_leaf)
        if isinstance(value, float) and value != value and isinstance(path[-1], int):
            value = 0.0
        doc = _mutate(doc, path, action, value)
    try:
        text = _to_toml(doc)
    except (TypeError, ValueError):
        return
    (folder / "robot.toml").write_text(text)
    try:
        robots.load(folder)
    except RobotConfigError:
        pass


# ---------------------------------------------------------------------------------------------
# robot folders: hand-mangled TOML, servo catalogues and MJCF (issue #12)

_HELDQUAD = Path(__file__).parent / "fixtures" / "heldquad"
bad_number = st.sampled_from(
    ["nan", "inf", "-inf", "1e309", "-1e308", "1e308", "5e-324", "abc", "", "1 2", "0x10", "-0"]
)
toml_scalar = st.one_of(
    toml_leaf,
    st.integers(-(10**400), 10**400),
    st.floats(min_value=-1e308, max_value=1e308),
    st.sampled_from([1e308, 5e-324, -0.0, 1.0, "0.1", "1", [1.0], {"x": 1}]),
)


@settings(
    max_examples=_examples(150),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_fuzzed_user_robot_toml_with_servos_and_holds(tmp_path: Path, data: st.DataObject) -> None:
    folder = tmp_path / "heldquad"
    if not folder.exists():
        shutil.copytree(_HELDQUAD, folder)
    doc = tomllib.loads((_HELDQUAD / "robot.toml").read_text())
    for _ in range(data.draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        path = data.draw(st.sampled_from(paths))
        action = data.draw(st.sampled_from(["replace", "delete"]))
        value = data.draw(toml_scalar)
        doc = _mutate(doc, path, action, value)
    try:
        text = _to_toml(doc)
    except (TypeError, ValueError):
        return
    if data.draw(st.booleans()):  # deep nesting somewhere
        depth = data.draw(st.integers(5, 3000))
        text += f"\n[deep]\nx = {'[' * depth}{']' * depth}\n"
    (folder / "robot.toml").write_text(text)
    try:
        robots.load(folder)
    except RobotConfigError:
        pass


@settings(max_examples=_examples(100), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_fuzzed_servo_catalogue(data: st.DataObject) -> None:
    from robots.servo import parse_catalogue

    doc = tomllib.loads((robots.robot.BUILTIN_DIR / "servos.toml").read_text())
    for _ in range(data.draw(st.integers(1, 3))):
        name = data.draw(st.sampled_from(sorted(doc)))
        key = data.draw(st.sampled_from(sorted(doc[name])))
        doc[name][key] = data.draw(toml_scalar)
    try:
        text = _to_toml(doc)
    except (TypeError, ValueError):
        return
    try:
        parse_catalogue(text, "fuzz_servos.toml")
    except RobotConfigError:
        pass


def _mjcf_mutation(data: st.DataObject, xml: str) -> str:
    import re

    kind = data.draw(st.sampled_from(["number", "delete", "missing_file", "deep", "truncate"]))
    if kind == "number":
        attrs = list(re.finditer(r'(\w+)="([^"]*)"', xml))
        if not attrs:
            return xml
        m = data.draw(st.sampled_from(attrs))
        return xml[: m.start(2)] + data.draw(bad_number) + xml[m.end(2) :]
    if kind == "delete":
        lines = xml.split("\n")
        i = data.draw(st.integers(0, len(lines) - 1))
        return "\n".join(lines[:i] + lines[i + 1 :])
    if kind == "missing_file":
        which = data.draw(st.sampled_from(["head.obj", "parts/head.xml", "meshes"]))
        return xml.replace(which, "nowhere/" + which)
    if kind == "deep":
        depth = data.draw(st.integers(50, 5000))
        body = "".join(f'<body name="d{i}"><geom size="0.01"/>' for i in range(depth))
        return xml.replace("</worldbody>", body + "</body>" * depth + "</worldbody>")
    cut = data.draw(st.integers(0, len(xml)))
    return xml[:cut]


@settings(
    max_examples=_examples(150),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_fuzzed_mjcf_raises_only_robot_config_error(tmp_path: Path, data: st.DataObject) -> None:
    folder = tmp_path / "heldquad"
    if not folder.exists():
        shutil.copytree(_HELDQUAD, folder)
    xml = (_HELDQUAD / "robot.xml").read_text()
    for _ in range(data.draw(st.integers(1, 2))):
        xml = _mjcf_mutation(data, xml)
    (folder / "robot.xml").write_text(xml)
    try:
        r = robots.load(folder)
    except RobotConfigError:
        return
    assert 0 < r.mass_kg <= 1e4 and 0 < r.stance_base_height_m <= 100  # loads only when plausible

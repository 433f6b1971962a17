"""Calibration: tick↔radian conversions, limits, atomic persistence keyed by robot build."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import robots
from hardware.errors import CalibrationError, LimitError
from hardware.play.calibration import Calibration, default_path, load_or_default


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


def test_from_robot_matches_description(quad: robots.Robot) -> None:
    cal = Calibration.from_robot(quad)
    assert cal.joint_names == quad.joint_names
    assert cal.bus_ids == tuple(j.bus_id for j in quad.joints)
    ticks = cal.rad_to_ticks(quad.nominal_stance_rad)
    for j, q in zip(quad.joints, quad.nominal_stance_rad, strict=True):
        assert ticks[j.bus_id] == round(j.angle_to_ticks(q))
    back = cal.ticks_to_rad(ticks)
    tol = 0.5 / quad.joints[0].servo.ticks_per_rad  # half a tick
    assert all(abs(a - b) <= tol for a, b in zip(back, quad.nominal_stance_rad, strict=True))


def test_direction_and_offset(quad: robots.Robot) -> None:
    j = Calibration.from_robot(quad).joints[0]
    flipped = dataclasses.replace(j, direction=-j.direction, zero_offset_ticks=1000)
    q = 0.5 * j.upper_rad
    assert flipped.rad_to_ticks(q) == round(1000 - j.direction * q * j.ticks_per_rad)
    assert flipped.ticks_to_rad(flipped.rad_to_ticks(q)) == pytest.approx(q, abs=1e-3)


def test_limit_error_names_the_joint(quad: robots.Robot) -> None:
    cal = Calibration.from_robot(quad)
    bad = list(quad.nominal_stance_rad)
    j = cal.joints[4]
    bad[4] = j.upper_rad + 0.01
    with pytest.raises(LimitError, match=j.name) as info:
        cal.rad_to_ticks(bad)
    assert info.value.joint == j.name and info.value.upper_rad == j.upper_rad
    with pytest.raises(LimitError):
        j.rad_to_ticks(math.nan)


@given(st.floats(0.0, 1.0))
def test_round_trip_inside_limits(frac: float) -> None:
    cal = Calibration.from_robot(robots.load("hex18"))
    for j in cal.joints:
        q = min(j.upper_rad, j.lower_rad + frac * (j.upper_rad - j.lower_rad))
        assert j.ticks_to_rad(j.rad_to_ticks(q)) == pytest.approx(q, abs=0.51 / j.ticks_per_rad)


def test_save_load_atomic_and_keyed_by_fingerprint(quad: robots.Robot, tmp_path: Path) -> None:
    cal = Calibration.from_robot(quad).with_zero_offsets({quad.joint_names[0]: 2000})
    path = default_path(quad, tmp_path)
    assert quad.fingerprint in path.name
    cal.save(path)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temp file left behind
    assert Calibration.load(path, quad) == cal
    assert load_or_default(quad, tmp_path) == cal
    other = dataclasses.replace(quad, fingerprint="0" * 16)
    with pytest.raises(CalibrationError, match="recalibrate"):
        Calibration.load(path, other)
    assert load_or_default(other, tmp_path) == Calibration.from_robot(other)


@pytest.mark.parametrize(
    "text",
    ["not json", '{"schema": "x"}', '{"schema": "gaitsmith.calibration/1", "robot": "q"}'],
)
def test_malformed_files_raise_calibration_error(text: str, tmp_path: Path) -> None:
    path = tmp_path / "cal.json"
    path.write_text(text)
    with pytest.raises(CalibrationError):
        Calibration.load(path)
    with pytest.raises(CalibrationError):
        Calibration.load(tmp_path / "missing.json")

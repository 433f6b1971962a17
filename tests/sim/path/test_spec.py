"""Path specs: parsing, errors, and the geometry of the arc-length parametrised paths."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sim.path.errors import PathSpecError
from sim.path.spec import MAX_WAYPOINTS, catmull_rom, parse_path

LEG_M = 0.18


def test_circle_is_exact_and_starts_at_the_origin_heading_x() -> None:
    p = parse_path("circle:1.0", LEG_M)
    assert p.closed
    assert p.length_m == pytest.approx(2 * math.pi, rel=1e-5)
    assert np.allclose(p.point_at(0.0), 0.0)
    assert float(p.heading_at(0.0)) == pytest.approx(0.0, abs=1e-6)
    s = np.linspace(0, p.length_m, 50)
    assert np.allclose(np.hypot(*(p.point_at(s) - [0.0, 1.0]).T), 1.0, atol=1e-6)
    assert np.allclose(p.curvature_at(s), 1.0, atol=1e-3)
    # laps: arc length keeps counting
    assert np.allclose(p.point_at(p.length_m + 1.0), p.point_at(1.0))


def test_negative_radius_turns_right() -> None:
    p = parse_path("circle:-0.5", LEG_M)
    assert float(p.curvature_at(0.3)) == pytest.approx(-2.0, rel=1e-3)
    assert p.point_at(p.length_m / 2)[1] == pytest.approx(-1.0, abs=1e-5)


def test_figure8_has_two_lobes_with_a_continuous_heading() -> None:
    p = parse_path("figure8:0.75", LEG_M)
    assert p.length_m == pytest.approx(4 * math.pi * 0.75, rel=1e-5)
    half = p.length_m / 2
    assert np.allclose(p.point_at(half), 0.0, atol=1e-5)
    assert float(p.curvature_at(half / 2)) == pytest.approx(1 / 0.75, rel=1e-3)
    assert float(p.curvature_at(1.5 * half)) == pytest.approx(-1 / 0.75, rel=1e-3)
    h = p.heading_at(np.array([half - 0.01, half + 0.01]))
    assert abs(h[1] - h[0]) < 0.03  # 2 cm of arc at 1/0.75 m⁻¹ on each side


def test_spline_passes_through_the_waypoints_and_is_arc_length_parametrised() -> None:
    spec = "0,0;1,0;1.5,0.8;0.5,1.5;-0.5,1"
    p = parse_path(spec, LEG_M)
    assert not p.closed
    w = np.array([[0, 0], [1, 0], [1.5, 0.8], [0.5, 1.5], [-0.5, 1]], dtype=float)
    assert np.allclose(p.waypoints_m, w)
    assert np.allclose(p.point_at(p.waypoint_s_m), w, atol=1e-5)
    steps = np.linalg.norm(np.diff(p.points_m, axis=0), axis=1)
    assert np.allclose(steps, p.step_m, rtol=1e-3)  # equal arc-length samples
    chords = np.linalg.norm(np.diff(w, axis=0), axis=1)
    assert chords.sum() < p.length_m < 1.2 * chords.sum()


def test_collinear_waypoints_give_the_straight_line() -> None:
    p = parse_path("0,0;1,0;3,0", LEG_M)
    assert p.length_m == pytest.approx(3.0, rel=1e-9)
    assert np.allclose(p.points_m[:, 1], 0.0, atol=1e-12)
    assert np.allclose(p.point_at(1.7), [1.7, 0.0])
    # beyond the ends: along the end tangents (look-ahead goals)
    assert np.allclose(p.point_at(3.5), [3.5, 0.0])


def test_catmull_rom_points_on_a_circle_trace_it() -> None:
    a = np.linspace(0, 2 * math.pi, 12, endpoint=False)
    dense, index = catmull_rom(np.stack([np.cos(a), np.sin(a)], axis=1), closed=True)
    assert np.allclose(np.hypot(dense[:, 0], dense[:, 1]), 1.0, atol=5e-3)
    assert np.allclose(dense[index], np.stack([np.cos(a), np.sin(a)], axis=1))


def test_centripetal_spline_does_not_overshoot_a_sharp_corner() -> None:
    # uniform Catmull-Rom loops past the corner of an uneven polyline; centripetal stays close
    p = parse_path("0,0;2,0;2.1,0.1;2.1,2", LEG_M)
    assert p.points_m[:, 0].max() < 2.2
    assert p.points_m[:, 1].min() > -0.05


def test_last_waypoint_repeating_the_first_closes_the_path() -> None:
    p = parse_path("0,0;1,0;1,1;0,1;0,0", LEG_M)
    assert p.closed
    assert len(p.waypoints_m) == 4
    assert np.allclose(p.point_at(p.length_m), [0.0, 0.0], atol=1e-9)


def test_nearest_is_signed_left_positive() -> None:
    p = parse_path("0,0;2,0", LEG_M)
    s, e = p.nearest(np.array([0.7, 0.2]), 0.0, 2.0)
    assert s == pytest.approx(0.7) and e == pytest.approx(0.2)
    _, e = p.nearest(np.array([0.7, -0.3]), 0.0, 2.0)
    assert e == pytest.approx(-0.3)


def test_waypoint_files(tmp_path: Path) -> None:
    j = tmp_path / "w.json"
    j.write_text(json.dumps({"waypoints": [[0, 0], [1, 0], [2, 1]]}))
    c = tmp_path / "w.csv"
    c.write_text("x,y\n0,0\n1,0\n2,1\n")
    a, b = parse_path(str(j), LEG_M), parse_path(str(c), LEG_M)
    assert np.allclose(a.points_m, b.points_m)
    assert np.allclose(a.waypoints_m[-1], [2, 1])


@pytest.mark.parametrize("spec, match", [
    ("", "empty path"),
    ("circle:", "is not a number"),
    ("circle:abc", "is not a number"),
    ("circle:nan", "finite, non-zero"),
    ("circle:0.1", "below 0.36 m"),
    ("figure8:1e6", "beyond"),
    ("spiral:2", "unknown path kind 'spiral'"),
    ("0,0", "at least 2 distinct"),
    ("0,0;1", "waypoint 2 has 1 numbers"),
    ("0,0;1,x", "not two numbers"),
    ("0,0;1,0;1.01,0", "waypoints 2 and 3 are 0.01 m apart"),
    ("0,0;1,0;0,0", "3 for a closed loop"),
    ("0,0;1000,0", "from the origin"),
    ("missing.json", "cannot read the waypoint file"),
])
def test_bad_specs_are_one_line_errors_naming_the_option(spec: str, match: str) -> None:
    with pytest.raises(PathSpecError, match=match) as info:
        parse_path(spec, LEG_M)
    msg = str(info.value)
    assert msg.startswith("--path ") and "\n" not in msg and "circle:1.0" in msg


def test_too_many_waypoints_and_too_long(tmp_path: Path) -> None:
    pts = [[0.1 * k, 0.0] for k in range(MAX_WAYPOINTS + 5)]
    f = tmp_path / "many.json"
    f.write_text(json.dumps(pts))
    with pytest.raises(PathSpecError, match="at most 1000"):
        parse_path(str(f), LEG_M)
    zigzag = ";".join(f"{k},{100 * (k % 2)}" for k in range(12))  # ≈ 1.1 km
    with pytest.raises(PathSpecError, match="m long, at most 900 m"):
        parse_path(zigzag, LEG_M)


def test_bad_json_file(tmp_path: Path) -> None:
    f = tmp_path / "bad.json"
    f.write_text('{"waypoints": [[0, 0], [1, "a"]]}')
    with pytest.raises(PathSpecError, match=r"list of \[x, y\] pairs"):
        parse_path(str(f), LEG_M)
    f.write_text("{")
    with pytest.raises(PathSpecError, match="invalid JSON at line 1"):
        parse_path(str(f), LEG_M)

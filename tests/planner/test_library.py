"""planner.library: the default grid, BFS warm-start waves, phase alignment, build failures."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

import robots
from planner.library import (
    GridSpec,
    LibraryBuildError,
    align_phase,
    build_library,
    default_grid,
    foot_radius_m,
    max_yaw_rate_rad_s,
    stand_gait,
)
from planner.nlp.config import default_speed_m_s
from planner.nlp.cycle_start import rotate_schedule
from planner.templates import default_gait_for, make_schedule
from robots import Gait, Velocity
from tests.zoo.fixtures import ZOO


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


@pytest.mark.parametrize("where", ["quad12", "hex18", str(ZOO / "star5")])
def test_default_grid_follows_the_robot(where: str) -> None:
    r = robots.load(where)
    grid = default_grid(r)
    v = default_speed_m_s(r.leg_length_m)
    assert grid.vx_m_s == pytest.approx((-v / 2, 0.0, v / 2, v), abs=1e-4)
    assert grid.vy_m_s == (0.0,)
    w = grid.yaw_rate_rad_s[-1]
    assert grid.yaw_rate_rad_s == (-w, 0.0, w) and w > 0
    period = make_schedule(r, default_gait_for(r)).period_s
    # feet sweep at v/2 about the centre, unless the yaw bounds cap it
    assert w == pytest.approx(min(0.5 * v / foot_radius_m(r), max_yaw_rate_rad_s(r, period)),
                              abs=1e-3)
    assert w <= 0.5 * math.sqrt(9.81 / r.leg_length_m)


def test_grid_checks_and_waves() -> None:
    with pytest.raises(LibraryBuildError, match="vx_m_s: repeats"):
        GridSpec((0.1, 0.1))
    with pytest.raises(LibraryBuildError, match="yaw_rate_rad_s: needs at least one finite"):
        GridSpec((0.1,), (0.0,), (math.nan,))
    grid = GridSpec((0.2, -0.1, 0.0, 0.1), (0.0,), (0.5, 0.0, -0.5))
    assert grid.vx_m_s == (-0.1, 0.0, 0.1, 0.2)  # sorted
    waves = grid.waves()
    assert waves[0] == [(1, 0, 1)]  # the command nearest zero first, cold
    assert sorted(waves[1]) == [(0, 0, 1), (1, 0, 0), (1, 0, 2), (2, 0, 1)]
    assert sum(len(w) for w in waves) == grid.size == 12
    for d, wave in enumerate(waves):  # every later node has a neighbour in the previous wave
        for n in wave:
            assert sum(abs(a - b) for a, b in zip(n, (1, 0, 1), strict=True)) == d


def test_align_phase_undoes_the_rest_like_start(quad: robots.Robot) -> None:
    template = make_schedule(quad, "trot")
    n, k = 20, 7
    phase = np.arange(n) / n
    knots = np.asarray(quad.nominal_stance_rad) + 0.1 * np.sin(2 * np.pi * phase)[:, None]
    original = Gait.create(robot=quad, knots_rad=knots, schedule=template,
                           velocity=Velocity(0.1), gait_label="trot")
    rotated = Gait.create(robot=quad, knots_rad=np.roll(knots, -k, axis=0),
                          schedule=rotate_schedule(template, k, n), velocity=Velocity(0.1),
                          gait_label="trot")
    back = align_phase(rotated, template, quad)
    assert back.schedule == original.schedule
    np.testing.assert_allclose(back.joint_angles_rad, original.joint_angles_rad, atol=1e-12)
    assert "phase_origin" in back.planner
    assert align_phase(original, template, quad) is original
    pace = make_schedule(quad, "pace")
    assert pace.touchdown_phase != template.touchdown_phase
    with pytest.raises(LibraryBuildError, match="does not follow the trot template"):
        align_phase(original, pace, quad)


@dataclass(frozen=True)
class FakeValidator:
    """Picklable validator factory: passes the commands in `good` with the command achieved."""

    good: tuple[tuple[float, float, float], ...]

    def __call__(self) -> Any:
        def check(gait: Gait) -> dict[str, Any]:
            c = gait.velocity
            key = (c.vx_m_s, c.vy_m_s, c.yaw_rate_rad_s)
            ok = gait.gait_label == "stand" or key in self.good
            return {"passed": ok, "reasons": [] if ok else ["speed: made up for the test"],
                    "metrics": {"achieved_vx_m_s": c.vx_m_s, "achieved_vy_m_s": c.vy_m_s,
                                "achieved_yaw_rate_rad_s": c.yaw_rate_rad_s}}
        return check


def test_a_failed_stand_stops_the_build_before_any_solve(quad: robots.Robot) -> None:
    def failing(gait: Gait) -> dict[str, Any]:
        return {"passed": False, "reasons": ["no fall: fell at t = 0.3 s"]}

    with pytest.raises(LibraryBuildError, match=r"quad12: the stand failed in MuJoCo \(no fall"):
        build_library(quad, GridSpec((0.25,)), validator=FakeValidator(()),
                      stand_validator=failing, executor="serial")


def test_stand_is_the_nominal_stance(quad: robots.Robot) -> None:
    s = stand_gait(quad, 0.5)
    assert s.velocity == Velocity() and set(s.schedule.duty_factor) == {1.0}
    np.testing.assert_allclose(s.knots_rad, np.tile(quad.nominal_stance_rad, (8, 1)))


@pytest.mark.slow
def test_failed_entries_are_reported_and_left_out(quad: robots.Robot) -> None:
    grid = GridSpec((0.2, 0.25))
    seen: list[tuple[int, int, bool, str]] = []
    build = build_library(
        quad, grid, n_knots=12, validator=FakeValidator(((0.25, 0.0, 0.0),)),
        executor="serial", min_entries=1,
        on_entry=lambda i, n, o: seen.append((i, n, o.passed, o.reason)))
    lib = build.library
    assert [e.command for e in lib.entries] == [Velocity(0.25)]
    assert [s[:3] for s in seen] == [(1, 2, False), (2, 2, True)]  # 0.2 is nearer zero: first
    assert "made up for the test" in seen[0][3]
    assert lib.built["failures"] == [
        {"command": {"vx_m_s": 0.2, "vy_m_s": 0.0, "yaw_rate_rad_s": 0.0},
         "reason": "MuJoCo: speed: made up for the test"}]
    entries = lib.built["entries"]
    assert [e["warm_started"] for e in entries] == [False, True]  # neighbour warm start
    assert lib.entries[0].gait.schedule == make_schedule(quad, "trot").with_period(
        lib.entries[0].gait.period_s)  # the template's phase origin
    with pytest.raises(LibraryBuildError, match=r"only 0 of 2 grid entries passed MuJoCo "
                       r"\(need 2\); no library written. Failed \(first reason each\): "
                       r"\(0.2, 0.0, 0.0\): MuJoCo: speed: made up"):
        build_library(quad, grid, n_knots=12, validator=FakeValidator(()), executor="serial",
                      warm_start=False)  # the cold path: one batch, same order


def test_default_grid_caps_the_yaw_rate_at_the_given_period(quad: robots.Robot) -> None:
    trot = default_grid(quad)
    long_period_s = 2.0 * make_schedule(quad, "trot").period_s
    slow = default_grid(quad, "walk", long_period_s)
    assert slow.vx_m_s == trot.vx_m_s  # the speeds follow the leg length only
    w = max(slow.yaw_rate_rad_s)
    assert w == pytest.approx(max_yaw_rate_rad_s(quad, long_period_s), abs=1e-3)
    assert w < max(trot.yaw_rate_rad_s)

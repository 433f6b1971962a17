"""Pure pursuit on an ideal unicycle (exact kinematics): the controller's own error, apart from
any robot's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots.gait import Velocity
from sim.errors import SimConfigError
from sim.path.pursuit import PurePursuit, PursuitSettings, wrap_angle
from sim.path.spec import parse_path

LEG_M = 0.18
BOX = (Velocity(0.0, 0.0, -0.6), Velocity(0.2, 0.0, 0.6))


def drive_unicycle(ctrl: PurePursuit, pose: tuple[float, float, float], dt_s: float = 0.01,
                   t_max_s: float = 400.0) -> tuple[np.ndarray, list[float], float]:
    """Integrate x' = vx cosψ − vy sinψ, y' = vx sinψ + vy cosψ, ψ' = ω exactly (arcs)."""
    x, y, yaw = pose
    log, errors = [], []
    t = 0.0
    while t < t_max_s:
        st = ctrl.step(x, y, yaw)
        errors.append(st.cross_track_m)
        if st.finished:
            break
        c = st.command
        w = c.yaw_rate_rad_s
        if abs(w) > 1e-12:  # exact arc of the body-frame velocity over dt
            dyaw = w * dt_s
            sx = (math.sin(yaw + dyaw) - math.sin(yaw)) / w
            cx = (math.cos(yaw) - math.cos(yaw + dyaw)) / w
            x += c.vx_m_s * sx - c.vy_m_s * cx
            y += c.vx_m_s * cx + c.vy_m_s * sx
            yaw += dyaw
        else:
            x += dt_s * (c.vx_m_s * math.cos(yaw) - c.vy_m_s * math.sin(yaw))
            y += dt_s * (c.vx_m_s * math.sin(yaw) + c.vy_m_s * math.cos(yaw))
        log.append((x, y, yaw))
        t += dt_s
    return np.array(log), errors, t


def test_holds_a_circle_with_no_steady_error_and_stops_at_the_end() -> None:
    path = parse_path("circle:1.0", LEG_M)
    ctrl = PurePursuit(path, BOX, LEG_M, laps=2)
    log, errors, t = drive_unicycle(ctrl, (0.0, 0.0, 0.0))
    assert ctrl.finished
    # steady state: on the circle to well under a millimetre (the sampled path's own chord error)
    steady = np.abs(errors[len(errors) // 4: -len(errors) // 10])
    assert steady.max() < 1e-3
    radius = np.hypot(log[:, 0], log[:, 1] - 1.0)
    assert np.abs(radius[len(radius) // 4:] - 1.0).max() < 2e-3
    # two laps at the cruise speed (0.2 m/s), plus braking at the end: 4π / 0.2 ≈ 63 s
    assert 4 * math.pi / 0.2 < t < 4 * math.pi / 0.2 + 10.0
    end = log[-1, :2]
    assert np.linalg.norm(end) < 0.25 * LEG_M + 0.02


def test_converges_from_an_offset_start() -> None:
    path = parse_path("circle:-1.5", LEG_M)
    ctrl = PurePursuit(path, BOX, LEG_M)
    _, errors, _ = drive_unicycle(ctrl, (0.0, 0.3, 0.4))
    assert abs(errors[0]) > 0.25
    assert np.abs(errors[len(errors) // 2:]).max() < 5e-3


def test_figure8_error_stays_small_where_the_curvature_flips() -> None:
    path = parse_path("figure8:0.75", LEG_M)
    ctrl = PurePursuit(path, BOX, LEG_M)
    _, errors, _ = drive_unicycle(ctrl, (0.0, 0.0, 0.0))
    assert ctrl.finished
    # measured (look-ahead 0.4 m = 2 s at 0.2 m/s): mean 0.35 cm, max 4.4 cm (where the goal
    # point runs ahead into the other lobe)
    assert np.abs(errors).mean() < 0.005
    assert np.abs(errors).max() < 0.05


def test_slows_in_a_curve_tighter_than_its_yaw_rate_allows() -> None:
    box = (Velocity(0.0, 0.0, -0.3), Velocity(0.2, 0.0, 0.3))
    path = parse_path("figure8:0.5", LEG_M)
    ctrl = PurePursuit(path, box, LEG_M)
    speeds = []
    x, y, yaw = 0.0, 0.0, 0.0
    for _ in range(3000):
        st = ctrl.step(x, y, yaw)
        c = st.command
        assert box[0].yaw_rate_rad_s <= c.yaw_rate_rad_s <= box[1].yaw_rate_rad_s
        speeds.append(c.vx_m_s)
        x += 0.01 * c.vx_m_s * math.cos(yaw)
        y += 0.01 * c.vx_m_s * math.sin(yaw)
        yaw += 0.01 * c.yaw_rate_rad_s
    # the curve limit: 0.8 · 0.3 rad/s / (1/0.5 m) = 0.12 m/s
    assert max(speeds[500:]) <= 0.8 * 0.3 * 0.5 + 1e-6


def test_uses_side_steps_when_the_box_has_them() -> None:
    box = (Velocity(0.0, -0.05, -0.6), Velocity(0.2, 0.05, 0.6))
    path = parse_path("0,0;2,0;4,0", LEG_M)
    ctrl = PurePursuit(path, box, LEG_M)
    st = ctrl.step(0.5, 0.1, 0.0)  # left of a straight path
    assert st.cross_track_m == pytest.approx(0.1, abs=1e-6)
    assert -0.05 <= st.command.vy_m_s < 0.0
    assert st.command.yaw_rate_rad_s < 0.0


def test_open_path_brakes_to_a_stop_at_its_end() -> None:
    path = parse_path("0,0;1,0.5;2,0", LEG_M)
    ctrl = PurePursuit(path, BOX, LEG_M)
    log, errors, _ = drive_unicycle(ctrl, (0.0, 0.0, float(path.heading_at(0.0))))
    assert ctrl.finished
    assert np.abs(errors).mean() < 0.02
    # it stops within the goal tolerance along the path; pure pursuit cuts the final bend
    # (its goal runs on along the end tangent) by a few centimetres
    assert np.linalg.norm(log[-1, :2] - np.array([2.0, 0.0])) < 0.25 * LEG_M + 0.05


def test_goal_behind_turns_in_place() -> None:
    path = parse_path("circle:1.0", LEG_M)
    ctrl = PurePursuit(path, BOX, LEG_M)
    st = ctrl.step(0.0, 0.0, math.pi)  # facing backwards on the path
    assert st.command.vx_m_s == 0.0 and st.command.yaw_rate_rad_s != 0.0
    assert abs(float(wrap_angle(st.heading_error_rad))) == pytest.approx(math.pi, abs=1e-2)


@pytest.mark.parametrize("bounds, laps, spec, match", [
    ((Velocity(0, 0, -0.5), Velocity(0.0, 0, 0.5)), 1, "circle:1", "no forward speed"),
    ((Velocity(0, 0, 0.0), Velocity(0.2, 0, 0.5)), 1, "circle:1", "no turning both ways"),
    (BOX, 2, "0,0;1,0", "open path"),
])
def test_refuses_a_box_or_laps_it_cannot_follow(bounds: tuple[Velocity, Velocity], laps: int,
                                                spec: str, match: str) -> None:
    with pytest.raises(SimConfigError, match=match):
        PurePursuit(parse_path(spec, LEG_M), bounds, LEG_M, laps=laps)


def test_settings_are_checked() -> None:
    with pytest.raises(SimConfigError, match="lookahead"):
        PursuitSettings(lookahead_leg_lengths=0.0)

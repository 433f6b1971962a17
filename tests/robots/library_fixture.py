"""A synthetic gait library (no planner, no MuJoCo) for tests of `robots.library` / `robots.blend`
and of the code that drives with a library (sim.path, hardware.play.drive).

Every entry's knots are linear in its command c = (vx, vy, yaw rate):

    q(φ) = stance + A·sin 2πφ + (vx·B + vy·C + w·D)·cos 2πφ + vx·E,

so multilinear blending at equal phase reproduces the same formula exactly at any command in
the box (`expected_targets`). The period follows vx (`period_s_for`), to exercise the period law.
"""

from __future__ import annotations

import numpy as np

from robots import ContactSchedule, Gait, Robot, Velocity
from robots.library import GaitLibrary, LibraryEntry

N_KNOTS = 24
VX = (0.0, 0.1, 0.2)
VY = (0.0,)
YAW = (-0.5, 0.0, 0.5)


def period_s_for(vx_m_s: float) -> float:
    return 0.5 + 0.5 * vx_m_s


def _coefficients(n_joints: int) -> tuple[np.ndarray, ...]:
    j = np.arange(n_joints)
    return (
        0.08 * np.ones(n_joints),  # A
        0.3 * np.cos(j),  # B per (m/s)
        0.2 * np.sin(j),  # C per (m/s)
        0.05 * np.cos(2 * j),  # D per (rad/s)
        0.1 * np.sin(3 * j + 1),  # E per (m/s)
    )


def expected_targets(robot: Robot, c: Velocity, phase: float | np.ndarray) -> np.ndarray:
    """The formula above at `phase` ((J,) or (K, J)); exact knots of the fixture's gaits."""
    a, b, cc, d, e = _coefficients(robot.dof)
    ph = np.asarray(phase, dtype=float)[..., None]
    stance = np.asarray(robot.nominal_stance_rad)
    amp = c.vx_m_s * b + c.vy_m_s * cc + c.yaw_rate_rad_s * d
    return np.asarray(
        stance + a * np.sin(2 * np.pi * ph) + amp * np.cos(2 * np.pi * ph) + c.vx_m_s * e
    )


def _schedule(robot: Robot, period_s: float, walking: bool) -> ContactSchedule:
    n = len(robot.legs)
    if not walking:
        return ContactSchedule(period_s, robot.foot_names, (0.0,) * n, (1.0,) * n)
    return ContactSchedule(
        period_s, robot.foot_names, tuple(0.5 * (i % 2) for i in range(n)), (0.6,) * n
    )


def make_entry(robot: Robot, c: Velocity, n_knots: int = N_KNOTS) -> LibraryEntry:
    knots = expected_targets(robot, c, np.arange(n_knots) / n_knots)
    gait = Gait.create(
        robot=robot, knots_rad=knots, schedule=_schedule(robot, period_s_for(c.vx_m_s), True),
        velocity=c, gait_label="trot",
    )
    metrics = {"achieved_vx_m_s": c.vx_m_s, "achieved_vy_m_s": c.vy_m_s,
               "achieved_yaw_rate_rad_s": c.yaw_rate_rad_s}
    return LibraryEntry(c, gait.with_validation({"passed": True, "metrics": metrics}), c)


def make_stand(robot: Robot) -> Gait:
    knots = np.tile(np.asarray(robot.nominal_stance_rad), (8, 1))
    gait = Gait.create(robot=robot, knots_rad=knots, schedule=_schedule(robot, 0.5, False),
                       velocity=Velocity(), gait_label="stand")
    return gait.with_validation({"passed": True, "metrics": {}})


def make_library(
    robot: Robot,
    vx: tuple[float, ...] = VX,
    vy: tuple[float, ...] = VY,
    yaw: tuple[float, ...] = YAW,
    skip: tuple[Velocity, ...] = (),
    n_knots: int = N_KNOTS,
) -> GaitLibrary:
    entries = tuple(
        make_entry(robot, Velocity(x, y, w), n_knots)
        for x in vx for y in vy for w in yaw if Velocity(x, y, w) not in skip
    )
    return GaitLibrary(
        robot=robot.name, robot_fingerprint=robot.fingerprint, joint_names=robot.joint_names,
        family="trot", stand=make_stand(robot), entries=entries,
        built={"synthetic": True, "failures": []},
    )

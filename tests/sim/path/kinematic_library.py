"""A small gait library of kinematic gaits (no planner) that really walk in MuJoCo, for the
drive-sim tests: each stance foot moves in the body frame as the ground does under a body moving
at the command (vx, vy, ω) — velocity −(v + ω × p) at its home position p — and each swing foot
returns on a half-sine arc (`sim.synthetic`'s IK). The hexapod's tripod keeps three feet down,
so these walk without planning (the `hex_tripod` fixture of tests/sim walks at 0.1 m/s)."""

from __future__ import annotations

import itertools

import numpy as np

from robots.gait import Gait, Velocity
from robots.library import GaitLibrary, LibraryEntry
from robots.robot import Robot
from robots.schedule import ContactSchedule
from sim.synthetic import _LegIK, standing_gait, trot_schedule


def kinematic_velocity_gait(robot: Robot, schedule: ContactSchedule, c: Velocity, *,
                            lift_m: float = 0.03, n_knots: int = 24) -> Gait:
    ik = _LegIK(robot)
    q0 = np.asarray(robot.nominal_stance_rad, dtype=float)
    home = ik.feet(q0)
    period = schedule.period_s
    knots = np.empty((n_knots, robot.dof))
    q = q0.copy()
    for k, s in enumerate(np.arange(n_knots) / n_knots):
        targets = home.copy()
        for f in range(schedule.n_feet):
            duty = schedule.duty_factor[f]
            u = (s - schedule.touchdown_phase[f]) % 1.0
            px, py = home[f, 0], home[f, 1]
            ground = np.array([-(c.vx_m_s - c.yaw_rate_rad_s * py),
                               -(c.vy_m_s + c.yaw_rate_rad_s * px)])
            stroke = ground * period * duty  # stance displacement, front to back
            if u < duty:
                frac = u / duty - 0.5
            else:
                v = (u - duty) / (1.0 - duty)
                frac = 0.5 - (3 * v**2 - 2 * v**3)
                targets[f, 2] += lift_m * np.sin(np.pi * v)
            targets[f, :2] += stroke * frac
        q = ik.solve(targets, q)
        knots[k] = q
    return Gait.create(robot=robot, knots_rad=knots, schedule=schedule, velocity=c,
                       gait_label="tripod", planner={"generator": "kinematic_velocity_gait"})


def kinematic_library(robot: Robot, vx: tuple[float, ...], yaw: tuple[float, ...],
                      period_s: float = 0.5, duty: float = 0.6) -> GaitLibrary:
    schedule = trot_schedule(robot, period_s, duty)
    entries = []
    for x, w in itertools.product(vx, yaw):
        c = Velocity(x, 0.0, w)
        g = kinematic_velocity_gait(robot, schedule, c)
        entries.append(LibraryEntry(c, g.with_validation({"passed": True, "metrics": {}}), c))
    stand = standing_gait(robot)
    return GaitLibrary(robot=robot.name, robot_fingerprint=robot.fingerprint,
                       joint_names=robot.joint_names, family="tripod",
                       stand=stand.with_validation({"passed": True, "metrics": {}}),
                       entries=tuple(entries), built={"kinematic": True, "failures": []})

"""The servo's position loop inside the planner: plan the motion, output the servo *goals*.

A hobby/smart servo is not a position source. Its firmware runs a proportional position loop whose
torque at the output shaft is (gains: `robots.servo.factory_gains`; model: `sim.servo`)::

    τ = kp·(goal − q) − kd·q̇ − b·q̇          (unsaturated: |kp·(goal − q) − kd·q̇| < τ_stall)

with kp = duty_per_rad·τ_stall (factory P gain), kd the D gain (0 on STS/XL430 factory settings)
and b = τ_stall/ω₀ the back-EMF slope of the DC motor. On the quad12's STS3215 kp ≈ 10.2 N·m/rad:
full duty at 10.8° of error. Streaming the planned angles as goals therefore gets the planned
angles minus a quasi-static sag τ/kp (≈ 4° at a loaded knee) minus a velocity lag (b + kd)·q̇/kp
(≈ 7° at 3 rad/s) — measured on quad12 trot: body ≈ 1 cm low, hind feet dragging through ≈ 45 %
of their swing, 0.151 of 0.25 m/s.

The planner already knows τ(t) (inverse dynamics of the planned motion, including armature and
the MJCF joint damping) and q̇(t), so it inverts the loop exactly::

    goal_k = q_k + (τ_k + (kd + b)·q̇_k) / kp                                 (per joint, per knot)

and the gait file carries these goals as its joint samples (see `planner.nlp.metadata`: the file
says
``joint_angles = "servo_goal"`` and keeps the achieved angles next to them). What this models:
the linear, unsaturated loop — exact inside the planner's torque envelope, since
|τ| ≤ m·τ_stall(1 − |q̇|/ω₀) with m ≤ 1 gives |τ + b·q̇| ≤ τ_stall. What it simplifies: the
player's zero-order hold (half a 100 Hz tick, ≈ 5 ms of lag) and the periodic cubic spline
between knots; gear backlash and friction are not in `sim` either.

Identified servos (`robots.servo_params`, `gaitsmith plan --servo-params FILE`, through
`PlannerOptions.servo_settings`): kp, kd and b follow each joint's fitted gain scale and strength
(`servo_loops`), and since such a servo acts on a goal `latency` after it was sent, the goals
are streamed that much earlier: goal'(t) = goal(t + latency), evaluated on the same periodic
cubic spline the player samples (`advance_by_latency`).

Goals are constrained like angles (inside the joint limits — the player clips to them — and
moving no faster than the player's step limit, margin·ω₀), in `planner.nlp.constraints`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robots import Robot
from robots.servo import factory_gains
from robots.servo_params import ServoSetting
from robots.spline import PeriodicSpline


@dataclass(frozen=True)
class ServoLoop:
    """Linear position loop of one joint's servo: τ = kp·(goal − q) − damping·q̇."""

    kp_nm_per_rad: float
    damping_nm_s_per_rad: float  # D gain + back-EMF slope (not the MJCF joint damping)
    latency_s: float = 0.0  # the goal acts this long after it was sent (identified servos)


def factory_servo_loops(robot: Robot) -> tuple[ServoLoop, ...]:
    """Each joint's servo at its factory gains (`robots.servo.factory_gains`, the same source
    `sim` builds its actuators from), in `Robot.joints` order."""
    return servo_loops(robot)


def servo_loops(
    robot: Robot, settings: tuple[ServoSetting, ...] | None = None
) -> tuple[ServoLoop, ...]:
    """Each joint's servo loop: factory gains, scaled by the identified `settings` (one per
    joint, `robots.servo_params`) when given — the same law `sim.model.servos_for` builds."""
    loops = []
    for n, joint in enumerate(robot.joints):
        servo = joint.servo
        st = settings[n] if settings is not None else ServoSetting()
        duty_p, duty_d = factory_gains(servo)
        drive = st.strength * servo.stall_torque_nm
        loops.append(
            ServoLoop(
                kp_nm_per_rad=st.gain_scale * duty_p * drive,
                damping_nm_s_per_rad=st.gain_scale * duty_d * drive
                + drive / servo.no_load_speed_rad_s,
                latency_s=st.latency_s,
            )
        )
    return tuple(loops)


def advance_by_latency(
    goals_rad: np.ndarray, period_s: float, loops: tuple[ServoLoop, ...]
) -> np.ndarray:
    """N × J periodic goals sent `latency_s` early per joint: row k becomes the goal at
    t_k + latency on the periodic cubic spline through the rows (unchanged without latency)."""
    goals = np.asarray(goals_rad, dtype=float)
    lat = np.array([s.latency_s for s in loops])
    if not np.any(lat > 0):
        return goals
    n = goals.shape[0]
    spline = PeriodicSpline(goals)
    out = goals.copy()
    for j in np.flatnonzero(lat > 0):
        phase = (np.arange(n) / n + lat[j] / period_s) % 1.0
        out[:, j] = np.asarray(spline(phase))[:, j]
    return out


def loop_arrays(loops: tuple[ServoLoop, ...]) -> tuple[np.ndarray, np.ndarray]:
    """(kp [N·m/rad], damping [N·m·s/rad]) per joint."""
    return (
        np.array([s.kp_nm_per_rad for s in loops], dtype=float),
        np.array([s.damping_nm_s_per_rad for s in loops], dtype=float),
    )


def servo_goals_rad(
    q_rad: np.ndarray, qd_rad_s: np.ndarray, tau_nm: np.ndarray, loops: tuple[ServoLoop, ...]
) -> np.ndarray:
    """N × J goals that make the servos produce `tau_nm` at the planned `q_rad`, `qd_rad_s`."""
    kp, damping = loop_arrays(loops)
    return np.asarray(q_rad) + (np.asarray(tau_nm) + damping * np.asarray(qd_rad_s)) / kp

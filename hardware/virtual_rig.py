"""A virtual robot on a `VirtualServoBus`: the robot's servos, placed at a chosen pose.

`VirtualServoBus.from_robot` starts every servo at the robot's nominal stance. `virtual_robot_bus`
places each servo at the ticks of a given joint pose [rad] (default: the robot's stance, slumped
by `slump_rad` on every joint towards the middle of its range, so the player has a real ramp-in
to do).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from hardware.virtual.bus import VirtualServoBus
from hardware.virtual.faults import NO_FAULTS, FaultPlan
from hardware.virtual.servo import VirtualServo
from robots.robot import Robot


def slumped_pose_rad(robot: Robot, slump_rad: float = 0.15) -> np.ndarray:
    """Stance moved by up to `slump_rad` per joint towards the middle of its limits."""
    stance = np.asarray(robot.nominal_stance_rad, float)
    mid = np.array([(j.lower_rad + j.upper_rad) / 2 for j in robot.joints])
    step = np.clip(mid - stance, -slump_rad, slump_rad)
    return stance + step


def place_servos(
    vbus: VirtualServoBus, robot: Robot, pose_rad: Sequence[float] | np.ndarray
) -> None:
    """Re-create the bus's servos at the ticks of `pose_rad` (robot's mounting: offset, sign)."""
    pose = np.asarray(pose_rad, float).reshape(-1)
    if pose.shape != (len(robot.joints),):
        raise ValueError(f"expected {len(robot.joints)} joint angles, got {pose.size}")
    now = vbus.clock()
    by_id = {j.bus_id: (j, q) for j, q in zip(robot.joints, pose, strict=True)}
    servos = []
    for s in vbus.servos:
        if s.servo_id in by_id:
            j, q = by_id[s.servo_id]
            tick = round(j.angle_to_ticks(float(q)))
            servos.append(VirtualServo(s.servo_id, s.model, s.table, now, position_tick=tick))
        else:
            servos.append(s)
    vbus.servos = servos


def virtual_robot_bus(
    robot: Robot,
    pose_rad: Sequence[float] | np.ndarray | None = None,
    clock: Callable[[], float] | None = None,
    faults: FaultPlan = NO_FAULTS,
) -> VirtualServoBus:
    """The robot's servos on a virtual bus, placed at `pose_rad` (default: slumped stance)."""
    kwargs: dict[str, Any] = {"faults": faults}
    if clock is not None:
        kwargs["clock"] = clock
    vbus = VirtualServoBus.from_robot(robot, **kwargs)
    place_servos(vbus, robot, slumped_pose_rad(robot) if pose_rad is None else pose_rad)
    return vbus


def bringup_gait(
    robot: Robot,
    amplitude_rad: float = 0.15,
    period_s: float = 0.8,
    n_knots: int = 40,
    vx_m_s: float = 0.0,
) -> Any:
    """A gentle stepping-in-place gait for bring-up and tests (not planned, not validated):
    each joint swings sinusoidally about stance, legs phased like a trot / tripod (alternate
    legs half a period apart), amplitudes kept `amplitude_rad` inside the joint limits."""
    from robots.gait import Gait, Velocity
    from robots.schedule import ContactSchedule

    stance = np.asarray(robot.nominal_stance_rad, float)
    lo = np.array([j.lower_rad for j in robot.joints]) + 0.05
    hi = np.array([j.upper_rad for j in robot.joints]) - 0.05
    leg_phase = {}
    for n, leg in enumerate(robot.legs):
        for name in leg.joints:
            leg_phase[name] = 0.5 * (n % 2 if len(robot.legs) != 4 else (n in (1, 2)))
    phase = np.arange(n_knots) / n_knots
    knots = np.empty((n_knots, len(robot.joints)))
    for j, joint in enumerate(robot.joints):
        shift = leg_phase.get(joint.name, 0.0)
        swing = 0.0 if joint.role == "hold" else amplitude_rad  # held joints stay at stance
        knots[:, j] = stance[j] + swing * np.sin(2 * np.pi * (phase - shift))
    knots = np.clip(knots, lo, hi)
    touchdown = tuple(float(leg_phase[leg.joints[0]]) for leg in robot.legs)
    schedule = ContactSchedule(period_s, robot.foot_names, touchdown, (0.6,) * len(robot.legs))
    return Gait.create(
        robot=robot,
        knots_rad=knots,
        schedule=schedule,
        velocity=Velocity(vx_m_s),
        gait_label="bringup",
    )

"""Interactive zero-offset calibration: torque off, pose the robot, press Enter, read, save.

Reference pose: the robot's nominal stance (`stance_deg` in robot.toml, printed joint by joint),
set with a jig or by eye with the body level on a flat surface. For each joint the new zero
offset is the tick at which the joint reads 0 rad:

    zero_offset_ticks = present_ticks − direction · stance_rad · ticks_per_rad

The flow is a plain function of injected `ask` / `say` callables, so tests feed it input.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hardware.bus.servo_bus import ServoBus
from hardware.errors import BusError
from hardware.play.calibration import Calibration
from hardware.play.errors import PlayerError
from robots.robot import Robot

SUSPICIOUS_SHIFT_RAD = np.pi / 4  # an offset this far from nominal is probably a mis-mounted horn


@dataclass(frozen=True)
class CalibrationOutcome:
    calibration: Calibration
    shifts_rad: dict[str, float]  # new − nominal zero, per joint [rad]
    warnings: tuple[str, ...]


def reference_pose_lines(robot: Robot) -> list[str]:
    return [
        f"  {j.name:<16} servo {j.bus_id:>3}  {np.degrees(j.stance_rad):7.1f}°"
        for j in robot.joints
    ]


def record_zero_offsets(
    robot: Robot, bus: ServoBus, ask: Callable[[str], str], say: Callable[[str], None]
) -> CalibrationOutcome:
    """Run the flow on an open bus; returns the new calibration (not yet saved)."""
    ids = [j.bus_id for j in robot.joints]
    for j in robot.joints:
        try:
            info = bus.ping(j.bus_id, retries=2)
        except BusError as exc:
            raise PlayerError(
                f"servo {j.bus_id} ({j.name}): does not answer ping ({exc})"
            ) from None
        if info.model_number != j.servo.model_number:
            raise PlayerError(
                f"servo {j.bus_id} ({j.name}): model number {info.model_number}, "
                f"expected {j.servo.model_number} ({j.servo.name})"
            )
    try:
        bus.torque_off(ids)
    except BusError as exc:
        raise PlayerError(f"cannot switch torque off: {exc}") from None
    say("Torque is OFF. Pose the robot in its reference pose (nominal stance):")
    for line in reference_pose_lines(robot):
        say(line)
    answer = ask("Press Enter when the robot is in the reference pose (q to abort)")
    if answer.strip().lower() in ("q", "quit", "abort"):
        raise PlayerError("calibration aborted by the user; nothing saved")
    try:
        present = bus.sync_read_positions(ids)
    except BusError as exc:
        raise PlayerError(f"cannot read present positions: {exc}") from None
    nominal = Calibration.from_robot(robot)
    offsets: dict[str, int] = {}
    shifts: dict[str, float] = {}
    warnings: list[str] = []
    for j in robot.joints:
        zero = round(present[j.bus_id] - j.direction * j.stance_rad * j.servo.ticks_per_rad)
        if not j.servo.position_min_tick <= zero <= j.servo.position_max_tick:
            raise PlayerError(
                f"joint {j.name} (servo {j.bus_id}): zero offset {zero} ticks outside the servo's "
                f"range [{j.servo.position_min_tick}, {j.servo.position_max_tick}]; "
                "re-mount the horn"
            )
        offsets[j.name] = zero
        shifts[j.name] = (zero - j.zero_offset_ticks) / j.servo.ticks_per_rad
        if abs(shifts[j.name]) > SUSPICIOUS_SHIFT_RAD:
            warnings.append(
                f"joint {j.name}: zero moved {np.degrees(shifts[j.name]):.0f}° from nominal "
                "(horn mounted off by a spline?)"
            )
    return CalibrationOutcome(nominal.with_zero_offsets(offsets), shifts, tuple(warnings))

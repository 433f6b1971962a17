"""Shared helpers of the player tests (no tests here): a virtual rig with a wire recorder."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import robots
from hardware.bus.servo_bus import BusConfig, ServoBus
from hardware.bus.virtual import VirtualServoBus
from hardware.bus.wire_log import WireRecorder
from hardware.play.clock import VirtualClock
from hardware.play.player import Player, PlayerConfig, PlayResult
from hardware.play.telemetry import Telemetry, TelemetryWriter, read_telemetry
from hardware.play.virtual_rig import bringup_gait, slumped_pose_rad, virtual_robot_bus
from robots.gait import Gait
from robots.robot import Robot

FAST_BUS = BusConfig(timeout_s=0.001, retries=1)


@dataclass
class Rig:
    robot: Robot
    gait: Gait
    clock: VirtualClock
    vbus: VirtualServoBus
    bus: ServoBus
    wire: WireRecorder
    start_ticks: np.ndarray  # servo positions before the run (joint order)
    telemetry_path: Path

    @property
    def ids(self) -> list[int]:
        return [j.bus_id for j in self.robot.joints]

    def play(
        self, config: PlayerConfig, on_tick: Callable[[int, float], None] | None = None
    ) -> tuple[PlayResult, Player]:
        writer = TelemetryWriter(self.telemetry_path, self.robot.joint_names, self.ids)
        player = Player(
            self.robot, self.gait, bus=self.bus, config=config, clock=self.clock,
            telemetry=writer, on_tick=on_tick,
        )  # fmt: skip
        return player.run(), player

    def telemetry(self) -> Telemetry:
        return read_telemetry(self.telemetry_path)


def make_rig(
    tmp_path: Path,
    robot_name: str = "quad12",
    start_pose_rad: np.ndarray | None = None,
    gait: Gait | None = None,
) -> Rig:
    robot = robots.load(robot_name)
    clock = VirtualClock()
    pose = slumped_pose_rad(robot) if start_pose_rad is None else start_pose_rad
    vbus = virtual_robot_bus(robot, pose, clock=clock)
    wire = WireRecorder(vbus)
    start = np.array([vbus.servo(j.bus_id).position_tick for j in robot.joints])
    return Rig(
        robot, gait or bringup_gait(robot), clock, vbus, vbus.connect(FAST_BUS), wire, start,
        tmp_path / "telemetry.csv",
    )  # fmt: skip


def assert_wire_safe(rig: Rig, max_step_ticks: np.ndarray) -> np.ndarray:
    """Every goal on the wire inside the joint limits; no step above the limit (incl. the first
    one, from the servo's position at torque-on). Returns the (K, J) goal matrix."""
    goals = rig.wire.goal_matrix(rig.ids)
    assert len(goals) > 0
    for j, joint in enumerate(rig.robot.joints):
        tpr = joint.servo.ticks_per_rad
        angles = (goals[:, j] - joint.zero_offset_ticks) / (joint.direction * tpr)
        assert np.all(angles >= joint.lower_rad - 1e-12), joint.name
        assert np.all(angles <= joint.upper_rad + 1e-12), joint.name
    path = np.vstack([np.round(rig.start_ticks), goals])
    steps = np.abs(np.diff(path, axis=0))
    assert np.all(steps <= max_step_ticks[None, :]), (steps.max(axis=0), max_step_ticks)
    return goals


def torque_all_off(rig: Rig) -> bool:
    return not any(s.torque_enabled for s in rig.vbus.servos)

"""Servo identification: the lifted twin, the fit, and the round trip (known servos come back)."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

import robots
from hardware.bus.servo_bus import BusConfig
from hardware.play.clock import VirtualClock
from hardware.play.identify import IdentifyPlayer
from hardware.play.player import PlayerConfig
from hardware.play.telemetry import TelemetryWriter
from robots.robot import Robot
from robots.servo_params import ServoSetting
from sim.errors import SimConfigError
from sim.identify.fit import contacts_beyond_joints, identify
from sim.model import LIFT_M, SimConditions, build_sim_model
from sim.twin import MujocoTwin
from tests.zoo.fixtures import ZOO


@pytest.fixture(scope="module")
def spot() -> Robot:
    return robots.load(str(ZOO / "spotmicro"))


def test_lifted_model_welds_the_base_in_the_air_and_ignores_the_floor(spot: Robot) -> None:
    sim = build_sim_model(spot, SimConditions(lifted=True))
    assert sim.model.nq == spot.dof  # no freejoint left
    data = mujoco.MjData(sim.model)
    mujoco.mj_setState(sim.model, data, sim.initial_state(), mujoco.mjtState.mjSTATE_FULLPHYSICS)
    q = np.asarray(spot.nominal_stance_rad)
    for _ in range(500):  # 1 s, servos holding the stance
        data.ctrl[:] = q
        mujoco.mj_step(sim.model, data)
    assert data.xpos[sim.root_body][2] == pytest.approx(spot.stance_base_height_m + LIFT_M)
    feet = sim.sensor(data.sensordata, "gs_robot_contacts")
    assert feet[0] == 0  # nothing touches the world
    assert np.max(np.abs(data.qpos[sim.qpos_adr] - q)) < 0.1  # hanging legs sag, but hold


def _write_goal(twin: MujocoTwin, joint: int, angle_rad: float) -> None:
    j = twin.robot.joints[joint]
    servo = next(s for s in twin.vbus.servos if s.servo_id == j.bus_id)
    reg = twin.vbus.table["goal_position"]
    servo.write(reg.addr, reg.encode(round(j.angle_to_ticks(angle_rad))))


def test_twin_goal_acts_after_the_servos_latency(spot: Robot) -> None:
    latency_ms = 13.0
    settings = [ServoSetting()] * spot.dof
    knee = spot.joint_names.index("fl_knee")
    settings[knee] = ServoSetting(latency_ms=latency_ms)
    clock = VirtualClock()
    twin = MujocoTwin(spot, clock.now_s, lifted=True, servo_settings=settings)
    t0 = clock.now_s()
    twin.advance(t0 + 0.2, twin.vbus.servos)  # settle
    q_rest = twin.joint_angles_rad[knee]
    _write_goal(twin, knee, float(q_rest) + 0.3)
    moved_at = None
    for k in range(1, 40):
        twin.advance(t0 + 0.2 + k * 0.002, twin.vbus.servos)
        if moved_at is None and twin.joint_angles_rad[knee] - q_rest > 1e-3:
            moved_at = k * 0.002
    assert moved_at is not None
    assert latency_ms / 1000 < moved_at <= latency_ms / 1000 + 0.006


def test_contacts_are_found_where_a_link_touches_another(spot: Robot) -> None:
    roll = spot.joint_names.index("fl_hip_roll")
    knee = spot.joint_names.index("fl_knee")
    pose = np.asarray(spot.nominal_stance_rad, float)
    rolled = pose.copy()
    rolled[roll] = math.radians(25.0)
    found = contacts_beyond_joints(spot, [roll, knee], np.stack([pose, rolled]))
    assert found[0] and all("/" in c for c in found[0])
    assert found[1] == ()  # the knee's links touched nothing


def test_a_record_without_excitation_is_refused_in_one_line(spot: Robot, tmp_path: Path) -> None:
    quad = robots.load("quad12")
    path = tmp_path / "run.csv"
    writer = TelemetryWriter(path, quad.joint_names, [j.bus_id for j in quad.joints])
    writer.finish("completed", "", 0, 0.0, 0.0)
    writer.close()
    with pytest.raises(SimConfigError, match="are not robot spotmicro's"):
        identify(path, spot)
    with pytest.raises(SimConfigError, match="no excitation ticks"):
        identify(path, quad)
    with pytest.raises(SimConfigError, match="cannot read it"):
        identify(tmp_path / "missing.csv", quad)


def _record(
    robot: Robot, settings: list[ServoSetting], path: Path, joints: tuple[str, ...],
    amplitude_deg: float, segment_s: float,
) -> None:  # fmt: skip
    clock = VirtualClock()
    twin = MujocoTwin(robot, clock.now_s, lifted=True, servo_settings=settings)
    writer = TelemetryWriter(path, robot.joint_names, [j.bus_id for j in robot.joints])
    player = IdentifyPlayer(
        robot, bus=twin.vbus.connect(BusConfig(timeout_s=0.002, retries=1)),
        config=PlayerConfig(ramp_s=0.5), clock=clock, telemetry=writer,
        amplitude_rad=math.radians(amplitude_deg), segment_s=segment_s, joints=joints,
    )  # fmt: skip
    assert player.run().stop.reason.value == "completed"
    writer.close()


@pytest.mark.slow
def test_round_trip_known_servos_come_back_within_10_percent(spot: Robot, tmp_path: Path) -> None:
    """spotmicro (a zoo robot) in the lifted twin with non-default servos per joint; its hip
    pitches and knees excited (the hip rolls touch the body within a few degrees, see below)."""
    rng = np.random.default_rng(18)
    settings = [
        ServoSetting(
            gain_scale=float(rng.uniform(0.7, 1.4)),
            latency_ms=float(rng.uniform(3.0, 15.0)),
            strength=float(rng.uniform(0.7, 1.2)),
        )
        for _ in spot.joints
    ]
    joints = tuple(n for n in spot.joint_names if not n.endswith("hip_roll"))
    path = tmp_path / "ident.csv"
    _record(spot, settings, path, joints, amplitude_deg=15.0, segment_s=5.0)
    result = identify(path, spot)
    assert [f.name for f in result.fits] == list(joints)
    for f in result.fits:
        true = settings[spot.joint_names.index(f.name)]
        assert f.setting.gain_scale == pytest.approx(true.gain_scale, rel=0.10), f.name
        assert f.setting.latency_ms == pytest.approx(true.latency_ms, rel=0.10), f.name
        assert f.setting.strength == pytest.approx(true.strength, rel=0.10), f.name
        assert math.degrees(f.held_out_rms_rad) < 0.1, f.name
        assert not f.contacts


def test_untrusted_fits_say_why_and_poorly_determined_ones_are_flagged() -> None:
    from sim.identify.fit import JointFit

    good = JointFit("knee", ServoSetting(1.1, 8.0, 0.9), 10.0, 1.7, 4e-4, 4e-4, 400, 12,
                    sd=(0.002, 0.05, 0.004))  # fmt: skip
    assert good.trusted and good.warnings == ()
    touching = JointFit("roll", ServoSetting(), 10.0, 1.9, 0.05, 0.05, 400, 12,
                        contacts=("body/hip",))  # fmt: skip
    assert not touching.trusted
    assert any("body/hip" in w and "--amplitude-deg" in w for w in touching.warnings)
    vague = JointFit("knee", ServoSetting(1.0, 8.0, 1.0), 10.0, 1.9, 4e-4, 4e-4, 400, 12,
                     sd=(0.001, 0.05, 0.2))  # fmt: skip
    assert vague.trusted
    assert [w for w in vague.warnings if "strength poorly determined (±20 %)" in w.replace(
        " by this record", "")]  # fmt: skip

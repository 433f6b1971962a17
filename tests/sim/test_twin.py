"""The MuJoCo twin behind the byte-level virtual bus: the whole pipeline closed on the wire.

player ─► SafetyGate ─► vendor SDK ─► packets ─► VirtualServoBus ─► MujocoTwin (sim servo model)
"""

from __future__ import annotations

import numpy as np
import pytest

import robots
from hardware.bus.servo_bus import BusConfig
from hardware.bus.wire_log import WireRecorder
from hardware.play.clock import VirtualClock
from hardware.play.player import Player, PlayerConfig, PlayResult
from robots.gait import Gait
from robots.robot import Robot
from sim.twin import MujocoTwin

BUS = BusConfig(timeout_s=0.002, retries=1)
RATE_HZ = 100.0


def _play(robot: Robot, gait: Gait, cycles: int) -> tuple[PlayResult, MujocoTwin, WireRecorder]:
    clock = VirtualClock()
    twin = MujocoTwin(robot, clock)
    wire = WireRecorder(twin.vbus)
    cfg = PlayerConfig(cycles=cycles, ramp_s=1.0, force=True, rate_hz=RATE_HZ)
    result = Player(robot, gait, bus=twin.vbus.connect(BUS), config=cfg, clock=clock).run()
    return result, twin, wire


def _steady_speed_m_s(
    result: PlayResult, twin: MujocoTwin, gait: Gait, skip_cycles: int = 2
) -> float:
    """Forward base speed over the gait's steady cycles (sim time = tick time, lockstep)."""
    n_ramp, n_gait = result.ticks_by_phase["ramp_in"], result.ticks_by_phase["gait"]
    period = 1.0 / RATE_HZ
    t0 = period * (1 + n_ramp + round(skip_cycles * gait.period_s * RATE_HZ))
    t1 = period * (n_ramp + n_gait)
    return float(twin.mean_velocity_m_s(t0, t1)[0])


def test_bringup_gait_is_tracked_and_physics_runs_in_lockstep(quad: Robot) -> None:
    from hardware.play.virtual_rig import bringup_gait

    gait = bringup_gait(quad, amplitude_rad=0.1, period_s=0.8)
    result, twin, wire = _play(quad, gait, cycles=2)
    assert result.stop.reason.value == "completed"
    # one goal sync-write per tick reached the twin; sim time advanced one period per tick
    assert len(wire.goal_frames()) == result.ticks
    dt = twin.model.opt.timestep
    assert twin.sim_time_s == pytest.approx(result.ticks / RATE_HZ, abs=2 * dt)
    # the simulated servos track the streamed goals (last goal vs the joint angle it produced)
    last_goal = wire.goal_matrix([j.bus_id for j in quad.joints])[-1]
    zero = np.array([j.zero_offset_ticks for j in quad.joints])
    scale = np.array([j.direction * j.servo.ticks_per_rad for j in quad.joints])
    assert np.max(np.abs((last_goal - zero) / scale - twin.joint_angles_rad)) < 0.1
    # stood throughout, and torque is off at the end (the twin's servos are limp)
    assert min(p[2] for _, p in [(h.t_s, h.position_m) for h in twin.history]) > 0.12
    assert not any(s.torque_enabled for s in twin.vbus.servos)


def test_twin_agrees_with_sim_validate(quad: Robot) -> None:
    """Same gait, same servo model: the wire-driven twin and sim.validate walk alike."""
    from sim.synthetic import kinematic_gait, trot_schedule
    from sim.validate import validate

    gait = kinematic_gait(quad, trot_schedule(quad, 0.8, 0.6), 0.2, lift_m=0.02)
    result, twin, _ = _play(quad, gait, cycles=8)
    twin_speed = _steady_speed_m_s(result, twin, gait)
    sim_speed = validate(gait, quad, cycles=8).metrics.achieved_speed_m_s
    assert twin_speed == pytest.approx(sim_speed, abs=0.015)


@pytest.fixture(scope="module")
def planned_trot(quad: Robot) -> Gait:
    """A quad12 trot from the spacetime planner (as `gaitsmith plan quad12 --gait trot`)."""
    pytest.importorskip("casadi")
    from planner.nlp.spacetime import GaitPlanner
    from planner.templates import make_schedule

    planner = GaitPlanner(quad, n_knots=24)
    result = planner.solve(make_schedule(quad, "trot"), 0.25)
    assert result.feasible, result.message
    return planner.to_gait(result, "trot")


def test_planned_trot_walks_through_the_twin(quad: Robot, planned_trot: Gait) -> None:
    from sim.validate import validate

    gait = planned_trot
    result, twin, _ = _play(quad, gait, cycles=8)
    assert result.stop.reason.value == "completed"
    commanded = gait.velocity.vx_m_s
    ratio = _steady_speed_m_s(result, twin, gait) / commanded
    sim_ratio = validate(gait, quad, cycles=8).metrics.achieved_speed_m_s / commanded
    assert ratio == pytest.approx(sim_ratio, abs=0.1)  # the twin is the simulator, on the wire
    assert gait.planner["joint_angles"] == "servo_goal"  # the player streams servo goals
    assert sim_ratio >= 0.9  # issue 6 acceptance: within 10 % in sim.validate
    assert ratio >= 0.8, f"{ratio:.0%} of {commanded} m/s through the twin"
    # issue 12: the entry through the mean pose does not turn it (a straight ramp to phase 0 put
    # it 15° off and 0.3 m sideways after 1.2 m); measured from the twin's start, stop included
    x, y, _ = twin.base_position_m
    assert abs(y) < 0.05 * x, f"y = {y:+.3f} m after x = {x:.3f} m"


def test_hardware_twin_is_reachable_only_lazily() -> None:
    import subprocess
    import sys

    code = (
        "import sys, hardware.play.player, hardware.play.commands, hardware.cli\n"
        "print(int('mujoco' in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "0"
    assert robots.load("quad12").name == "quad12"

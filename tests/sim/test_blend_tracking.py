"""A blended command between two grid points tracks in MuJoCo within the tolerance the grid
points themselves meet (issue #15 item 3).

The library is two hex18 tripod gaits (kinematic reference gaits, `sim.synthetic`: the blending is
under test here, not the planner) at 0.05 and 0.10 m/s, each validated by `sim.validate`. The
blender streams its targets at 100 Hz from the stand — stand → walk transition included — into
the MuJoCo servo model (`sim.model`, `sim.servo.held_targets`, as `sim.rollout` does for a
single gait); the achieved velocity is measured in the world frame over the steady cycles.
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import mujoco.rollout
import numpy as np
import pytest

from robots import Gait, Robot, Velocity
from robots.blend import BlendLimits, GaitBlender
from robots.library import GaitLibrary, LibraryEntry
from robots.library import load as load_library
from robots.library import save as save_library
from sim.metrics import yaw_of
from sim.model import build_sim_model
from sim.servo import held_targets
from sim.synthetic import kinematic_gait, standing_gait, trot_schedule
from sim.validate import PassCriteria, validate

RATE_HZ = 100.0
GRID_VX = (0.05, 0.10)
PERIOD_S = 0.5


def _entry(robot: Robot, vx: float) -> tuple[LibraryEntry, float]:
    gait = kinematic_gait(robot, trot_schedule(robot, PERIOD_S, 0.6), vx, label="tripod")
    result = validate(gait, robot, 12, keep_trajectory=False)
    assert result.passed, result.reasons  # the grid point meets its tolerance
    m = result.metrics
    achieved = Velocity(m.achieved_vx_m_s, m.achieved_vy_m_s, m.achieved_yaw_rate_rad_s)
    return LibraryEntry(Velocity(vx), gait.with_validation(result.to_dict()), achieved), \
        abs(m.achieved_vx_m_s - vx)


def _library(robot: Robot) -> tuple[GaitLibrary, list[float]]:
    built = [_entry(robot, vx) for vx in GRID_VX]
    stand: Gait = standing_gait(robot, PERIOD_S)
    return GaitLibrary(robot.name, robot.fingerprint, robot.joint_names, "tripod", stand,
                       tuple(e for e, _ in built), {}), [err for _, err in built]


def blended_run(robot: Robot, lib: GaitLibrary, command: Velocity, seconds: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(time, base xy, base yaw) per physics step and the time the full gait began."""
    blender = GaitBlender(lib, BlendLimits.for_robot(robot, 0.5, 2.0))
    stream, full_at = [], math.inf
    for k in range(round(seconds * RATE_HZ)):
        stream.append(blender.step(command, 1.0 / RATE_HZ))
        if blender.blend_weight == 1.0 and math.isinf(full_at):
            full_at = k / RATE_HZ
    sim = build_sim_model(robot)
    dt = float(sim.model.opt.timestep)
    steps = round(seconds / dt)
    ctrl = held_targets(np.array(stream), rate_hz=RATE_HZ, latency_s=0.0, dt_s=dt, n_steps=steps,
                        initial_rad=np.asarray(robot.nominal_stance_rad))
    st, sd = mujoco.rollout.rollout(sim.model, mujoco.MjData(sim.model),
                                    sim.initial_state()[None], ctrl[None])
    pos = sim.sensor(sd[0], "gs_base_pos")
    assert np.all(np.isfinite(pos)) and pos[:, 2].min() > 0.5 * robot.stance_base_height_m
    return st[0][:, 0], pos[:, :2], np.unwrap(yaw_of(sim.sensor(sd[0], "gs_base_quat"))), full_at


def test_blended_command_tracks_like_the_grid_points(hex18: Robot) -> None:
    lib, grid_errors = _library(hex18)
    command = Velocity(0.5 * (GRID_VX[0] + GRID_VX[1]))
    warmup = PassCriteria().warmup_cycles * PERIOD_S
    t, xy, yaw, full_at = blended_run(hex18, lib, command, seconds=11.0)
    steady = t >= full_at + warmup
    assert steady.sum() > 0.5 * len(t) / 2
    i0 = int(np.argmax(steady))
    span = t[-1] - t[i0]
    # world frame, rotated by the start heading (the robot starts facing +x)
    c, s = math.cos(yaw[0]), math.sin(yaw[0])
    dx, dy = (xy[-1] - xy[i0]) / span
    vx, vy = c * dx + s * dy, -s * dx + c * dy
    tol = max(PassCriteria().speed_rel_tol * command.vx_m_s, PassCriteria().speed_abs_tol_m_s)
    assert abs(vx - command.vx_m_s) <= tol, (vx, command.vx_m_s, tol, grid_errors)
    assert abs(vy) <= PassCriteria().vy_abs_tol_m_s + PassCriteria().vy_rel_tol * vx
    assert abs(yaw[-1] - yaw[0]) <= PassCriteria().max_heading_error_rad


@pytest.mark.slow
def test_planned_library_blends_between_its_grid_points(hex18: Robot, tmp_path: Path) -> None:
    """End to end on a planned 2 × 1 × 2 grid (vx × yaw rate, N = 16): build (every entry
    validated in MuJoCo), save, load, blend at the cell centre; the blend meets the criteria the
    entries met (vx for the straight command, yaw rate for the turning one)."""
    from gaitsmith.library_cmd import SimValidator
    from planner.library import GridSpec, build_library

    grid = GridSpec((0.0, 0.1), (0.0,), (0.0, 0.4))
    build = build_library(hex18, grid, n_knots=16, validator=SimValidator(str(hex18.root_dir), 12),
                          executor="serial", min_entries=grid.size)
    path = tmp_path / "hex18_lib.json"
    save_library(build.library, path)
    lib = load_library(path, hex18)
    c = PassCriteria()
    for command in (Velocity(0.05), Velocity(0.05, 0.0, 0.2)):
        t, xy, yaw, full_at = blended_run(hex18, lib, command, seconds=12.0)
        i0 = int(np.argmax(t >= full_at + c.warmup_cycles * lib.entries[0].gait.period_s))
        span = t[-1] - t[i0]
        if command.yaw_rate_rad_s == 0.0:
            vx = float((xy[-1, 0] - xy[i0, 0]) / span)  # starts facing +x
            tol = max(c.speed_rel_tol * command.vx_m_s, c.speed_abs_tol_m_s)
            assert abs(vx - command.vx_m_s) <= tol, (vx, tol)
        else:
            w = float((yaw[-1] - yaw[i0]) / span)
            tol = max(c.yaw_rate_rel_tol * command.yaw_rate_rad_s, c.yaw_rate_abs_tol_rad_s)
            assert abs(w - command.yaw_rate_rad_s) <= tol, (w, tol)

"""Stance feet hold inside their friction cone: no soft-contact creep (sim.model noslip)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import robots
from sim.model import build_sim_model
from tests.zoo.fixtures import ZOO


@pytest.mark.parametrize("robot_dir", ["quad12", str(ZOO / "spotmicro")])
def test_pushed_standing_robot_feet_do_not_creep(robot_dir: str) -> None:
    """A horizontal push of 0.2·m·g (µ of the MJCFs ≥ 0.9) on the standing robot for 1 s. Without
    the noslip solver the feet crept 5-7 mm (quad12) and 10-16 mm (spotmicro)."""
    sim = build_sim_model(robots.load(robot_dir))
    m = sim.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, sim.initial_state(), mujoco.mjtState.mjSTATE_FULLPHYSICS)
    d.ctrl[:] = np.asarray(sim.robot.nominal_stance_rad)
    mujoco.mj_step(m, d, nstep=round(0.5 / m.opt.timestep))
    site = mujoco.mjtObj.mjOBJ_SITE
    sites = [mujoco.mj_name2id(m, site, leg.foot_site) for leg in sim.robot.legs]
    before = d.site_xpos[sites, :2].copy()
    d.xfrc_applied[sim.root_body, 0] = 0.2 * sim.mass_kg * 9.81
    mujoco.mj_step(m, d, nstep=round(1.0 / m.opt.timestep))
    moved = np.linalg.norm(d.site_xpos[sites, :2] - before, axis=1)
    assert moved.max() < 0.002, moved

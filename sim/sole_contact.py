"""Where each flat sole carries its load in MuJoCo: centre of pressure and contact count per step.

The measurement behind docs/results/biped_walk_robustness.md: the validation run replayed step
by step (`mujoco.mj_step` on the same model, target stream and latency as `sim.rollout.run`,
so the states are the same), and at every step, for each flat foot,

- the normal force of its sole–floor contacts (`mj_contactForce`, the contact frame's normal),
- the centre of pressure, Σ fₙ·p / Σ fₙ over those contacts, in the sole frame
  (`robots.sole.sole_pose_world`) as a fraction of the half length X and half width Y:
  ±1 is on an edge (NaN: the sole carries nothing),
- the number of contacts: a box on a plane touches at its corners, so 4 means the sole is flat
  on the ground, 2 on an edge, 1 on a corner.

`edge_shares` sums that up over single support: how often the stance sole stood on an edge,
and how often its CoP was at the side or the toe/heel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from robots.gait import Gait
from robots.robot import Robot
from robots.sole import sole_pose_world
from sim.errors import SimConfigError
from sim.model import SimConditions, build_sim_model
from sim.rollout import RunSettings, run_plan, stream_latency_s, stream_targets
from sim.servo import held_targets

#: |CoP| beyond this fraction of a half extent counts as "at the edge"
EDGE_FRACTION = 0.95
#: a sole carrying less than this share of the robot's weight counts as in the air
LOADED_WEIGHT_FRACTION = 0.05


@dataclass(frozen=True, eq=False)
class SoleContactLog:
    """Per physics step (first axis T) and flat foot (second axis, `feet` order)."""

    feet: tuple[str, ...]
    time_s: np.ndarray  # (T,)
    gait_phase: np.ndarray  # (T,) cycles since the gait started (negative in the entry)
    normal_force_n: np.ndarray  # (T, F)
    cop_fraction: np.ndarray  # (T, F, 2): CoP x/X, y/Y in the sole frame; NaN unloaded
    contacts: np.ndarray  # (T, F) sole–floor contacts
    weight_n: float


@dataclass(frozen=True)
class EdgeShares:
    """Over the single-support steps of the window: the stance sole on ≤ 2 contacts, its CoP
    within (1 − EDGE_FRACTION) of the side edges, of the toe or heel."""

    steps: int
    on_edge: float
    cop_at_side: float
    cop_at_toe_or_heel: float


def sole_contact_log(
    gait: Gait, robot: Robot, cycles: int = 20, *, latency_s: float = 0.0
) -> SoleContactLog:
    """Replay the validation run of `gait` (no fall stop) and log the flat soles' contact."""
    flat = [f for f, leg in enumerate(robot.legs) if leg.is_flat]
    if not flat:
        raise SimConfigError(f"{robot.name}: no flat feet, so no soles to log")
    gait.check_robot(robot)
    sim = build_sim_model(robot, SimConditions())
    settings = RunSettings(cycles=cycles, latency_s=latency_s)
    stream, _, gait_start = stream_targets(gait, sim, settings)
    plan = run_plan(gait, sim, settings)
    model = sim.model
    data = mujoco.MjData(model)
    dt = float(model.opt.timestep)
    total = round(plan.gait_end_s / dt)
    ctrl = held_targets(stream, rate_hz=settings.rate_hz,
                        latency_s=stream_latency_s(settings, sim), dt_s=dt, n_steps=total,
                        initial_rad=np.asarray(robot.nominal_stance_rad, dtype=float))
    mujoco.mj_setState(model, data, sim.initial_state(), mujoco.mjtState.mjSTATE_FULLPHYSICS)
    floor = set(np.flatnonzero(model.geom_bodyid == 0).tolist())
    geoms = [set(sim.foot_geoms[f]) for f in flat]
    n_f = len(flat)
    time_s = np.empty(total)
    force = np.zeros((total, n_f))
    cop = np.full((total, n_f, 2), np.nan)
    count = np.zeros((total, n_f), dtype=int)
    wrench = np.zeros(6)
    weight = sim.mass_kg * float(np.linalg.norm(model.opt.gravity))
    for step in range(total):
        data.ctrl[:] = ctrl[step]
        mujoco.mj_step(model, data)
        time_s[step] = data.time
        for k, f in enumerate(flat):
            centre, rot = sole_pose_world(model, data, robot.legs[f])
            moment = np.zeros(3)
            for c in range(data.ncon):
                con = data.contact[c]
                pair = {int(con.geom1), int(con.geom2)}
                if not (pair & geoms[k] and pair & floor):
                    continue
                mujoco.mj_contactForce(model, data, c, wrench)
                fn = abs(float(wrench[0]))  # normal component in the contact frame
                force[step, k] += fn
                moment += fn * (np.asarray(con.pos) - centre)
                count[step, k] += 1
            if force[step, k] > LOADED_WEIGHT_FRACTION * weight:
                local = rot.T @ (moment / force[step, k])
                hx, hy = robot.legs[f].sole_half_extents_m or (math.nan, math.nan)
                cop[step, k] = (local[0] / hx, local[1] / hy)
    return SoleContactLog(
        feet=tuple(robot.legs[f].name for f in flat),
        time_s=time_s,
        gait_phase=(time_s - gait_start) / gait.period_s,
        normal_force_n=force,
        cop_fraction=cop,
        contacts=count,
        weight_n=weight,
    )


def edge_shares(log: SoleContactLog, from_cycle: float = 1.0, to_cycle: float = 3.0
                ) -> EdgeShares:
    """`EdgeShares` over the steps with exactly one loaded sole, gait phase in the window."""
    loaded = log.normal_force_n > LOADED_WEIGHT_FRACTION * log.weight_n
    window = (log.gait_phase >= from_cycle) & (log.gait_phase < to_cycle)
    single = window & (loaded.sum(axis=1) == 1)
    if not np.any(single):
        return EdgeShares(0, math.nan, math.nan, math.nan)
    stance = np.argmax(loaded[single], axis=1)
    rows = np.flatnonzero(single)
    cop = log.cop_fraction[rows, stance]
    return EdgeShares(
        steps=int(single.sum()),
        on_edge=float(np.mean(log.contacts[rows, stance] <= 2)),
        cop_at_side=float(np.mean(np.abs(cop[:, 1]) > EDGE_FRACTION)),
        cop_at_toe_or_heel=float(np.mean(np.abs(cop[:, 0]) > EDGE_FRACTION)),
    )

"""Where a written gait cycle starts: the knot the player ramps into from rest.

Since issue #12 the player and the simulator no longer ramp to the phase-0 sample: they ramp to
the gait's mean pose and blend the gait in over whole cycles (`robots.ramp.gait_entry`), because
the straight ramp to phase 0 turned the robot 7–18° before its first step (the swing groups sit
at opposite ends of their strides there, so the robot ended up on one diagonal while its feet
moved apart). Phase 0 is now only where the blend ends, already in motion; the history below is
why it was chosen as it is, and the choice stays harmless.

Before, the player and the simulator ramped from the standing pose to the gait's phase-0 sample,
held it for an instant, and started the cycle. With servo goals (`planner.nlp.servo_loop`)
that sample is not just a pose: goal = q + τ/kp carries the planned *dynamic* load of each leg,
so the servos push as if the robot were mid-stride. If phase 0 falls where a foot is in swing or
the planned load is lopsided (a landing impact, a leg about to lift), the robot standing still at
the end of the ramp gets the wrong load distribution: the heavily-offset legs over-extend, the
body rises and lightly loaded feet leave the ground before the gait even starts. MuJoCo showed
exactly that: a quad12 lateral-sequence walk (0.15 m/s, period 1.06 s) rose 35 mm during the
ramp, lifted a diagonal pair and rolled over before its first step. Started from its most evenly
loaded knot, the same plan got through the ramp (it still fell within its first cycle, for
reasons of its own; the search's MuJoCo acceptance rejects such gaits).

The planned cycle is periodic, so its start is free: `start_knot` picks the knot with the most
feet in stance and, among those, the most even vertical load (closest to the static share m·g/n
on every stance foot); `rotate` re-indexes a plan so that knot becomes phase 0 (touchdown phases
shift by −k/N, every per-knot array rolls by k). Nothing else about the gait changes.

Loads within `LOAD_TIE` (a fraction of the total load) of the evenest count as a tie, and a tie
goes to the lowest knot, i.e. the earliest in the schedule the plan was solved on. A
mirror-symmetric plan (a biped walk, a trot) has two such knots half a cycle apart whose loads
differ only by rounding (1e-13): without the tolerance, rounding picked the start, so a change
of the NLP's arithmetic that left the plan the same to 1e-12 made the written gait lead with the
other leg. For the built-in biped at 0.2 m/s that flipped the MuJoCo run from "stays up" to
"falls at 12.24 s" (docs/results/biped_walk_robustness.md §Session 25).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from planner.nlp.spacetime import PlanResult
from robots import ContactSchedule
from robots.schedule import KNOT_TOL

#: loads whose imbalance is within this fraction of the total load of the evenest count as equal
LOAD_TIE = 1e-6


def start_knot(schedule: ContactSchedule, forces_n: np.ndarray) -> int:
    """The knot to start from: most stance feet, then the most even vertical load (within
    `LOAD_TIE`), then the lowest index.

    `forces_n` is N × F × 3 (world frame), N the number of knots.
    """
    n_knots = forces_n.shape[0]
    contact = schedule.contact_matrix(n_knots)
    n_stance = contact.sum(axis=1)
    fz = np.where(contact, forces_n[:, :, 2], np.nan)
    total = np.nansum(fz, axis=1)
    share = total / np.maximum(n_stance, 1)
    imbalance = np.nanmax(np.abs(fz - share[:, None]), axis=1, initial=0.0) / np.maximum(
        np.abs(total), 1e-9)
    full = n_stance == n_stance.max()
    best = float(np.min(imbalance[full]))
    return int(np.flatnonzero(full & (imbalance <= best + LOAD_TIE))[0])


def rotate_schedule(schedule: ContactSchedule, k: int, n_knots: int) -> ContactSchedule:
    """`schedule` with knot k of n_knots as phase 0: contact_matrix rolls by exactly k rows.

    Phases are shifted in knot units, (p·N − k) mod N, so a touchdown that sat on a knot still
    sits exactly on the same knot (a float shift of −k/N can land a hair before it and lose it).
    A touchdown within `KNOT_TOL` of a knot is snapped onto it first: a hair below knot k
    (0.19999999999999996·30 = 5.999999999999999, k = 6) otherwise wrapped to phase 1.0, which
    `ContactSchedule` refuses, and writing the gait failed.
    """
    def shifted(p: float) -> float:
        m = p * n_knots
        if abs(m - round(m)) <= KNOT_TOL * n_knots:
            m = float(round(m))
        return float(((m - k) % n_knots) / n_knots) % 1.0

    phases = tuple(shifted(p) for p in schedule.touchdown_phase)
    return ContactSchedule(schedule.period_s, schedule.feet, phases, schedule.duty_factor)


def rotate(result: PlanResult, k: int) -> PlanResult:
    """`result` with knot `k` as phase 0 (exact for a periodic plan)."""
    n = result.joint_angles_rad.shape[0]
    k %= n
    if k == 0:
        return result
    schedule = rotate_schedule(result.schedule, k, n)

    def roll(a: np.ndarray) -> np.ndarray:
        return np.roll(a, -k, axis=0)

    return dataclasses.replace(
        result,
        schedule=schedule,
        base_pose=roll(result.base_pose),
        joint_angles_rad=roll(result.joint_angles_rad),
        joint_speeds_rad_s=roll(result.joint_speeds_rad_s),
        contact_forces_n=roll(result.contact_forces_n),
        joint_torques_nm=roll(result.joint_torques_nm),
    )


def start_from_rest_like_knot(result: PlanResult) -> PlanResult:
    """`rotate(result, start_knot(...))`: the plan as it should be written to a gait file."""
    return rotate(result, start_knot(result.schedule, result.contact_forces_n))


__all__ = ["LOAD_TIE", "rotate", "rotate_schedule", "start_from_rest_like_knot", "start_knot"]

"""Re-plans of one command that should walk the same: the plans `sim.robustness.knife_edge_check`
judges beside the nominal one.

A gait that passes MuJoCo only for one exact plan is on a knife edge: the built-in biped's N = 12
walk at 0.1 m/s passed with one derivative path and fell at ≈4.9 s with the other, the two plans
5.6e-5 rad apart (docs/results/biped_walk_robustness.md). The variants here are what a user
changes without meaning to change the gait: the speed by ±1 % and the knot count by ±4. Each is
planned cold (no warm start from the nominal plan), as a fresh `gaitsmith plan` would.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from planner.errors import InfeasibleGaitError, PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from robots import ContactSchedule, Gait, Robot

SPEED_FRACTIONS = (-0.01, 0.01)
KNOT_OFFSETS = (-4, 4)
MIN_KNOTS = 8


@dataclass(frozen=True)
class Replan:
    """One variant: its label ("speed +1 %", "N 20"), the gait (None: the plan was infeasible)
    and the planner's message."""

    label: str
    gait: Gait | None
    message: str


def replans(
    robot: Robot,
    schedule: ContactSchedule,
    gait_label: str,
    speed_m_s: float,
    n_knots: int,
    options: PlannerOptions | None = None,
    *,
    speed_fractions: Sequence[float] = SPEED_FRACTIONS,
    knot_offsets: Sequence[int] = KNOT_OFFSETS,
    extra_metadata: dict[str, Any] | None = None,
) -> list[Replan]:
    """The variants of the command (`speed_m_s` at `n_knots`), each planned cold.

    `extra_metadata` is the nominal gait file's own (`GaitPlanner.to_gait`): what the player and
    the simulator read from it (entry cycles, the stance-compliance record) must be the same in
    every variant, or a variant is judged started differently from the plan it stands beside."""
    if any(not -0.5 < f < 0.5 for f in speed_fractions):
        raise PlannerConfigError(f"speed fractions must be within ±50 %, got {speed_fractions}")
    out: list[Replan] = []
    planner = GaitPlanner(robot, n_knots=n_knots, options=options)
    for frac in speed_fractions:
        out.append(_solve(planner, schedule, gait_label, speed_m_s * (1.0 + frac),
                          f"speed {frac * 100:+g} %", extra_metadata))
    for dn in knot_offsets:
        n = n_knots + dn
        if n < MIN_KNOTS or n == n_knots:
            continue
        other = GaitPlanner(robot, n_knots=n, options=options)
        out.append(_solve(other, schedule, gait_label, speed_m_s, f"N {n}", extra_metadata))
    return out


def _solve(planner: GaitPlanner, schedule: ContactSchedule, gait_label: str, speed_m_s: float,
           label: str, extra_metadata: dict[str, Any] | None) -> Replan:
    result = planner.solve(schedule, speed_m_s, warm_start=False)
    try:
        return Replan(label, planner.to_gait(result, gait_label, extra_metadata), result.status)
    except InfeasibleGaitError as exc:
        return Replan(label, None, str(exc))

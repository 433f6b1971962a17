"""MuJoCo acceptance of a gait as a picklable check, for search loops that must not import sim.

`planner.search.gait_search` can reject timings whose planned gait does not walk under the servo
model
(basin-CMA ranks them as infeasible); the command line wires this check in, so that `planner`
never imports `sim` (DESIGN: the CLI wires the packages). `SimAcceptance` is a frozen, picklable
factory — each executor worker calls it once and gets a `GaitCheck` bound to its robot.

The check runs `sim.validate.validate` (ramp-in from rest, `cycles` cycles, stopping one chunk
after a fall) with `SEARCH_CRITERIA`: the default `PassCriteria` except peak torque, allowed up to
stall instead of 80 % of it. The search scores samples on a coarse NLP (12 knots), whose servo
goal spline asks for more torque than the same timing planned at 30 knots (quad12 trot at
0.3 m/s: peak 86 % of stall at 12 knots, ≤ 80 % at 30 knots, every other criterion met at both);
the 80 % margin is judged where it matters, on the final gait. Its "badness" is the number of
failed criteria, so a gait that only misses the speed tolerance ranks ahead of one that falls.
`entry_cycles` K > 1: every gait is judged started with at least K cycles of entry blend, as the
gait file the search writes asks (`gaitsmith plan --search --entry-cycles K`, `robots.ramp`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from robots import Gait, Robot
from robots import load as load_robot
from robots.gait import ENTRY_CYCLES_KEY
from sim.validate import PassCriteria, validate

#: Cycles per acceptance run: 2 warm-up + 6 judged keeps a check ≈ 0.1 s at ~80× real time.
DEFAULT_ACCEPTANCE_CYCLES = 8
SEARCH_CRITERIA = PassCriteria(max_peak_torque_fraction=1.0)


@dataclass(frozen=True)
class GaitVerdict:
    passed: bool
    badness: float  # 0 when passed, else the number of failed criteria
    achieved_speed_m_s: float
    reasons: tuple[str, ...]


@dataclass
class GaitCheck:
    """Validate one gait on `robot` in MuJoCo."""

    robot: Robot
    cycles: int = DEFAULT_ACCEPTANCE_CYCLES
    criteria: PassCriteria = SEARCH_CRITERIA
    entry_cycles: int = 1

    def __call__(self, gait: Gait) -> GaitVerdict:
        gait = with_entry_cycles(gait, self.entry_cycles)
        result = validate(gait, self.robot, self.cycles, criteria=self.criteria,
                          keep_trajectory=False)
        failed = sum(1 for _, ok, _ in result.checks if not ok)
        return GaitVerdict(result.passed, 0.0 if result.passed else float(max(failed, 1)),
                           result.metrics.achieved_speed_m_s, result.reasons)


@dataclass(frozen=True)
class SimAcceptance:
    """Picklable factory of a `GaitCheck` (built once per worker)."""

    robot_dir: str
    cycles: int = DEFAULT_ACCEPTANCE_CYCLES
    criteria: PassCriteria = SEARCH_CRITERIA
    entry_cycles: int = 1

    def __call__(self) -> GaitCheck:
        return GaitCheck(load_robot(self.robot_dir), self.cycles, self.criteria,
                         self.entry_cycles)


def with_entry_cycles(gait: Gait, cycles: int) -> Gait:
    """`gait` asking for at least `cycles` entry blend cycles (unchanged for 1)."""
    if cycles <= 1:
        return gait
    return replace(gait, planner={**gait.planner, ENTRY_CYCLES_KEY: int(cycles)})


__all__ = [
    "DEFAULT_ACCEPTANCE_CYCLES",
    "SEARCH_CRITERIA",
    "GaitCheck",
    "GaitVerdict",
    "SimAcceptance",
    "with_entry_cycles",
]

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

Every gait is judged with the controller it will be played with (`validate_as_played`): the IMU
attitude feedback at the gain `robots.attitude.gait_attitude_gain` gives it — per gait, so on a
biped with an ``[imu]`` a walk sample runs closed loop at G 0.5 and a run sample (a flight phase)
open loop, as `gaitsmith plan --simulate` judges the gait the search writes; `attitude_gain`
(``--attitude-gain``) overrides the rule for every gait. A closed-loop verdict records its gain
in the validation's conditions (`sim.validate`, ``attitude_gain``), which the player checks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from robots import Gait, Robot
from robots import load as load_robot
from robots.attitude import ATTITUDE_GAIN_KEY, gait_attitude_gain
from robots.gait import ENTRY_CYCLES_KEY
from sim.attitude_loop import closed_loop
from sim.validate import PassCriteria, ValidationResult, criterion_excess, validate

#: Cycles per acceptance run: 2 warm-up + 6 judged keeps a check ≈ 0.1 s at ~80× real time.
DEFAULT_ACCEPTANCE_CYCLES = 8
SEARCH_CRITERIA = PassCriteria(max_peak_torque_fraction=1.0)


@dataclass(frozen=True)
class GaitVerdict:
    passed: bool
    badness: float  # 0 when passed, else the number of failed criteria
    achieved_speed_m_s: float
    reasons: tuple[str, ...]
    attitude_gain: float = 0.0  # the IMU feedback's gain the gait was judged with (0: open loop)
    #: every failed criterion and how far its metric is past the limit, relative to it
    #: (`sim.validate.criterion_excess`: 0.004 is 0.4 % past, a fall +inf); empty when passed
    excess: tuple[tuple[str, float], ...] = ()


def validate_as_played(gait: Gait, robot: Robot, cycles: int,
                       attitude_gain: float | None = None, **kwargs: Any) -> ValidationResult:
    """`sim.validate.validate` of `gait` closed loop at the gain it will be played with
    (`robots.attitude.gait_attitude_gain`: `attitude_gain` if given, else the robot's rule for
    this gait), open loop at 0; `kwargs` go to `validate`."""
    gain, _ = gait_attitude_gain(robot, gait, attitude_gain)
    return validate(gait, robot, cycles, attitude=closed_loop(gain), **kwargs)


@dataclass
class GaitCheck:
    """Validate one gait on `robot` in MuJoCo (`attitude_gain`: None applies the rule per
    gait, a number every gait's gain)."""

    robot: Robot
    cycles: int = DEFAULT_ACCEPTANCE_CYCLES
    criteria: PassCriteria = SEARCH_CRITERIA
    entry_cycles: int = 1
    attitude_gain: float | None = None

    def __call__(self, gait: Gait) -> GaitVerdict:
        gait = with_entry_cycles(gait, self.entry_cycles)
        result = validate_as_played(gait, self.robot, self.cycles, self.attitude_gain,
                                    criteria=self.criteria, keep_trajectory=False)
        failed = sum(1 for _, ok, _ in result.checks if not ok)
        gain = result.conditions.get(ATTITUDE_GAIN_KEY) or 0.0
        return GaitVerdict(result.passed, 0.0 if result.passed else float(max(failed, 1)),
                           result.metrics.achieved_speed_m_s, result.reasons, float(gain),
                           failed_excess(result, self.robot.leg_length_m))


@dataclass(frozen=True)
class SimAcceptance:
    """Picklable factory of a `GaitCheck` (built once per worker)."""

    robot_dir: str
    cycles: int = DEFAULT_ACCEPTANCE_CYCLES
    criteria: PassCriteria = SEARCH_CRITERIA
    entry_cycles: int = 1
    attitude_gain: float | None = None  # None: the rule per gait (`gait_attitude_gain`)

    def __call__(self) -> GaitCheck:
        return GaitCheck(load_robot(self.robot_dir), self.cycles, self.criteria,
                         self.entry_cycles, self.attitude_gain)


def failed_excess(result: ValidationResult, leg_length_m: float
                  ) -> tuple[tuple[str, float], ...]:
    """The failed checks of `result` with their metrics' relative excess over the limits
    (`sim.validate.criterion_excess`, floored at 0 so a failed check never reads as within)."""
    excess = dict(criterion_excess(result.metrics, result.criteria, leg_length_m))
    return tuple((name, max(excess.get(name, math.inf), 0.0))
                 for name, ok, _ in result.checks if not ok)


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
    "failed_excess",
    "validate_as_played",
    "with_entry_cycles",
]

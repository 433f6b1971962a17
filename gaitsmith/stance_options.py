"""The stance-compliance rule (`planner.compliant_stance`) applied to `gaitsmith plan`'s
options: every NLP-shaping option the user left out (None) takes the rule's value, every one
given on the command line wins, and the gait file records the figure, the rule's values and
which ones were used (``planner["stance_compliance"]``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from gaitsmith.console import console
from planner.compliant_stance import compliant_stance_defaults
from planner.nlp.config import CostWeights
from robots import Robot
from robots.servo_params import ServoSetting

#: the gait file's planner-metadata key of the rule's record
STANCE_COMPLIANCE_KEY = "stance_compliance"


@dataclass(frozen=True)
class StanceShaped:
    """The options after the rule: None where neither the user nor the rule asks for anything
    (the planner's own defaults); `metadata` empty when the robot has no flat foot."""

    force_rate: float | None
    bounce: float | None
    entry: int | None
    metadata: dict[str, Any]

    @property
    def weights(self) -> CostWeights:
        """The objective's weights with the bounce weight, if any, set."""
        return CostWeights() if self.bounce is None else CostWeights(bounce_s2_m2=self.bounce)

    @property
    def rate_bound(self) -> float | None:
        """`PlannerOptions.normal_force_rate_weights_per_t0` (0 from `--force-rate 0`: None,
        no rows)."""
        return None if self.force_rate == 0.0 else self.force_rate


def stance_shaped(robot: Robot, settings: tuple[ServoSetting, ...] | None,
                  force_rate: float | None, bounce: float | None, entry: int | None,
                  ) -> StanceShaped:
    """`force_rate`, `bounce`, `entry` as given (None: not given), filled from the rule."""
    rule = compliant_stance_defaults(robot, settings)
    if rule.compliance is not None:
        console.print(rule.summary())
    used = StanceShaped(
        force_rate if force_rate is not None else rule.force_rate_weights_per_t0,
        bounce if bounce is not None else rule.bounce_s2_m2,
        entry if entry is not None else (rule.entry_cycles if rule.applies else None),
        {},
    )
    if rule.compliance is None:  # no flat foot: nothing to record
        return used
    meta = {**rule.as_metadata(),
            "user_set": [name for name, v in (("force_rate", force_rate),
                                              ("bounce_weight", bounce),
                                              ("entry_cycles", entry)) if v is not None],
            "used": {"normal_force_rate_weights_per_t0": used.force_rate,
                     "bounce_s2_m2": used.bounce, "entry_cycles": used.entry or 1}}
    return StanceShaped(used.force_rate, used.bounce, used.entry, meta)

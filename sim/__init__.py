"""gaitsmith's MuJoCo validation: servo model, rollouts, metrics, video, plots and report.

Public API: `validate`, `validate_and_annotate`, `simulate` + `evaluate`, `PassCriteria`,
`ValidationResult` (sim.validate); `robustness_sweep` (sim.robustness); `ServoParams`,
`servo_params` (sim.servo); `render_video` (sim.render); `write_report` (sim.report).

`MUJOCO_GL` defaults to "egl" here (headless offscreen rendering): it must be set before mujoco
is first imported; `sim.render` also copes when mujoco was imported earlier without it.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from sim.errors import (
    RenderError,
    ReportError,
    SimConfigError,
    SimDivergedError,
    SimError,
    SimSetupError,
)
from sim.robustness import RobustnessResult, robustness_sweep
from sim.servo import ServoParams, servo_params
from sim.validate import (
    PassCriteria,
    ValidationResult,
    evaluate,
    simulate,
    validate,
    validate_and_annotate,
)

__all__ = [
    "PassCriteria",
    "RenderError",
    "ReportError",
    "RobustnessResult",
    "ServoParams",
    "SimConfigError",
    "SimDivergedError",
    "SimError",
    "SimSetupError",
    "ValidationResult",
    "evaluate",
    "robustness_sweep",
    "servo_params",
    "simulate",
    "validate",
    "validate_and_annotate",
]

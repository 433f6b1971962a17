"""Typed errors of the gait player (`gaitsmith-play run` / `calibrate`).

Hierarchy (extends `hardware.errors` additively)::

    HardwareError
    └── PlayerError               the player refuses to start or cannot go on
        ├── PreflightError        a pre-flight check failed (names the servo / field at fault)
        ├── SpeedScaleError       --speed-scale would drive a joint faster than allowed
        └── RunReportError        `report`: a telemetry / gait file missing, garbled or mismatched
"""

from __future__ import annotations

from hardware.errors import HardwareError


class PlayerError(HardwareError):
    """The player refuses to start or cannot go on."""


class PreflightError(PlayerError):
    """A pre-flight check failed: `what` names the servo / joint / field, `problem` says why."""

    def __init__(self, what: str, problem: str) -> None:
        self.what = what
        self.problem = problem
        super().__init__(f"pre-flight: {what}: {problem}")


class SpeedScaleError(PlayerError):
    """The requested time scaling makes joint `joint` faster than its allowed speed."""

    def __init__(
        self,
        joint: str,
        speed_rad_s: float,
        allowed_rad_s: float,
        scale: float,
        rate_hz: float | None = None,
    ) -> None:
        self.joint = joint
        self.speed_rad_s = speed_rad_s
        self.allowed_rad_s = allowed_rad_s
        self.scale = scale
        self.rate_hz = rate_hz
        at = "" if rate_hz is None else f" (enforced at --rate {rate_hz:g})"
        super().__init__(
            f"--speed-scale {scale:g}: joint {joint!r} would reach {speed_rad_s:.2f} rad/s, "
            f"above its allowed {allowed_rad_s:.2f} rad/s{at} "
            f"(largest allowed scale {scale * allowed_rad_s / speed_rad_s:.3f})"
        )


class RunReportError(PlayerError):
    """`gaitsmith-play report` cannot read its inputs: `source` names the file (or option),
    `problem` says what is wrong and what to do."""

    def __init__(self, source: str, problem: str) -> None:
        self.source = source
        self.problem = problem
        super().__init__(f"{source}: {problem}")

"""Typed errors of the planner: every user-facing failure is a `PlannerError`.

`gaitsmith.cli.main` prints a `PlannerError` as one line and exits with code 2, so the messages
here are written for the person running `gaitsmith plan`.
"""

from __future__ import annotations


class PlannerError(Exception):
    """Base class of every user-facing error raised by `planner`."""


class ModelError(PlannerError):
    """The robot's MJCF uses something the symbolic model does not support."""


class PlannerConfigError(PlannerError, ValueError):
    """Bad planner options or a request that does not fit the built problem."""


class TemplateError(PlannerError, ValueError):
    """A gait template does not apply to this robot (e.g. `gallop` on a hexapod)."""


class InfeasibleGaitError(PlannerError):
    """IPOPT found no gait satisfying every limit; `binding` names the limits that bind.

    `binding` is a tuple of (group, worst violation or multiplier share) pairs, most binding
    first; the message lists them in words (joint speed, torque envelope, friction, …).
    """

    def __init__(self, message: str, binding: tuple[tuple[str, float], ...] = ()) -> None:
        self.binding = binding
        super().__init__(message)

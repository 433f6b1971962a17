"""Typed errors of `sim`: every user-facing failure is a `SimError` with a one-line message."""

from __future__ import annotations


class SimError(Exception):
    """Base class of every error raised by `sim` (the CLI prints it as one line, exit 2)."""


class SimSetupError(SimError):
    """The robot cannot be turned into a simulation model (no foot geom, bad servo figures, …)."""


class SimConfigError(SimError, ValueError):
    """A bad simulation setting: cycles, stream rate, latency, friction, payload, strength, …."""


class SimDivergedError(SimError):
    """The physics produced NaN/inf (an unstable model or absurd gains)."""


class RenderError(SimError):
    """Offscreen rendering failed (no EGL/OSMesa context) or the video could not be written."""


class ReportError(SimError):
    """A plot or the HTML report could not be produced or written."""

"""Typed errors of `sim.path` (all `SimError`s, so the CLI prints them as one line, exit 2)."""

from __future__ import annotations

from sim.errors import SimConfigError


class PathSpecError(SimConfigError):
    """A `--path` spec (or waypoint file) that cannot be turned into a path: the message names
    the option or file and what to write instead."""

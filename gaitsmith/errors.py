"""Typed errors of the `gaitsmith` command line itself (bad options, unusable output paths).

`gaitsmith.cli.main` prints every `CliError` as one line and exits with code 2, like a usage
error: the messages name the option at fault and what it accepts.
"""

from __future__ import annotations


class CliError(Exception):
    """Base class of the command line's own user-facing errors."""


class OptionError(CliError, ValueError):
    """An option value outside its accepted range (checked before any expensive work)."""


class OutputError(CliError):
    """An output path that cannot be written (missing/read-only folder, full disk)."""

"""Typed errors of the `robots` package: every bad input names the file and field at fault."""

from __future__ import annotations


class RobotsError(Exception):
    """Base class of every error raised by `robots`."""


class RobotConfigError(RobotsError):
    """A robot folder (robot.xml + robot.toml) or the servo catalogue is missing or inconsistent."""

    def __init__(self, file: str, field: str, problem: str) -> None:
        self.file = file
        self.field = field
        self.problem = problem
        super().__init__(f"{file}: {field}: {problem}")


class GaitFileError(RobotsError):
    """A gait file is malformed, inconsistent, or does not match the robot it is used with."""

    def __init__(self, file: str, field: str, problem: str) -> None:
        self.file = file
        self.field = field
        self.problem = problem
        super().__init__(f"{file}: {field}: {problem}")


class OutputWriteError(RobotsError, OSError):
    """An output file cannot be written (missing or read-only folder, full disk, …).

    Also an `OSError`, so code that caught the plain `OSError` of a failed write still does.
    """


class LibraryFileError(GaitFileError):
    """A gait-library file is malformed, inconsistent, or does not match the robot it is used
    with (a `GaitFileError`, so code that refuses bad gait files refuses bad libraries too)."""

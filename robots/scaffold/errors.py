"""Errors of `robots init`: one line naming the model file, the element at fault and what to do."""

from __future__ import annotations

from robots.errors import RobotsError


class ScaffoldError(RobotsError):
    """The model cannot be turned into a robot folder without a decision only the user can make."""

    def __init__(self, file: str, field: str, problem: str) -> None:
        self.file = file
        self.field = field
        self.problem = problem
        super().__init__(f"{file}: {field}: {problem}")

"""Run a `gaitsmith` command up to its expensive call and return that call's keyword
arguments: the call is replaced by a stand-in that records them and raises `Started`."""

from __future__ import annotations

from typing import Any

import pytest

from gaitsmith.cli import main


class Started(Exception):
    """Raised by the stand-in of the expensive call (the NLP build, the search, the sweep)."""


def captured_kwargs(monkeypatch: pytest.MonkeyPatch, owner: object, name: str,
                    argv: list[str]) -> dict[str, Any]:
    """`owner.name` replaced by a recorder while `gaitsmith argv` runs; its keyword arguments."""
    seen: dict[str, Any] = {}

    def record(*args: Any, **kwargs: Any) -> Any:
        seen.update(kwargs)
        raise Started

    monkeypatch.setattr(owner, name, record)
    with pytest.raises(Started):
        main(argv)
    return seen

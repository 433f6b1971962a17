"""`planner.robust_plan.replans`: the variants of one command, written as the nominal file is."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import pytest

import robots
from planner import robust_plan
from planner.errors import PlannerConfigError
from robots.gait import ENTRY_CYCLES_KEY


@dataclass
class _Result:
    status: str = "Solve_Succeeded"


class _Planner:
    """Stands in for `GaitPlanner`: records what each variant was planned and written with."""

    made: ClassVar[list[tuple[int, float, dict[str, Any] | None]]] = []

    def __init__(self, robot: robots.Robot, n_knots: int, options: Any = None) -> None:
        self.n_knots = n_knots
        self.speed = 0.0

    def solve(self, schedule: Any, speed_m_s: float, warm_start: bool = True) -> _Result:
        assert not warm_start, "every variant is planned cold"
        self.speed = speed_m_s
        return _Result()

    def to_gait(self, result: _Result, label: str,
                extra_metadata: dict[str, Any] | None = None) -> Any:
        _Planner.made.append((self.n_knots, self.speed, extra_metadata))
        return label


def test_every_variant_is_written_with_the_nominal_files_metadata(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The knife-edge check judged humanoid20's re-plans without the nominal's 3 entry cycles
    (session 28): a variant must start as the plan it stands beside."""
    monkeypatch.setattr(robust_plan, "GaitPlanner", _Planner)
    _Planner.made = []
    meta = {ENTRY_CYCLES_KEY: 3, "stance_compliance": {"lambda": 0.61}}
    bot = robots.load("quad12")
    out = robust_plan.replans(bot, None, "trot", 0.2, 20, extra_metadata=meta)  # type: ignore[arg-type]
    assert [v.label for v in out] == ["speed -1 %", "speed +1 %", "N 16", "N 24"]
    assert [(n, round(v, 6)) for n, v, _ in _Planner.made] == [
        (20, 0.198), (20, 0.202), (16, 0.2), (24, 0.2)]
    assert all(m == meta for _, _, m in _Planner.made)


def test_speed_fractions_are_bounded() -> None:
    with pytest.raises(PlannerConfigError, match="±50 %"):
        robust_plan.replans(robots.load("quad12"), None, "trot", 0.2, 20,  # type: ignore[arg-type]
                            speed_fractions=(0.6,))

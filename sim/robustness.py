"""Robustness sweep: how often does the gait still pass when the world is not the nominal one?

One-at-a-time perturbations around the nominal build (each run changes one factor): ground
friction µ, payload on the body, stream latency, servo strength. The answer is the fraction of
perturbed runs that pass plus the table of runs. One-at-a-time keeps the cost linear in the number
of levels; a factor that fails alone will not be rescued by the others.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robots.gait import Gait
from robots.robot import Robot
from sim.validate import PassCriteria, validate

DEFAULT_FRICTIONS = (0.4, 0.6, 1.2)
DEFAULT_PAYLOAD_FRACTIONS = (0.1, 0.2)  # of the robot's mass
DEFAULT_LATENCIES_S = (0.01, 0.02, 0.04)
DEFAULT_STRENGTHS = (0.8, 0.9)


@dataclass(frozen=True)
class SweepRun:
    factor: str  # "friction", "payload_kg", "latency_s", "strength"
    value: float
    passed: bool
    reasons: tuple[str, ...]
    achieved_speed_m_s: float
    peak_torque_fraction: float
    fell: bool


@dataclass(frozen=True)
class RobustnessResult:
    runs: tuple[SweepRun, ...]

    @property
    def pass_fraction(self) -> float:
        return sum(r.passed for r in self.runs) / len(self.runs) if self.runs else 0.0

    def to_dict(self) -> dict[str, object]:
        return {
            "pass_fraction": self.pass_fraction,
            "runs": [
                {
                    "factor": r.factor,
                    "value": r.value,
                    "passed": r.passed,
                    "reasons": list(r.reasons),
                    "achieved_speed_m_s": r.achieved_speed_m_s,
                    "peak_torque_fraction": r.peak_torque_fraction,
                    "fell": r.fell,
                }
                for r in self.runs
            ],
        }


def robustness_sweep(
    gait: Gait,
    robot: Robot,
    cycles: int = 10,
    *,
    frictions: tuple[float, ...] = DEFAULT_FRICTIONS,
    payloads_kg: tuple[float, ...] | None = None,
    latencies_s: tuple[float, ...] = DEFAULT_LATENCIES_S,
    strengths: tuple[float, ...] = DEFAULT_STRENGTHS,
    rate_hz: float = 100.0,
    criteria: PassCriteria = PassCriteria(),
    progress: Callable[[int, int], None] | None = None,
) -> RobustnessResult:
    """Validate `gait` under each perturbation in turn; see the module docstring."""
    if payloads_kg is None:
        payloads_kg = tuple(round(f * robot.mass_kg, 3) for f in DEFAULT_PAYLOAD_FRACTIONS)
    plan: list[tuple[str, float, dict[str, Any]]] = []
    plan += [("friction", f, {"friction": f}) for f in frictions]
    plan += [("payload_kg", p, {"payload_kg": p}) for p in payloads_kg]
    plan += [("latency_s", lat, {"latency_s": lat}) for lat in latencies_s]
    plan += [("strength", s, {"strength": s}) for s in strengths]
    runs: list[SweepRun] = []
    for i, (factor, value, kwargs) in enumerate(plan):
        res = validate(
            gait, robot, cycles, rate_hz=rate_hz, criteria=criteria, keep_trajectory=False, **kwargs
        )  # type: ignore[arg-type]
        m = res.metrics
        runs.append(
            SweepRun(
                factor,
                float(value),
                res.passed,
                res.reasons,
                m.achieved_speed_m_s,
                m.peak_torque_fraction,
                m.fell,
            )
        )
        if progress is not None:
            progress(i + 1, len(plan))
    return RobustnessResult(tuple(runs))

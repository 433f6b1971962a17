"""Robustness sweep: how often does the gait still pass when the world is not the nominal one?

One-at-a-time perturbations around the nominal build (each run changes one factor): ground
friction µ, payload on the body, stream latency, servo strength. The answer is the fraction of
perturbed runs that pass plus the table of runs. One-at-a-time keeps the cost linear in the number
of levels; a factor that fails alone will not be rescued by the others.

`knife_edge_check` asks a narrower question: does the verdict survive what should not matter —
a few ms of stream latency, and plans of the same command that differ only by rounding-sized
changes (±1 % speed, N ± 4 knots; the caller re-plans them, `planner.robust_plan`)? A plan that
passes alone but fails one of those is on a knife edge (`KnifeEdgeResult.verdict`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robots.gait import Gait
from robots.robot import Robot
from robots.servo_params import ServoSetting
from sim.attitude_loop import AttitudeSettings
from sim.errors import SimConfigError
from sim.validate import PassCriteria, validate

DEFAULT_FRICTIONS = (0.4, 0.6, 1.2)
DEFAULT_PAYLOAD_FRACTIONS = (0.1, 0.2)  # of the robot's mass
DEFAULT_LATENCIES_S = (0.01, 0.02, 0.04)
DEFAULT_STRENGTHS = (0.8, 0.9)
#: stream latencies of the knife-edge check [s]: a USB–serial adapter and bus add a few ms
KNIFE_EDGE_LATENCIES_S = (0.0, 0.005, 0.01)


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
    attitude: AttitudeSettings | None = None,
) -> RobustnessResult:
    """Validate `gait` under each perturbation in turn; see the module docstring (`attitude`:
    every run closed loop with that IMU feedback)."""
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
            gait, robot, cycles, rate_hz=rate_hz, criteria=criteria, keep_trajectory=False,
            attitude=attitude, **kwargs,
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


@dataclass(frozen=True)
class KnifeEdgeRun:
    """One run of the knife-edge check: which plan (`plan`: "nominal" or the re-plan's label,
    e.g. "speed +1 %", "N 20") at which stream latency, and its verdict."""

    plan: str
    latency_s: float
    passed: bool
    fell: bool
    fall_time_s: float | None
    heading_deg: float
    peak_torque_fraction: float
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class KnifeEdgeResult:
    runs: tuple[KnifeEdgeRun, ...]

    @property
    def nominal_passed(self) -> bool:
        return any(r.plan == "nominal" and r.latency_s == 0.0 and r.passed for r in self.runs)

    @property
    def robust(self) -> bool:
        """Every run passed."""
        return bool(self.runs) and all(r.passed for r in self.runs)

    @property
    def failed(self) -> tuple[KnifeEdgeRun, ...]:
        return tuple(r for r in self.runs if not r.passed)

    @property
    def verdict(self) -> str:
        """"robust", "knife edge" (the nominal run passes, a perturbed one fails) or "fails"."""
        if self.robust:
            return "robust"
        return "knife edge" if self.nominal_passed else "fails"

    def summary(self) -> str:
        passed = sum(r.passed for r in self.runs)
        text = f"{self.verdict}: {passed} of {len(self.runs)} runs pass"
        if self.failed:
            text += "; failed: " + ", ".join(
                f"{r.plan} at {r.latency_s * 1000:g} ms" for r in self.failed
            )
        return text

    def to_dict(self) -> dict[str, object]:
        return {
            "verdict": self.verdict,
            "runs": [
                {
                    "plan": r.plan,
                    "latency_s": r.latency_s,
                    "passed": r.passed,
                    "fell": r.fell,
                    "fall_time_s": r.fall_time_s,
                    "heading_deg": r.heading_deg,
                    "peak_torque_fraction": r.peak_torque_fraction,
                    "reasons": list(r.reasons),
                }
                for r in self.runs
            ],
        }


def knife_edge_check(
    nominal: Gait,
    robot: Robot,
    replans: Sequence[tuple[str, Gait | None]] = (),
    cycles: int = 20,
    *,
    latencies_s: Sequence[float] = KNIFE_EDGE_LATENCIES_S,
    criteria: PassCriteria = PassCriteria(),
    progress: Callable[[int, int], None] | None = None,
    servo_settings: Sequence[ServoSetting] | None = None,
    attitude: AttitudeSettings | None = None,
) -> KnifeEdgeResult:
    """The nominal gait at every latency in `latencies_s`, and each re-planned variant in
    `replans` (label, gait) at the first latency; see the module docstring. A re-plan without a
    gait (None: the planner found none) counts as a failed run. `servo_settings` (identified
    servos, `gaitsmith plan --servo-params`) are simulated in every run, as `validate` does for
    the nominal verdict, and so is `attitude` (closed-loop IMU feedback, `sim.attitude_loop`)."""
    if not latencies_s:
        raise SimConfigError("the knife-edge check needs at least one latency")
    todo: list[tuple[str, Gait | None, float]] = [
        ("nominal", nominal, float(lat)) for lat in latencies_s
    ]
    todo += [(label, gait, float(latencies_s[0])) for label, gait in replans]
    runs = []
    for i, (label, gait, latency) in enumerate(todo):
        if gait is None:
            runs.append(KnifeEdgeRun(label, latency, False, False, None, math.nan, math.nan,
                                     ("re-plan: no feasible gait",)))
            continue
        res = validate(gait, robot, cycles, latency_s=latency, criteria=criteria,
                       keep_trajectory=False, servo_settings=servo_settings,
                       attitude=attitude)
        m = res.metrics
        runs.append(
            KnifeEdgeRun(
                label,
                latency,
                res.passed,
                m.fell,
                m.fall_time_s,
                math.degrees(m.heading_change_rad),
                m.peak_torque_fraction,
                res.reasons,
            )
        )
        if progress is not None:
            progress(i + 1, len(todo))
    return KnifeEdgeResult(tuple(runs))

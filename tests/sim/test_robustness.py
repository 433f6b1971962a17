"""The knife-edge check's verdict (`sim.robustness.knife_edge_check`) from its runs."""

from __future__ import annotations

import math

import pytest

import robots
from sim.errors import SimConfigError
from sim.robustness import KnifeEdgeResult, KnifeEdgeRun, knife_edge_check


def _run(plan: str, latency_s: float, passed: bool) -> KnifeEdgeRun:
    return KnifeEdgeRun(plan, latency_s, passed, not passed, None if passed else 4.9, 0.0, 0.4,
                        () if passed else ("no fall: fell at t = 4.90 s",))


def test_verdict_robust_knife_edge_or_fails() -> None:
    ok = [_run("nominal", 0.0, True), _run("nominal", 0.005, True), _run("N 16", 0.0, True)]
    assert KnifeEdgeResult(tuple(ok)).verdict == "robust"
    edge = KnifeEdgeResult((*ok[:2], _run("N 16", 0.0, False)))
    assert edge.verdict == "knife edge" and edge.nominal_passed
    assert edge.summary() == "knife edge: 2 of 3 runs pass; failed: N 16 at 0 ms"
    down = KnifeEdgeResult((_run("nominal", 0.0, False), *ok[1:]))
    assert down.verdict == "fails" and not down.robust
    assert KnifeEdgeResult(()).verdict == "fails"
    assert edge.to_dict()["verdict"] == "knife edge"


def test_a_missing_replan_counts_as_a_failed_run_and_latencies_are_required() -> None:
    bot = robots.load("biped")
    from planner.library import stand_gait

    stand = stand_gait(bot, 0.5)
    with pytest.raises(SimConfigError, match="latency"):
        knife_edge_check(stand, bot, latencies_s=())
    result = knife_edge_check(stand, bot, [("N 8", None)], cycles=3, latencies_s=(0.0,))
    assert [r.plan for r in result.runs] == ["nominal", "N 8"]
    missing = result.runs[1]
    assert not missing.passed and math.isnan(missing.heading_deg)
    assert result.verdict in {"knife edge", "fails"}


def test_every_run_is_simulated_with_the_identified_servos(monkeypatch: pytest.MonkeyPatch) -> None:
    """`plan --servo-params --knife-edge`: the knife-edge runs use the same servos as --simulate."""
    import sim.robustness as robustness
    from planner.library import stand_gait
    from robots.servo_params import ServoSetting

    bot = robots.load("biped")
    stand = stand_gait(bot, 0.5)
    seen: list[object] = []
    real = robustness.validate

    def spy(*args: object, **kwargs: object) -> object:
        seen.append(kwargs.get("servo_settings"))
        return real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(robustness, "validate", spy)
    settings = (ServoSetting(gain_scale=0.5),) * len(bot.joints)
    knife_edge_check(stand, bot, [("N 8", stand)], cycles=3, latencies_s=(0.0, 0.005),
                     servo_settings=settings)
    assert seen == [settings, settings, settings]

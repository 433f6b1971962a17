"""The watchdog's temperature trend against the gait's predicted heating, the virtual servo's
heating-rate fault, and pre-flight's supply-voltage margin."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hardware.bus.servo_bus import ServoStatus
from hardware.bus.virtual import FaultPlan
from hardware.play.errors import PreflightError
from hardware.play.player import PlayerConfig
from hardware.play.preflight import check_supply
from hardware.play.thermal_watch import (
    HeatingTrend,
    PredictedHeating,
    TrendLimits,
    predicted_heating,
)
from hardware.play.watchdog import StopReason, Watchdog, WatchdogLimits
from robots.gait import Gait
from robots.servo import servo_model
from robots.thermal import thermal_model
from tests.hardware.play.player_rig import make_rig

STS = servo_model("STS3215_7V4")


def _with_torques(gait: Gait, torque_nm: float) -> Gait:
    return replace(gait, joint_torques_nm=np.full((gait.n_knots, gait.knots_rad.shape[1]),
                                                  torque_nm))


def _prediction(power_w: float) -> PredictedHeating:
    return PredictedHeating("knee", power_w, thermal_model(STS), "plan")


def _run_trend(trend: HeatingTrend, rate_k_per_s: float, seconds: float, t0_c: float = 30.0
               ) -> tuple[list[str], tuple[float, str] | None]:
    warnings = []
    for t in np.arange(0.0, seconds, 0.5):
        temp = float(round(t0_c + rate_k_per_s * t))  # the register counts whole degrees
        v = trend.feed(1, float(t), temp, "servo 1 (knee)")
        if v.warning:
            warnings.append(v.warning)
        if v.stop:
            return warnings, (temp, v.stop)
    return warnings, None


def test_heating_as_predicted_is_not_flagged() -> None:
    pred = _prediction(6.0)  # 11.7 K steady, 3.5 K/min at the start
    trend = HeatingTrend({1: pred}, {1: 65.0})
    rate = pred.steady_rise_k / pred.model.tau_th_s
    warnings, stop = _run_trend(trend, rate, 120.0)
    assert warnings == [] and stop is None


def test_heating_faster_than_predicted_warns_then_stops_before_the_limit() -> None:
    trend = HeatingTrend({1: _prediction(1.0)}, {1: 65.0})
    warnings, stop = _run_trend(trend, 0.2, 600.0)  # 12 K/min against ≈0.6 predicted
    assert len(warnings) == 1 and "faster than predicted" in warnings[0]
    assert stop is not None
    temp, message = stop
    assert temp < 65.0 - 0.2 * 60  # stopped over a minute before reaching the limit
    assert "12.0 K/min" in message and "65 °C in" in message


def test_trend_needs_a_span_before_judging() -> None:
    trend = HeatingTrend({1: _prediction(0.0)}, {1: 65.0}, TrendLimits(min_span_s=30.0))
    for t in range(0, 30, 5):
        assert trend.feed(1, float(t), 30.0 + t, "s").warning is None  # 60 K/min, but too early
    assert trend.feed(1, 30.0, 60.0, "s").warning is not None


def test_trend_limits_are_checked() -> None:
    with pytest.raises(ValueError, match="min_span_s"):
        TrendLimits(window_s=10.0, min_span_s=20.0)
    with pytest.raises(ValueError, match="rate_factor"):
        TrendLimits(rate_factor=float("nan"))


def test_prediction_comes_from_the_validation_block_else_the_plan(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    assert predicted_heating(rig.robot, rig.gait) == {}  # bring-up gait: nothing to go by
    planned = _with_torques(rig.gait, 0.5)
    pred = predicted_heating(rig.robot, planned)
    assert set(pred) == {j.bus_id for j in rig.robot.joints}
    one = pred[rig.robot.joints[0].bus_id]
    assert one.source == "plan"
    assert one.mean_power_w == pytest.approx(float(thermal_model(STS).power_w(0.5)))
    name = rig.robot.joints[0].name
    validated = planned.with_validation(
        {"passed": True, "thermal": {"joints": [{"joint": name, "mean_power_w": 2.5}]}}
    )
    pred = predicted_heating(rig.robot, validated)
    assert pred[rig.robot.joints[0].bus_id].source == "sim"
    assert pred[rig.robot.joints[0].bus_id].mean_power_w == 2.5
    assert pred[rig.robot.joints[1].bus_id].source == "plan"


def test_virtual_heating_fault_climbs_while_torque_is_on_and_trips_overheat(clock) -> None:  # type: ignore[no-untyped-def]
    from hardware.bus.virtual import VirtualServoBus

    vbus = VirtualServoBus({1: STS}, "feetech_sts", clock=clock,
                           faults=FaultPlan(heating_k_per_s={1: 1.0}))
    bus = vbus.connect()
    clock.advance(10.0)
    assert bus.read_status([1])[1].temperature_c == 30.0  # torque off: no heat
    bus.torque_on([1])
    clock.advance(20.0)
    st = bus.read_status([1])[1]
    assert st.temperature_c == 50.0 and not st.error_flags
    clock.advance(25.0)
    assert "overheat" in bus.read_status([1])[1].error_flags  # past 70 °C: the firmware's flag
    with pytest.raises(ValueError, match="heating_k_per_s"):
        FaultPlan(heating_k_per_s={1: float("inf")})


def test_player_stops_a_servo_heating_faster_than_predicted_before_it_overheats(
    tmp_path: Path,
) -> None:
    rig = make_rig(tmp_path)
    rig.gait = _with_torques(rig.gait, 0.5)  # predicted ≈ 0.8 K/min on every servo
    hot, warm = rig.robot.joints[2], rig.robot.joints[5]
    # hot: 12 K/min (a stalled knee); warm: 0.6 K/min, as predicted
    rig.vbus.faults = FaultPlan(heating_k_per_s={hot.bus_id: 0.2, warm.bus_id: 0.01})
    config = PlayerConfig(rate_hz=20.0, cycles=500, ramp_s=0.5, force=True)
    result, _ = rig.play(config)
    assert result.stop.reason is StopReason.OVER_TEMPERATURE and result.exit_code == 5
    assert result.stop.servo_id == hot.bus_id
    assert "faster than predicted" in result.stop.message
    limit = hot.servo.max_temperature_c - WatchdogLimits().temperature_margin_c
    temp_at_stop = 30.0 + 0.2 * (result.stop.t_s + 1.0)  # + the pre-flight second, generously
    assert temp_at_stop < limit - 10.0  # well before the watchdog's absolute limit
    heating = [w for w in result.warnings if "heating" in w]
    assert len(heating) == 1 and f"servo {hot.bus_id}" in heating[0]


def test_watchdog_without_prediction_keeps_its_absolute_limits() -> None:
    wd = Watchdog(WatchdogLimits(), {1: STS}, {1: "knee"})
    assert wd.heating is None
    st = ServoStatus(1, 0.0, 7.4, 66.0, (), 0)
    stop = wd.status({1: st}, 1, 1.0)
    assert stop is not None and stop.reason is StopReason.OVER_TEMPERATURE


def test_supply_margin_reported_warned_and_refused(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    gait = _with_torques(rig.gait, 1.4)  # 73 % of stall at 7.4 V
    line, warnings = check_supply(rig.robot, gait, 7.4, "--supply-v", force=False)
    assert "at 7.40 V the peak" in line and "73 % of stall" in line and warnings == []
    line, warnings = check_supply(rig.robot, gait, 6.5, "measured", force=False)
    assert "83 % of stall (73 % at 7.40 V nominal)" in line
    assert len(warnings) == 1 and "over the 80 %" in warnings[0]
    strong = _with_torques(rig.gait, 1.8)
    with pytest.raises(PreflightError, match="more than the servo can give"):
        check_supply(rig.robot, strong, 6.0, "measured", force=False)
    _, warnings = check_supply(rig.robot, strong, 6.0, "measured", force=True)
    assert "because of --force" in warnings[-1]
    with pytest.raises(PreflightError, match=r"outside the servos' range \[6, 8.4\] V"):
        check_supply(rig.robot, gait, 9.0, "--supply-v", force=False)


def test_player_measures_the_supply_at_preflight(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    rig.gait = _with_torques(rig.gait, 1.4)
    rig.vbus.faults = FaultPlan(voltage_sag_v=0.6)  # the pack at 6.8 V
    result, _ = rig.play(PlayerConfig(cycles=1, ramp_s=0.5, force=True))
    assert result.stop.reason is StopReason.COMPLETED
    assert result.supply_margin is not None
    assert "measured, lowest reading servo" in result.supply_margin
    assert "at 6.80 V the peak" in result.supply_margin
    result, _ = rig.play(PlayerConfig(cycles=1, ramp_s=0.5, force=True, supply_v=7.4))
    assert "(--supply-v)" in (result.supply_margin or "")


def test_running_slope_is_the_least_squares_slope() -> None:
    trend = HeatingTrend({}, {1: 65.0}, TrendLimits(window_s=20.0, min_span_s=5.0))
    rng = np.random.default_rng(1)
    ts = np.arange(0.0, 1000.0, 0.1) + 1e4  # far from zero, and rebased every 200 s
    ys = np.round(30.0 + 0.05 * (ts - ts[0]) + rng.normal(0, 0.3, ts.size))
    for t, y in zip(ts, ys, strict=True):
        trend.feed(1, float(t), float(y), "s")
    keep = ts >= ts[-1] - 20.0
    expected = np.polyfit(ts[keep], ys[keep], 1)[0]
    assert trend.slope_k_per_s(1) == pytest.approx(expected, rel=1e-6)


def test_preflight_warns_of_a_servo_predicted_to_reach_its_limit_within_the_run(
    tmp_path: Path,
) -> None:
    from hardware.play.preflight import check_heating

    rig = make_rig(tmp_path)
    j = rig.robot.joints[2]
    statuses = {i: ServoStatus(i, 0.0, 7.4, 30.0, (), 0) for i in rig.ids}
    statuses[j.bus_id] = ServoStatus(j.bus_id, 0.0, 7.4, 50.0, (), 0)  # already warm
    hot = {j.bus_id: _prediction(25.0)}  # 52 K steady: over the 65 °C stop from a 30 °C room
    (w,) = check_heating(rig.robot, hot, statuses, WatchdogLimits(), run_s=None)
    assert f"servo {j.bus_id} ({j.name}): predicted to reach 65 °C after" in w
    t_min = float(w.split("after ")[1].split(" min")[0])
    assert 0.0 < t_min < 10.0
    assert check_heating(rig.robot, hot, statuses, WatchdogLimits(), run_s=t_min * 60 - 30) == []
    cool = {j.bus_id: _prediction(2.0)}
    assert check_heating(rig.robot, cool, statuses, WatchdogLimits(), run_s=None) == []


def test_supply_margin_uses_the_simulated_peaks_too(tmp_path: Path) -> None:
    rig = make_rig(tmp_path)
    names = rig.robot.joint_names
    sim = {"supply": {"supply_v": 7.4, "joints": [
        {"joint": n, "peak_torque_nm": 1.7 if k == 4 else 0.3} for k, n in enumerate(names)
    ]}}
    gait = _with_torques(rig.gait, 0.5).with_validation(sim)  # planned 0.5, simulated 1.7
    line, _ = check_supply(rig.robot, gait, 7.4, "--supply-v", force=False)
    assert f"peak {names[4]} torque is 89 % of stall" in line
    with pytest.raises(PreflightError, match="more than the servo can give"):
        check_supply(rig.robot, gait, 6.5, "measured", force=False)
    line, _ = check_supply(rig.robot, rig.gait, 7.4, "measured", force=False)
    assert "no planned or simulated torques" in line

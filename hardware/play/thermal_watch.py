"""The servos' live temperature trend against the gait's predicted heating.

Prediction (per servo, `predicted_heating`): the cycle-mean winding heat P̄ of its joint — from
the gait's validation block (`thermal`, written by `gaitsmith simulate --write-validation` from
the MuJoCo rollout's torques) or, failing that, from the planned torques the gait file carries
(`joint_torques_nm`, one sample per knot) — through the servo's first-order thermal model
(`robots.thermal`; no mujoco here). From the first temperature reading T₀ (taken as ambient),
the model's heating rate at the present temperature T is

    Ṫ_pred = max(0, P̄·R_th − (T − T₀)) / τ_th.

Measured (`HeatingTrend.feed`): the least-squares slope Ṫ of the servo's temperature readings
over the last `window_s` seconds (judged once they span `min_span_s`: the register counts whole
degrees, so a short window is all quantisation). Rules, per servo:

- heating faster than predicted: Ṫ > `rate_factor`·Ṫ_pred + `rate_margin_k_per_min` → one
  warning (the servo, both rates, and when it would reach its stop temperature at this rate);
- stop before the limit: a servo heating faster than predicted whose temperature would reach
  its stop temperature (max_temperature_c − `WatchdogLimits.temperature_margin_c`) within
  `lead_s` at the measured rate → OVER_TEMPERATURE, before the watchdog's absolute limit (or
  the servo's own shutdown) is hit.

The gait is played at `speed_scale`; the prediction is at the gait's own speed (a slower
playback has lower heating, so the comparison errs on the side of a warning).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from robots.gait import Gait
from robots.robot import Robot
from robots.thermal import ThermalModel, has_thermal_data, thermal_model

REBASE_WINDOWS = 10.0  # recompute the running sums from the window this often (in windows)


@dataclass(frozen=True)
class TrendLimits:
    """When a temperature trend is judged, and how much faster than predicted is too fast."""

    window_s: float = 60.0
    min_span_s: float = 30.0
    rate_factor: float = 2.0
    rate_margin_k_per_min: float = 1.0
    lead_s: float = 120.0

    def __post_init__(self) -> None:
        for name in ("window_s", "min_span_s", "rate_factor", "lead_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"TrendLimits.{name} must be a positive number, got {v!r}")
        if not (math.isfinite(self.rate_margin_k_per_min) and self.rate_margin_k_per_min >= 0):
            raise ValueError("TrendLimits.rate_margin_k_per_min must be >= 0")
        if self.min_span_s > self.window_s:
            raise ValueError("TrendLimits.min_span_s must not exceed window_s")


@dataclass(frozen=True)
class PredictedHeating:
    """One servo's predicted heating: mean winding heat [W] and its thermal model."""

    joint: str
    mean_power_w: float
    model: ThermalModel
    source: str  # "sim" (validation block) or "plan" (planned torques)

    @property
    def steady_rise_k(self) -> float:
        return self.model.steady_rise_k(self.mean_power_w)

    def rate_k_per_s(self, rise_k: float) -> float:
        """Ṫ_pred at a rise of `rise_k` above the first reading."""
        return max(0.0, self.steady_rise_k - max(0.0, rise_k)) / self.model.tau_th_s


def _validation_powers(gait: Gait) -> dict[str, float]:
    block: Any = (gait.validation or {}).get("thermal")
    out: dict[str, float] = {}
    if not isinstance(block, dict) or not isinstance(block.get("joints"), list):
        return out
    for j in block["joints"]:
        if isinstance(j, dict) and isinstance(j.get("joint"), str):
            p = j.get("mean_power_w")
            if isinstance(p, (int, float)) and not isinstance(p, bool) and math.isfinite(p) \
                    and p >= 0:
                out[j["joint"]] = float(p)
    return out


def predicted_heating(robot: Robot, gait: Gait) -> dict[int, PredictedHeating]:
    """{bus id: prediction} for every joint whose servo has thermal data and whose heating the
    gait says (validation block first, else its planned torques); others are not predicted."""
    sim_p = _validation_powers(gait)
    planned = gait.joint_torques_nm
    out: dict[int, PredictedHeating] = {}
    for j, joint in enumerate(robot.joints):
        if not has_thermal_data(joint.servo):
            continue
        model = thermal_model(joint.servo)
        if joint.name in sim_p:
            out[joint.bus_id] = PredictedHeating(joint.name, sim_p[joint.name], model, "sim")
        elif planned is not None and planned.shape[1] == robot.dof:
            p = float(np.mean(model.power_w(planned[:, j])))
            out[joint.bus_id] = PredictedHeating(joint.name, p, model, "plan")
    return out


@dataclass(frozen=True)
class TrendVerdict:
    """What one reading of one servo means: a warning to show and/or a reason to stop."""

    warning: str | None = None
    stop: str | None = None


class HeatingTrend:
    """Per-servo temperature history and the rules of the module docstring."""

    def __init__(
        self,
        predictions: Mapping[int, PredictedHeating],
        stop_temperature_c: Mapping[int, float],
        limits: TrendLimits | None = None,
    ) -> None:
        self.predictions = dict(predictions)
        self.stop_temperature_c = dict(stop_temperature_c)
        self.limits = limits or TrendLimits()
        self._first: dict[int, tuple[float, float]] = {}  # (time, temperature) of the first
        self._history: dict[int, deque[tuple[float, float]]] = {}
        self._sums: dict[int, list[float]] = {}  # n, Σt, Σy, Σt², Σty over the window
        self._sums_origin: dict[int, float] = {}  # time origin of the sums (after a rebase)
        self.warned: set[int] = set()

    def slope_k_per_s(self, servo_id: int) -> float | None:
        """Least-squares slope of the window's readings, or None while they span too little.
        O(1) per reading (running sums; times relative to the first reading, temperatures to
        the first temperature, so the sums stay well conditioned)."""
        h = self._history.get(servo_id)
        if not h or h[-1][0] - h[0][0] < self.limits.min_span_s:
            return None
        n, st, sy, stt, sty = self._sums[servo_id]
        den = n * stt - st * st
        return (n * sty - st * sy) / den if den > 0 else None

    def _first_t(self, servo_id: int) -> float:
        return self._sums_origin.get(servo_id, self._first[servo_id][0])

    def _rebase(self, servo_id: int, first_c: float) -> None:
        """Move the sums' time origin to the window's oldest reading and recompute them (once
        every `REBASE_WINDOWS` windows: a run of hours keeps its slope exact)."""
        h = self._history[servo_id]
        t0 = h[0][0]
        self._sums_origin[servo_id] = t0
        self._sums[servo_id] = [0.0] * 5
        for t, y in h:
            self._accumulate(servo_id, t - t0, y - first_c, 1.0)

    def _add(self, servo_id: int, t: float, y: float, sign: float) -> None:
        self._accumulate(servo_id, t - self._first_t(servo_id), y - self._first[servo_id][1],
                         sign)

    def _accumulate(self, servo_id: int, dt: float, dy: float, sign: float) -> None:
        s = self._sums[servo_id]
        for k, v in enumerate((1.0, dt, dy, dt * dt, dt * dy)):
            s[k] += sign * v

    def feed(self, servo_id: int, t_s: float, temperature_c: float, who: str) -> TrendVerdict:
        """One temperature reading; returns the warning (first time only) and/or stop."""
        lim = self.limits
        first = self._first.setdefault(servo_id, (t_s, temperature_c))[1]
        h = self._history.setdefault(servo_id, deque())
        self._sums.setdefault(servo_id, [0.0] * 5)
        h.append((t_s, temperature_c))
        self._add(servo_id, t_s, temperature_c, 1.0)
        while h and h[0][0] < t_s - lim.window_s:
            self._add(servo_id, *h.popleft(), -1.0)
        if t_s - self._first_t(servo_id) > REBASE_WINDOWS * lim.window_s:
            self._rebase(servo_id, first)
        slope = self.slope_k_per_s(servo_id)
        if slope is None or slope <= 0.0:
            return TrendVerdict()
        pred = self.predictions.get(servo_id)
        predicted = pred.rate_k_per_s(temperature_c - first) if pred is not None else 0.0
        allowed = lim.rate_factor * predicted + lim.rate_margin_k_per_min / 60.0
        if slope <= allowed:
            return TrendVerdict()
        t_stop = self.stop_temperature_c.get(servo_id, math.inf)
        eta_s = (t_stop - temperature_c) / slope
        what = "no prediction" if pred is None else (
            f"predicted {predicted * 60:.2f} K/min ({pred.source})"
        )
        line = (
            f"{who}: heating {slope * 60:.1f} K/min at {temperature_c:.0f} °C, faster than "
            f"{what}; at this rate {t_stop:.0f} °C in {max(0.0, eta_s) / 60:.1f} min"
        )
        warning = None
        if servo_id not in self.warned:
            self.warned.add(servo_id)
            warning = f"WARNING: {line}"
        stop = line + f" (stopping {lim.lead_s:.0f} s ahead)" if eta_s <= lim.lead_s else None
        return TrendVerdict(warning, stop)

"""Predicted servo heating of a simulated gait: per joint, over a walking bout.

From the MuJoCo rollout's servo output torques (`Trajectory.torque_nm`) over the steady cycles
(those the verdict judges, `sim.metrics.steady_mask`), each joint's cycle-mean winding heat P̄
(`robots.thermal`: I ∝ |τ|, P = I²R) drives its servo's first-order thermal model for a bout
(default 10 minutes from a 25 °C ambient): the temperature after the bout, the steady
temperature, and the minutes until the servo's `max_temperature_c` is reached (None: never).
Joints whose servo has no published stall current are listed, not guessed.

`ThermalPrediction.to_dict` is what `gaitsmith simulate --write-validation` stores under the
validation block's `thermal` key; gaitsmith-play's watchdog compares the servos' temperature
trend against it (hardware.play.thermal_watch).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from robots.robot import Robot
from robots.thermal import (
    DEFAULT_AMBIENT_C,
    DEFAULT_BOUT_S,
    JointHeating,
    has_thermal_data,
    joint_heating,
    thermal_model,
)
from sim.errors import SimConfigError
from sim.metrics import steady_mask
from sim.rollout import Trajectory

THERMAL_SCHEMA = "gaitsmith.thermal/1"
MAX_BOUT_S = 24 * 3600.0
AMBIENT_RANGE_C = (-40.0, 60.0)
HIGHLIGHT = 3  # joints drawn in colour in the plot (the hottest)


@dataclass(frozen=True)
class ThermalPrediction:
    """Per-joint heating over a bout (hottest first in `hottest`)."""

    bout_s: float
    ambient_c: float
    joints: tuple[JointHeating, ...]
    unmodelled: tuple[str, ...]  # joints whose servo has no thermal data

    @property
    def hottest(self) -> tuple[JointHeating, ...]:
        return tuple(sorted(self.joints, key=lambda h: -h.rise_after_bout_k))

    @property
    def first_to_limit(self) -> JointHeating | None:
        """The joint that reaches its limit first (None: none does)."""
        over = [h for h in self.joints if h.minutes_to_limit is not None]
        return min(over, key=lambda h: h.minutes_to_limit or 0.0) if over else None

    def summary(self) -> str:
        if not self.joints:
            return "no thermal prediction: no servo of this robot has thermal data"
        hot = self.hottest[0]
        line = (
            f"after {self.bout_s / 60:.0f} min at {self.ambient_c:.0f} °C ambient the hottest "
            f"servo ({hot.joint}) reaches {hot.temperature_after_bout_c:.1f} °C (limit "
            f"{hot.max_temperature_c:.0f} °C)"
        )
        first = self.first_to_limit
        if first is not None:
            line += f"; {first.joint} reaches its limit after {first.minutes_to_limit:.1f} min"
        else:
            line += "; no servo reaches its limit at steady state"
        return line

    def to_dict(self) -> dict[str, object]:
        return {
            "schema": THERMAL_SCHEMA,
            "bout_s": self.bout_s,
            "ambient_c": self.ambient_c,
            "model": "first-order: P = I²R with I ∝ |τ|; robots.thermal (R_th, τ_th estimated)",
            "joints": [h.to_dict() for h in self.joints],
            "unmodelled": list(self.unmodelled),
        }


def check_bout(bout_s: float, ambient_c: float) -> None:
    if not (np.isfinite(bout_s) and 0.0 < bout_s <= MAX_BOUT_S):
        raise SimConfigError(f"thermal bout must be in (0, {MAX_BOUT_S:g}] s, got {bout_s!r}")
    lo, hi = AMBIENT_RANGE_C
    if not (np.isfinite(ambient_c) and lo <= ambient_c <= hi):
        raise SimConfigError(f"ambient must be in [{lo:g}, {hi:g}] °C, got {ambient_c!r}")


def predict_heating(
    robot: Robot,
    torque_nm: np.ndarray,
    *,
    bout_s: float = DEFAULT_BOUT_S,
    ambient_c: float = DEFAULT_AMBIENT_C,
) -> ThermalPrediction:
    """Heating per joint from torque samples `torque_nm` (T × J, uniform in time, whole cycles
    of the gait, e.g. the rollout's steady cycles or the planner's knots)."""
    check_bout(bout_s, ambient_c)
    tau = np.asarray(torque_nm, dtype=float)
    if tau.ndim != 2 or tau.shape[1] != robot.dof or len(tau) == 0:
        raise SimConfigError(f"torques must be (T > 0, {robot.dof}), got {tau.shape}")
    joints, unmodelled = [], []
    for j, joint in enumerate(robot.joints):
        if not has_thermal_data(joint.servo):
            unmodelled.append(joint.name)
            continue
        model = thermal_model(joint.servo)
        joints.append(joint_heating(joint.name, model, tau[:, j], bout_s=bout_s,
                                    ambient_c=ambient_c))
    return ThermalPrediction(bout_s, ambient_c, tuple(joints), tuple(unmodelled))


def predict_from_trajectory(
    traj: Trajectory,
    robot: Robot,
    *,
    warmup_cycles: int = 2,
    bout_s: float = DEFAULT_BOUT_S,
    ambient_c: float = DEFAULT_AMBIENT_C,
) -> ThermalPrediction:
    """`predict_heating` from a rollout's servo torques over its steady cycles."""
    mask = steady_mask(traj, warmup_cycles)
    return predict_heating(robot, traj.torque_nm[mask], bout_s=bout_s, ambient_c=ambient_c)


def temperature_plot(pred: ThermalPrediction, *, samples: int = 200) -> bytes:
    """PNG: predicted temperature vs time per joint over the bout; the `HIGHLIGHT` hottest in
    colour, the others grey; each servo's limit dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.linspace(0.0, pred.bout_s, samples)
    fig, ax = plt.subplots(figsize=(9, 4.5))
    hottest = pred.hottest
    for h in reversed(hottest[HIGHLIGHT:]):
        ax.plot(t / 60.0, pred.ambient_c + h.rise_k(t), color="0.7", lw=1.0)
    for k, h in enumerate(hottest[:HIGHLIGHT]):
        ax.plot(t / 60.0, pred.ambient_c + h.rise_k(t), lw=2.0, color=f"C{k}",
                label=f"{h.joint} ({h.servo})")
    for limit in sorted({h.max_temperature_c for h in pred.joints}):
        ax.axhline(limit, color="C3", ls="--", lw=1.0)
        ax.text(0.0, limit, f" limit {limit:.0f} °C", color="C3", va="bottom", fontsize=8)
    ax.set_xlabel("time walking [min]")
    ax.set_ylabel("predicted servo temperature [°C]")
    ax.set_title(f"predicted heating, {pred.ambient_c:.0f} °C ambient "
                 f"(grey: the other {max(0, len(hottest) - HIGHLIGHT)} joints)")
    if hottest:
        ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()

"""The servo envelope at a supply voltage: stall torque and no-load speed scale ∝ V/V_nominal.

A servo's motor is a brushed DC motor: at fixed winding (resistance R, torque constant k),
stall torque τ_stall = k·V/R and no-load speed ω₀ = V/k (times the gear ratio), so both are
proportional to the supply voltage V, and the torque–speed line |τ| ≤ τ_stall(V)·(1 − |q̇|/ω₀(V))
shrinks towards the origin as the pack sags (a 2S pack at 7.0 V, not its 7.4 V nominal, gives
95 % of the datasheet's stall torque and no-load speed). Friction and the driver's voltage drop
are ignored, as in the datasheet line itself. Valid within the servo's supply range
[voltage_min_v, voltage_max_v] only; outside it the servo cuts out or is damaged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from robots.errors import RobotConfigError
from robots.robot import Robot
from robots.servo import ServoModel, load_catalogue


def _rated(servo: ServoModel) -> ServoModel:
    """The catalogue entry (at its nominal voltage) of `servo`, or `servo` itself."""
    return load_catalogue().get(servo.name, servo)


def voltage_range_v(robot: Robot) -> tuple[float, float]:
    """Supply voltages every servo of `robot` accepts: (highest minimum, lowest maximum)."""
    lo = max(j.servo.voltage_min_v for j in robot.joints)
    hi = min(j.servo.voltage_max_v for j in robot.joints)
    return lo, hi


def nominal_supply_v(robot: Robot) -> float:
    """The supply the datasheets' figures hold at: the first servo's nominal voltage (kept
    inside the range every servo accepts, for builds that mix servo models)."""
    lo, hi = voltage_range_v(robot)
    return min(max(_rated(robot.joints[0].servo).nominal_voltage_v, lo), hi)


def check_supply_voltage(servo: ServoModel, supply_v: float) -> None:
    """RobotConfigError unless `supply_v` is finite and in the servo's supply range."""
    if not (math.isfinite(supply_v) and servo.voltage_min_v <= supply_v <= servo.voltage_max_v):
        raise RobotConfigError(
            "servos.toml", f"[{servo.name}]",
            f"supply {supply_v:g} V outside its range [{servo.voltage_min_v:g}, "
            f"{servo.voltage_max_v:g}] V",
        )


def servo_at_voltage(servo: ServoModel, supply_v: float) -> ServoModel:
    """`servo` with stall torque and no-load speed at `supply_v` (∝ V/V_nominal).

    `nominal_voltage_v` stays the datasheet's rating voltage (the voltage its catalogue figures
    hold at), so `voltage_scale` of the result says how far the envelope was scaled. Scaling
    always starts from the catalogue figures: applying it twice does not compound.
    """
    check_supply_voltage(servo, supply_v)
    rated = _rated(servo)
    k = supply_v / rated.nominal_voltage_v
    return replace(
        servo,
        stall_torque_nm=rated.stall_torque_nm * k,
        no_load_speed_rad_s=rated.no_load_speed_rad_s * k,
    )


def voltage_scale(servo: ServoModel) -> float:
    """Stall torque of `servo` over its catalogue stall torque (1 at the nominal voltage)."""
    return servo.stall_torque_nm / _rated(servo).stall_torque_nm


def robot_at_voltage(robot: Robot, supply_v: float | None) -> Robot:
    """`robot` with every servo's envelope at `supply_v` (None: unchanged, the datasheets').
    The fingerprint is unchanged: the build is the same, only the supply differs."""
    if supply_v is None:
        return robot
    joints = tuple(replace(j, servo=servo_at_voltage(j.servo, supply_v)) for j in robot.joints)
    return replace(robot, joints=joints)


@dataclass(frozen=True)
class JointMargin:
    """Peak torque of one joint against its stall torque at the supply and at nominal."""

    joint: str
    peak_torque_nm: float
    fraction_at_supply: float
    fraction_at_nominal: float


@dataclass(frozen=True)
class VoltageMargin:
    """How much of the (voltage-scaled) envelope a gait's peak torque uses."""

    supply_v: float
    nominal_v: float
    joints: tuple[JointMargin, ...]

    @property
    def worst(self) -> JointMargin:
        return max(self.joints, key=lambda j: j.fraction_at_supply)

    def summary(self) -> str:
        """One line, e.g. "at 7.0 V the peak knee_fl torque is 83 % of stall (78 % at 7.4 V)"."""
        w = self.worst
        return (
            f"at {self.supply_v:.2f} V the peak {w.joint} torque is "
            f"{100 * w.fraction_at_supply:.0f} % of stall ({100 * w.fraction_at_nominal:.0f} % at "
            f"{self.nominal_v:.2f} V nominal)"
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "supply_v": self.supply_v, "nominal_v": self.nominal_v,
            "joints": [
                {"joint": j.joint, "peak_torque_nm": j.peak_torque_nm,
                 "fraction_at_supply": j.fraction_at_supply,
                 "fraction_at_nominal": j.fraction_at_nominal} for j in self.joints
            ],
        }


def voltage_margin(robot: Robot, torques_nm: ArrayLike, supply_v: float) -> VoltageMargin:
    """Peak |τ| per joint of `torques_nm` (T × J) against stall at `supply_v` and at nominal.
    `robot` may already be at the supply voltage: fractions use the catalogue figures."""
    tau = np.abs(np.asarray(torques_nm, dtype=float))
    if tau.ndim != 2 or tau.shape[1] != robot.dof:
        raise ValueError(f"torques must be (T, {robot.dof}), got {tau.shape}")
    peaks = tau.max(axis=0) if len(tau) else np.zeros(robot.dof)
    joints = []
    for j, joint in enumerate(robot.joints):
        check_supply_voltage(joint.servo, supply_v)
        rated = _rated(joint.servo)
        at_supply = rated.stall_torque_nm * supply_v / rated.nominal_voltage_v
        joints.append(JointMargin(joint.name, float(peaks[j]), float(peaks[j] / at_supply),
                                  float(peaks[j] / rated.stall_torque_nm)))
    nominal = _rated(robot.joints[0].servo).nominal_voltage_v
    return VoltageMargin(supply_v, nominal, tuple(joints))

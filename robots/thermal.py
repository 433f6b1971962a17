"""Servo heating: a first-order thermal model per servo, from the joint torque it delivers.

Model (one servo; a brushed DC motor behind a gearbox, temperature read by the servo's sensor):

    I   = I₀ + (I_stall − I₀)·|τ|/τ_stall          current ∝ output torque (fixed torque constant)
    P   = I²·R_w,   R_w = V_nom / I_stall           winding (I²R) heat; at stall all of V_nom
                                                    drops across the winding
    dΔT/dt = (P·R_th − ΔT) / τ_th                   ΔT = temperature − ambient

with τ_stall, I_stall at the catalogue's nominal voltage V_nom. The current per unit torque
I_stall/τ_stall is the motor's torque constant, so the heat of a given torque does not depend on
the supply voltage (at a lower voltage the same torque is a larger fraction of a smaller stall
torque, drawing the same current). For a gait whose period is much shorter than τ_th the filter
sees the cycle-mean power P̄: ΔT(t) = P̄·R_th·(1 − e^(−t/τ_th)) from a cold start, and the
temperature limit T_max is reached after t = −τ_th·ln(1 − (T_max − T_amb)/(P̄·R_th)), or never
when T_amb + P̄·R_th < T_max.

Where the figures come from (`ELECTRICAL`, `REFERENCE`): stall currents are the vendors'
published figures at the catalogue's nominal voltage (cited per entry). No vendor publishes a
thermal resistance or time constant for these servos, so R_th and τ_th are *estimated* from one
measured test and scaled by mass (see `REFERENCE` and `thermal_model`); treat minutes-to-limit as
an estimate to be checked against the servo's own temperature register (gaitsmith-play's watchdog
does exactly that). No mujoco import: `hardware` uses this module too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from robots.errors import RobotConfigError
from robots.servo import CATALOGUE_PATH, ServoModel, load_catalogue

DEFAULT_AMBIENT_C = 25.0
DEFAULT_BOUT_S = 600.0  # a 10-minute walking bout


@dataclass(frozen=True)
class ServoElectrical:
    """Published electrical figures of one catalogue servo, at its catalogue nominal voltage."""

    servo: str  # catalogue name (robots/servos.toml)
    stall_current_a: float
    no_load_current_a: float  # 0 where not published (only the torque-proportional heat counts)
    source: str


@dataclass(frozen=True)
class ThermalReference:
    """The one measured heating test the thermal constants are estimated from."""

    servo: str
    mass_kg: float
    r_th_k_per_w: float
    tau_th_s: float
    source: str


# Stall currents at the catalogue's nominal voltage (the same voltage as its stall torque).
ELECTRICAL: tuple[ServoElectrical, ...] = (
    ServoElectrical("STS3215_7V4", 2.7, 0.0,
                    "Feetech STS3215 datasheet: stall current 2.7 A @7.4 V"),
    ServoElectrical("STS3215_12V", 2.4, 0.0,
                    "Feetech STS3215 C018 datasheet: stall current 2.4 A @12 V"),
    ServoElectrical("XL430_W250", 1.3, 0.0,
                    "ROBOTIS XL430-W250 e-Manual: 1.4 N·m (at 11.1 V, 1.3 A)"),
    ServoElectrical("XL330_M288", 1.47, 0.017,
                    "ROBOTIS XL330-M288 e-Manual: 0.52 N·m (at 5.0 V, 1.47 A); standby 17 mA"),
    ServoElectrical("AX_12A", 1.5, 0.0, "ROBOTIS AX-12A e-Manual: 1.5 N·m (at 12 V, 1.5 A)"),
    ServoElectrical("XM430_W350", 2.3, 0.0,
                    "ROBOTIS XM430-W350 e-Manual: 4.1 N·m (at 12.0 V, 2.3 A)"),
    ServoElectrical("XM430_W210", 2.3, 0.0,
                    "ROBOTIS XM430-W210 (e-Manual TurtleBot3 appendix): 3.0 N·m (at 12 V, 2.3 A)"),
    ServoElectrical("MX_28_P2", 1.4, 0.0, "ROBOTIS MX-28(2.0) e-Manual: 2.5 N·m (at 12 V, 1.4 A)"),
    ServoElectrical("MX_64_P2", 4.1, 0.0, "ROBOTIS MX-64(2.0) e-Manual: 6.0 N·m (at 12 V, 4.1 A)"),
    ServoElectrical("XL_320", 1.1, 0.0, "ROBOTIS XL-320 e-Manual: 0.39 N·m (at 7.4 V, 1.1 A)"),
    ServoElectrical("AX_18A", 2.2, 0.0, "ROBOTIS AX-18A e-Manual: 1.8 N·m (at 12 V, 2.2 A)"),
)

# Estimated from robonine.com's STS3215 tests ("Testing of Feetech STS3215 Servomotor: Backlash,
# Repeatability, and Torque", robonine.com, and its results table in TheRobotStudio/SO-ARM100
# issue #134), on the 12 V C018 (30 kg·cm) at a regulated 12 V:
#   - static: 1 kg at 15 cm (1.471 N·m, 50 % of the 2.942 N·m stall) held continuously → 48 °C
#     after 10 min, "remained stable for >1 h with no further increase";
#   - lifting 1.5 kg on 10 cm (the same 1.471 N·m at the top, less on average) → "+15 °C rise
#     after 10 min" (consistent with a lower mean torque than the static hold).
# The static hold is the clean measurement. The room temperature is not stated: taking 25 °C
# (the conservative reading: more heating per watt than if the servo started warm), ΔT = 23 K at
# P = (0.5·2.4 A)²·(12 V/2.4 A) = 7.2 W → R_th = 23/7.2 = 3.19 K/W; settled by 10 minutes →
# 3·τ_th ≤ 600 s → τ_th = 200 s (the slowest time constant consistent with it). Not fitted, and
# a warning about this model: the same article's oscillation test (±90° continuous motion from
# 48 °C: 60 °C after 50 min, then 71 °C after ~110 min, overheat) heats more, and more slowly,
# than an I²R-of-output-torque model explains — motion adds losses (gearbox friction carried by
# the motor, driver switching) that |τ| does not show. Expect the prediction to be optimistic
# for servos that move a lot; gaitsmith-play's watchdog compares it with the servos' own readings.
REFERENCE = ThermalReference(
    servo="STS3215_12V",
    mass_kg=0.055,
    r_th_k_per_w=23.0 / ((1.471 / 2.942) ** 2 * 12.0 * 2.4),
    tau_th_s=200.0,
    source="estimated from robonine.com's STS3215 C018 hold test (1.47 N·m → 48 °C, settled "
    "within 10 min; 25 °C room assumed)",
)


@dataclass(frozen=True)
class ThermalModel:
    """First-order heating of one servo (see the module docstring for the law)."""

    servo: str
    stall_torque_nm: float  # at the nominal voltage (the current's reference)
    stall_current_a: float
    no_load_current_a: float
    winding_resistance_ohm: float
    r_th_k_per_w: float
    tau_th_s: float
    max_temperature_c: float
    source: str

    def current_a(self, torque_nm: ArrayLike) -> np.ndarray:
        frac = np.abs(np.asarray(torque_nm, dtype=float)) / self.stall_torque_nm
        return self.no_load_current_a + (self.stall_current_a - self.no_load_current_a) * frac

    def power_w(self, torque_nm: ArrayLike) -> np.ndarray:
        """Winding heat P = I²·R_w [W] at output torque `torque_nm`."""
        return self.current_a(torque_nm) ** 2 * self.winding_resistance_ohm

    def steady_rise_k(self, power_w: float) -> float:
        return float(power_w) * self.r_th_k_per_w

    def rise_k(self, power_w: float, t_s: ArrayLike, initial_rise_k: float = 0.0) -> np.ndarray:
        """ΔT [K] after `t_s` seconds at constant mean power, from `initial_rise_k`."""
        ss = self.steady_rise_k(power_w)
        t = np.asarray(t_s, dtype=float)
        return ss + (initial_rise_k - ss) * np.exp(-t / self.tau_th_s)

    def rise_series_k(self, power_w: ArrayLike, dt_s: float, initial_rise_k: float = 0.0
                      ) -> np.ndarray:
        """ΔT [K] after each sample of a power series held for `dt_s` (exact per step)."""
        p = np.asarray(power_w, dtype=float)
        decay = math.exp(-dt_s / self.tau_th_s)
        out = np.empty_like(p)
        rise = initial_rise_k
        for k, pk in enumerate(p):
            ss = pk * self.r_th_k_per_w
            rise = ss + (rise - ss) * decay
            out[k] = rise
        return out

    def heating_rate_k_per_s(self, power_w: float, rise_k: float) -> float:
        """dΔT/dt [K/s] at mean power `power_w` and present rise `rise_k`."""
        return (float(power_w) * self.r_th_k_per_w - rise_k) / self.tau_th_s

    def time_to_limit_s(self, power_w: float, ambient_c: float = DEFAULT_AMBIENT_C,
                        start_c: float | None = None, limit_c: float | None = None
                        ) -> float | None:
        """Seconds until the temperature reaches `limit_c` (default: the servo's maximum) at
        constant mean power, from `start_c` (default: ambient); 0 if already there, None if
        the steady temperature stays below the limit."""
        limit = self.max_temperature_c if limit_c is None else limit_c
        start = ambient_c if start_c is None else start_c
        if start >= limit:
            return 0.0
        ss = self.steady_rise_k(power_w)
        need, have = limit - ambient_c, start - ambient_c
        if ss <= need:
            return None
        return -self.tau_th_s * math.log((ss - need) / (ss - have))


def electrical_of(name: str) -> ServoElectrical | None:
    for e in ELECTRICAL:
        if e.servo == name:
            return e
    return None


def has_thermal_data(servo: ServoModel) -> bool:
    return electrical_of(servo.name) is not None


def thermal_model(servo: ServoModel) -> ThermalModel:
    """The thermal model of a catalogue servo; RobotConfigError if its stall current is not
    published (listing the servos that have one).

    Electrical figures are taken at the catalogue entry's nominal voltage (not at `servo`'s,
    which may be a copy scaled to a supply voltage: the torque constant does not change).
    R_th and τ_th: the `REFERENCE` test, scaled by mass for other housings (estimated): heat
    leaves through the case surface ∝ m^(2/3), so R_th ∝ m^(−2/3); the heat capacity ∝ m, so
    τ_th = C·R_th ∝ m^(1/3).
    """
    elec = electrical_of(servo.name)
    if elec is None:
        known = sorted(e.servo for e in ELECTRICAL)
        raise RobotConfigError(
            str(CATALOGUE_PATH), f"[{servo.name}]",
            f"no published stall current, no thermal model; servos with one: {known}",
        )
    rated = load_catalogue().get(servo.name, servo)
    ratio = rated.mass_kg / REFERENCE.mass_kg
    same_housing = servo.name.startswith("STS3215")
    r_th = REFERENCE.r_th_k_per_w * (1.0 if same_housing else ratio ** (-2.0 / 3.0))
    tau = REFERENCE.tau_th_s * (1.0 if same_housing else ratio ** (1.0 / 3.0))
    how = REFERENCE.source if same_housing else (
        f"{REFERENCE.source}, scaled by mass {rated.mass_kg * 1000:.1f} g / "
        f"{REFERENCE.mass_kg * 1000:.0f} g"
    )
    return ThermalModel(
        servo=servo.name,
        stall_torque_nm=rated.stall_torque_nm,
        stall_current_a=elec.stall_current_a,
        no_load_current_a=elec.no_load_current_a,
        winding_resistance_ohm=rated.nominal_voltage_v / elec.stall_current_a,
        r_th_k_per_w=r_th,
        tau_th_s=tau,
        max_temperature_c=rated.max_temperature_c,
        source=f"{elec.source}; R_th, τ_th {how}",
    )


@dataclass(frozen=True)
class JointHeating:
    """Predicted heating of one joint's servo over a bout, from its cycle-mean winding heat."""

    joint: str
    servo: str
    mean_power_w: float
    steady_rise_k: float
    rise_after_bout_k: float
    temperature_after_bout_c: float
    minutes_to_limit: float | None  # None: the steady temperature stays below the limit
    max_temperature_c: float
    tau_th_s: float

    @property
    def initial_rate_k_per_s(self) -> float:
        """dΔT/dt at a cold start: P̄·R_th/τ_th."""
        return self.steady_rise_k / self.tau_th_s

    def rise_k(self, t_s: ArrayLike) -> np.ndarray:
        t = np.asarray(t_s, dtype=float)
        return self.steady_rise_k * (1.0 - np.exp(-t / self.tau_th_s))

    def to_dict(self) -> dict[str, object]:
        return {
            "joint": self.joint, "servo": self.servo, "mean_power_w": self.mean_power_w,
            "steady_rise_k": self.steady_rise_k, "rise_after_bout_k": self.rise_after_bout_k,
            "temperature_after_bout_c": self.temperature_after_bout_c,
            "minutes_to_limit": self.minutes_to_limit,
            "max_temperature_c": self.max_temperature_c, "tau_th_s": self.tau_th_s,
        }


def joint_heating(joint: str, model: ThermalModel, torque_nm: ArrayLike, *,
                  bout_s: float = DEFAULT_BOUT_S, ambient_c: float = DEFAULT_AMBIENT_C
                  ) -> JointHeating:
    """Heating of one joint that repeats the torque samples `torque_nm` (uniform in time, e.g.
    one or more whole gait cycles) for `bout_s` seconds from ambient."""
    p = float(np.mean(model.power_w(torque_nm)))
    ss = model.steady_rise_k(p)
    rise = float(model.rise_k(p, bout_s))
    t_lim = model.time_to_limit_s(p, ambient_c)
    return JointHeating(
        joint=joint, servo=model.servo, mean_power_w=p, steady_rise_k=ss,
        rise_after_bout_k=rise, temperature_after_bout_c=ambient_c + rise,
        minutes_to_limit=None if t_lim is None else t_lim / 60.0,
        max_temperature_c=model.max_temperature_c, tau_th_s=model.tau_th_s,
    )

"""Servo models from the catalogue `robots/servos.toml` (vendors' published figures)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from robots import toml_schema as ts
from robots.errors import RobotConfigError

CATALOGUE_PATH = Path(__file__).with_name("servos.toml")
PROTOCOLS = (
    "dynamixel2",
    "dynamixel1",
    "feetech_sts",
    "feetech_scs",
    "dynamixel2_xl320",
    "hiwonder_bus",
    "pwm",
)


@dataclass(frozen=True)
class ServoModel:
    """One servo model at its nominal voltage.

    The torque–speed envelope is the DC-motor line |τ| ≤ τ_stall·(1 − |q̇|/ω₀).
    """

    name: str
    vendor: str
    protocol: str
    model_number: int
    nominal_voltage_v: float
    voltage_min_v: float
    voltage_max_v: float
    stall_torque_nm: float
    no_load_speed_rad_s: float
    ticks_per_rev: float
    position_min_tick: int
    position_max_tick: int
    default_baud: int
    mass_kg: float
    max_temperature_c: float
    # identified reflected rotor inertia at the output shaft [kg·m²] (MJCF joint `armature`);
    # None where no identification is published (`robots/servos.toml`)
    armature_kg_m2: float | None = None

    @property
    def ticks_per_rad(self) -> float:
        return self.ticks_per_rev / (2.0 * math.pi)

    def torque_limit_nm(self, speed_rad_s: float, margin: float = 1.0) -> float:
        """Largest torque magnitude available at joint speed `speed_rad_s` (0 beyond ω₀)."""
        frac = 1.0 - abs(speed_rad_s) / self.no_load_speed_rad_s
        return max(0.0, self.stall_torque_nm * frac * margin)


# field → (lower, upper) bound: generous physical limits, so a typo (1e308, 5e-324) is refused
_FLOAT_FIELDS: dict[str, tuple[float, float]] = {
    "nominal_voltage_v": (0.0, 100.0),
    "voltage_min_v": (0.0, 100.0),
    "voltage_max_v": (0.0, 100.0),
    "stall_torque_nm": (1e-4, 1000.0),
    "no_load_speed_rad_s": (1e-3, 1000.0),
    "ticks_per_rev": (1.0, 1e7),
    "mass_kg": (1e-4, 100.0),
    "max_temperature_c": (1.0, 300.0),
}
_INT_FIELDS: dict[str, tuple[int, int]] = {
    "model_number": (0, 65535),
    "position_min_tick": (0, 10**7),
    "position_max_tick": (0, 10**7),
    "default_baud": (0, 10**8),  # 0: a PWM servo (no bus), see _check_bus_fields
}
# optional figures: absent means not known for this servo
_OPTIONAL_FLOAT_FIELDS: dict[str, tuple[float, float]] = {"armature_kg_m2": (1e-7, 10.0)}
SERVO_FIELDS = ("vendor", "protocol", *_FLOAT_FIELDS, *_INT_FIELDS, *_OPTIONAL_FLOAT_FIELDS)
ENV_CATALOGUE = "GAITSMITH_SERVOS"


def parse_servo(file: str, where: str, name: str, table: Any) -> ServoModel:
    """Validate one servo model's table (`where` is its TOML path, e.g. "[servos.MY_SERVO]").

    The one validation for the built-in catalogue, a user catalogue file and robot.toml's
    [servos] tables: exactly the fields of `ServoModel`, each bounded.
    """
    if not isinstance(table, dict):
        raise RobotConfigError(file, where, "must be a table of servo figures")
    ts.string(file, f"{where} (the servo model's name)", name)
    ts.check_keys(file, where, table, set(SERVO_FIELDS))
    values: dict[str, Any] = {"name": name}
    for key in ("vendor", "protocol"):
        values[key] = ts.string(file, f"{where}.{key}", table.get(key))
    if values["protocol"] not in PROTOCOLS:
        raise RobotConfigError(
            file, f"{where}.protocol", f"is {values['protocol']!r}; must be one of {PROTOCOLS}"
        )
    for key, (lo, hi) in _FLOAT_FIELDS.items():
        values[key] = ts.number(file, f"{where}.{key}", table.get(key), lo, hi, lo_open=True)
    for key, (ilo, ihi) in _INT_FIELDS.items():
        values[key] = ts.integer(file, f"{where}.{key}", table.get(key), ilo, ihi)
    for key, (lo, hi) in _OPTIONAL_FLOAT_FIELDS.items():
        if key in table:
            values[key] = ts.number(file, f"{where}.{key}", table[key], lo, hi, lo_open=True)
    if values["position_max_tick"] <= values["position_min_tick"]:
        raise RobotConfigError(file, f"{where}.position_max_tick", "must exceed position_min_tick")
    if not values["voltage_min_v"] <= values["nominal_voltage_v"] <= values["voltage_max_v"]:
        raise RobotConfigError(
            file, f"{where}.nominal_voltage_v", "must lie within voltage_min_v..voltage_max_v"
        )
    _check_bus_fields(file, where, values)
    return ServoModel(**values)


def _check_bus_fields(file: str, where: str, values: dict[str, Any]) -> None:
    """PWM servos have no bus: model_number and default_baud are 0; bus servos have a baud rate."""
    if values["protocol"] == "pwm":
        for key in ("model_number", "default_baud"):
            if values[key] != 0:
                raise RobotConfigError(
                    file, f"{where}.{key}", "must be 0 for a PWM servo (no bus, nothing answers)"
                )
    elif values["default_baud"] == 0:
        raise RobotConfigError(
            file, f"{where}.default_baud", f"a {values['protocol']} bus servo needs its baud rate"
        )


def parse_servo_tables(file: str, prefix: str, tables: Any) -> dict[str, ServoModel]:
    """Servo models from a table of tables; `prefix` "" (a catalogue) or "servos." (robot.toml)."""
    if not isinstance(tables, dict):
        raise RobotConfigError(file, f"[{prefix.rstrip('.')}]", "must be a table of servo tables")
    return {name: parse_servo(file, f"[{prefix}{name}]", name, t) for name, t in tables.items()}


def parse_catalogue(text: str, file: str = str(CATALOGUE_PATH)) -> dict[str, ServoModel]:
    """Parse a servo catalogue's TOML text; raises RobotConfigError naming the field at fault."""
    return parse_servo_tables(file, "", ts.read_toml(text, file))


@lru_cache(maxsize=1)
def load_catalogue() -> dict[str, ServoModel]:
    """The built-in servo catalogue, keyed by model name (e.g. "XL430_W250")."""
    return parse_catalogue(CATALOGUE_PATH.read_text(encoding="utf-8"))


def read_catalogue_file(path: str | Path) -> dict[str, ServoModel]:
    """A user's servo catalogue file (same format and validation as robots/servos.toml)."""
    p = Path(path).expanduser()
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotConfigError(
            str(p),
            "<file>",
            f"cannot read the servo catalogue: {exc}; check --servos / {ENV_CATALOGUE}",
        ) from None
    return parse_catalogue(text, str(p))


def user_catalogue_path(servo_catalogue: str | Path | None = None) -> Path | None:
    """The user catalogue in force: the argument (`--servos FILE`), else $GAITSMITH_SERVOS."""
    if servo_catalogue is not None and str(servo_catalogue) != "":
        return Path(servo_catalogue).expanduser()
    env = os.environ.get(ENV_CATALOGUE, "").strip()
    return Path(env).expanduser() if env else None


def servo_catalogue(servo_catalogue: str | Path | None = None) -> dict[str, ServoModel]:
    """Built-in catalogue overlaid with the user catalogue in force (see `user_catalogue_path`).

    Precedence of a servo model's name: robot.toml's [servos] (applied by `robots.load`) >
    the user catalogue file (`--servos FILE` or $GAITSMITH_SERVOS) > the built-in catalogue.
    """
    merged = dict(load_catalogue())
    path = user_catalogue_path(servo_catalogue)
    if path is not None:
        merged.update(read_catalogue_file(path))
    return merged


def servo_model(name: str, servo_catalogue_file: str | Path | None = None) -> ServoModel:
    """Look up one model (built-in + user catalogue); raises RobotConfigError listing the known."""
    catalogue = servo_catalogue(servo_catalogue_file)
    if name not in catalogue:
        raise RobotConfigError(
            str(CATALOGUE_PATH), name, f"unknown servo model; known: {sorted(catalogue)}"
        )
    return catalogue[name]


# ---------------------------------------------------------------------------------------------
# Factory position-loop gains (what the servo's firmware does with a goal position)

DYNAMIXEL_X_PWM_FULL = 885.0  # e-Manual: Goal PWM range ±885 = ±100 % duty
DYNAMIXEL_X_KPP_DEFAULT = 800.0  # e-Manual: Position P Gain default (XL430-W250)
DYNAMIXEL_X_KPP_SCALE = 128.0  # e-Manual: K_PP = KPP(TBL) / 128
DYNAMIXEL_1_COMPLIANCE_SLOPE_TICKS = 32.0  # AX-12A e-Manual: CW/CCW compliance slope default
FEETECH_STS_P_DEFAULT = 32.0  # STS memory table: P coefficient default
FEETECH_STS_DUTY_PER_P_RAD = 0.166  # BAM (Duclusaud & Passault 2025): duty per (P · rad)
# Protocols whose factory position loop no vendor document states as a gain we can convert:
# hobby PWM servos (analogue/digital pulse-stretcher boards), Hiwonder bus servos (move-in-time
# commands, no gain register), Feetech SCS and the XL-320 (P registers, unpublished output scale).
STAND_IN_LOOP_PROTOCOLS = ("feetech_scs", "dynamixel2_xl320", "hiwonder_bus", "pwm")


def factory_gains(servo: ServoModel) -> tuple[float, float]:
    """(duty_per_rad, duty_s_per_rad) of the servo's factory position loop, by protocol.

    The loop drives the motor at PWM duty u = clip(g_p·(goal − q) − g_d·q̇, −1, 1); at full duty
    the output torque is τ_stall·(1 − q̇/ω₀). Sources:

    - Dynamixel X (Protocol 2.0): e-Manual "Position PID Gain": K_P = KPP(TBL)/128, default
      Position P Gain 800 (XL430-W250), output in PWM units with 885 = 100 % duty, error in
      ticks → g_p = 800/128 · ticks_per_rad / 885 ≈ 4.60 /rad; D gain default 0.
    - Dynamixel Protocol 1.0 (AX-12A): compliance slope default 32 ticks from zero to full torque
      → g_p = ticks_per_rad / 32.
    - Feetech STS: P coefficient default 32; Duclusaud & Passault, "Extended friction models for
      the physics simulation of servo actuators" (2025, BAM), measured on an STS3215:
      duty = 0.166 · P · error[rad] → g_p = 5.31 /rad; no D term.
    - `STAND_IN_LOOP_PROTOCOLS` (PWM hobby servos, Hiwonder bus, Feetech SCS, XL-320): no
      published gain. Stand-in, not a figure for these servos: the one hobby-servo loop that has
      been measured, the STS3215's above (full duty at 10.8° of error), so that they plan and
      simulate; measure the servo (BAM's rig) before trusting its tracking in simulation.

    Used by `sim` (the servo actuator model) and `planner` (servo-goal output), so both see the
    same servo.
    """
    if servo.protocol == "dynamixel2":
        kpp = DYNAMIXEL_X_KPP_DEFAULT / DYNAMIXEL_X_KPP_SCALE
        return kpp * servo.ticks_per_rad / DYNAMIXEL_X_PWM_FULL, 0.0
    if servo.protocol == "dynamixel1":
        return servo.ticks_per_rad / DYNAMIXEL_1_COMPLIANCE_SLOPE_TICKS, 0.0
    if servo.protocol == "feetech_sts" or servo.protocol in STAND_IN_LOOP_PROTOCOLS:
        return FEETECH_STS_P_DEFAULT * FEETECH_STS_DUTY_PER_P_RAD, 0.0
    raise RobotConfigError(
        str(CATALOGUE_PATH),
        f"[{servo.name}].protocol",
        f"no factory position-loop gains known for protocol {servo.protocol!r}",
    )

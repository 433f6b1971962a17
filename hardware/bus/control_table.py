"""Servo control tables as data: register addresses, sizes, sign conventions and units.

Sources (facts checked against the vendors' documents):

* ROBOTIS DYNAMIXEL XL430-W250 e-Manual, "Control Table of EEPROM/RAM Area" (X-series, Protocol
  2.0): Model Number 0 (2 B), Firmware Version 6, ID 7, Baud Rate 8, Return Delay Time 9 (2 µs
  per unit, factory 250 = 500 µs), Shutdown 63, Torque Enable 64,
  Hardware Error Status 70, Goal Position 116 (4 B), Moving 122, Present Load 126 (2 B, signed,
  0.1 %), Present Velocity 128 (4 B, 0.229 rpm), Present Position 132 (4 B), Present Input Voltage
  144 (2 B, 0.1 V), Present Temperature 146 (1 °C). Hardware Error Status bits: 0 input voltage,
  2 overheating, 3 motor encoder, 4 electrical shock, 5 overload. Status-packet error byte:
  bit 7 = alert (Hardware Error Status ≠ 0), bits 0-6 = error number (1 result fail ... 7 access).
* Feetech SMS/STS memory table (STS3215): firmware major 0 / minor 1, Model Number 3 (2 B), ID 5,
  Baud Rate 6, Return Delay Time 7 (2 µs per unit, factory 0), Torque Enable 40, Acceleration 41,
  Goal Position 42 (2 B), Present Position 56,
  Present Speed 58, Present Load 60 (0.1 %, sign bit 10), Present Voltage 62 (0.1 V), Present
  Temperature 63 (°C), Status 65, Moving 66. Positions and speeds are sign-magnitude with the sign
  in bit 15. Status byte bits: 0 voltage, 1 angle/sensor, 2 overheat, 3 over-current, 5 overload.
* ROBOTIS DYNAMIXEL AX-12A / AX-18A e-Manual, "Control Table" (Protocol 1.0; MX-28/64/106 in
  Protocol 1.0 share addresses 0-49): Model Number 0 (2 B), Firmware Version 2, ID 3, Baud Rate 4,
  Return Delay Time 5 (2 µs per unit, factory 250 = 500 µs), CW Angle Limit 6 (2 B), CCW Angle
  Limit 8 (2 B), Temperature Limit 11, Min / Max Voltage Limit 12 / 13 (0.1 V), Max Torque 14
  (2 B), Status Return Level 16 (factory 2: reply to every instruction), Alarm LED 17, Shutdown 18
  (factory 36 = overheating | overload), Torque Enable 24, LED 25, Goal Position 30 (2 B,
  0-1023 over 300°), Moving Speed 32 (2 B), Torque Limit 34 (2 B), Present Position 36 (2 B),
  Present Speed 38 (2 B, 0.111 rpm, direction in bit 10), Present Load 40 (2 B, ~0.1 %, direction
  in bit 10), Present Voltage 42 (0.1 V), Present Temperature 43 (°C), Registered 44, Moving 46,
  Lock 47, Punch 48 (2 B). There is no hardware-error register: the status packet's error byte
  carries the health bits (`hardware.bus.protocol.dynamixel1.ERROR_BITS`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

SignMode = Literal["unsigned", "twos", "sign_magnitude"]


@dataclass(frozen=True)
class Register:
    """One control-table entry: little-endian `size` bytes at `addr`.

    `signed` says how negative values are represented: "twos" (two's complement, Dynamixel) or
    "sign_magnitude" with the sign in bit `sign_bit` (Feetech). `unit` is the value of one LSB
    in the named physical unit (e.g. 0.1 for "V" means the raw value is in 0.1 V).
    """

    addr: int
    size: int
    signed: SignMode = "unsigned"
    sign_bit: int = 15
    unit: float = 1.0
    unit_name: str = ""
    writable: bool = False

    def encode(self, value: int) -> bytes:
        """Raw little-endian bytes for integer `value`; ValueError when it does not fit."""
        bits = 8 * self.size
        if self.signed == "sign_magnitude":
            raw = encode_sign_magnitude(value, self.sign_bit)
        elif self.signed == "twos":
            if not -(1 << (bits - 1)) <= value < (1 << (bits - 1)):
                raise ValueError(f"{value} does not fit a signed {bits}-bit register")
            raw = value & ((1 << bits) - 1)
        else:
            if not 0 <= value < (1 << bits):
                raise ValueError(f"{value} does not fit an unsigned {bits}-bit register")
            raw = value
        return raw.to_bytes(self.size, "little")

    def decode(self, data: bytes) -> int:
        """Integer value of `data` (exactly `size` bytes, little-endian)."""
        if len(data) != self.size:
            raise ValueError(f"expected {self.size} bytes, got {len(data)}")
        raw = int.from_bytes(data, "little")
        if self.signed == "sign_magnitude":
            return decode_sign_magnitude(raw, self.sign_bit)
        if self.signed == "twos" and raw & (1 << (8 * self.size - 1)):
            return raw - (1 << (8 * self.size))
        return raw

    def to_physical(self, value: int) -> float:
        """Raw register value → physical value in `unit_name` units."""
        return round(value * self.unit, 6)


def encode_sign_magnitude(value: int, sign_bit: int) -> int:
    """Feetech sign-magnitude: |value| in the low bits, bit `sign_bit` set when negative."""
    magnitude = abs(value)
    if magnitude >= (1 << sign_bit):
        raise ValueError(f"|{value}| does not fit below sign bit {sign_bit}")
    return magnitude | (1 << sign_bit) if value < 0 else magnitude


def decode_sign_magnitude(raw: int, sign_bit: int) -> int:
    """Inverse of `encode_sign_magnitude` (bits above the sign bit are ignored)."""
    magnitude = raw & ((1 << sign_bit) - 1)
    return -magnitude if raw & (1 << sign_bit) else magnitude


def decode_flags(raw: int, bits: Mapping[int, str]) -> tuple[str, ...]:
    """Names of the set bits of `raw` (unknown bits become "bit<n>"), lowest bit first."""
    return tuple(bits.get(1 << n, f"bit{n}") for n in range(8) if raw & (1 << n))


@dataclass(frozen=True)
class ControlTable:
    """A servo family's control table plus the meaning of its error bits."""

    family: str
    size: int  # bytes of emulated memory (0..size-1)
    registers: Mapping[str, Register]
    hardware_error_bits: Mapping[int, str]  # bits of the "hardware_error" register
    status_error_bits: Mapping[int, str] = field(default_factory=dict)  # status-packet error byte
    ram_start: int = 0  # first address writable while torque is enabled

    def __getitem__(self, name: str) -> Register:
        try:
            return self.registers[name]
        except KeyError:
            raise KeyError(
                f"{self.family} control table has no register {name!r}; "
                f"known: {sorted(self.registers)}"
            ) from None


DYNAMIXEL_X = ControlTable(
    family="dynamixel_x",
    size=252,
    ram_start=64,
    registers={
        "model_number": Register(0, 2),
        "firmware": Register(6, 1),
        "id": Register(7, 1, writable=True),
        "baud_rate": Register(8, 1, writable=True),
        "return_delay": Register(9, 1, unit=2.0, unit_name="us", writable=True),
        "operating_mode": Register(11, 1, writable=True),
        "temperature_limit": Register(31, 1, unit=1.0, unit_name="degC", writable=True),
        "max_voltage_limit": Register(32, 2, unit=0.1, unit_name="V", writable=True),
        "min_voltage_limit": Register(34, 2, unit=0.1, unit_name="V", writable=True),
        "max_position_limit": Register(48, 4, writable=True),
        "min_position_limit": Register(52, 4, writable=True),
        "shutdown": Register(63, 1, writable=True),
        "torque_enable": Register(64, 1, writable=True),
        "led": Register(65, 1, writable=True),
        "hardware_error": Register(70, 1),
        "goal_position": Register(116, 4, signed="twos", writable=True),
        "moving": Register(122, 1),
        "present_load": Register(126, 2, signed="twos", unit=0.1, unit_name="%"),
        "present_velocity": Register(128, 4, signed="twos", unit=0.229, unit_name="rpm"),
        "present_position": Register(132, 4, signed="twos"),
        "present_voltage": Register(144, 2, unit=0.1, unit_name="V"),
        "present_temperature": Register(146, 1, unit=1.0, unit_name="degC"),
    },
    hardware_error_bits={
        0x01: "input_voltage",
        0x04: "overheating",
        0x08: "motor_encoder",
        0x10: "electrical_shock",
        0x20: "overload",
    },
    status_error_bits={},  # error number (bits 0-6) + alert (bit 7): see DYNAMIXEL_ERROR_NUMBERS
)

# Protocol 2.0 status-packet error numbers (bits 0-6 of the error byte); bit 7 is the alert flag.
DYNAMIXEL_ALERT_BIT = 0x80
DYNAMIXEL_ERROR_NUMBERS: Mapping[int, str] = {
    1: "result_fail",
    2: "instruction_error",
    3: "crc_error",
    4: "data_range_error",
    5: "data_length_error",
    6: "data_limit_error",
    7: "access_error",
}

_FEETECH_ERROR_BITS: Mapping[int, str] = {
    0x01: "voltage",
    0x02: "angle",
    0x04: "overheat",
    0x08: "overcurrent",
    0x20: "overload",
}

FEETECH_STS = ControlTable(
    family="feetech_sts",
    size=87,
    ram_start=40,
    registers={
        "firmware_major": Register(0, 1),
        "firmware_minor": Register(1, 1),
        "model_number": Register(3, 2),
        "id": Register(5, 1, writable=True),
        "baud_rate": Register(6, 1, writable=True),
        "return_delay": Register(7, 1, unit=2.0, unit_name="us", writable=True),
        "min_position_limit": Register(9, 2, writable=True),
        "max_position_limit": Register(11, 2, writable=True),
        "max_temperature_limit": Register(13, 1, unit=1.0, unit_name="degC", writable=True),
        "max_voltage_limit": Register(14, 1, unit=0.1, unit_name="V", writable=True),
        "min_voltage_limit": Register(15, 1, unit=0.1, unit_name="V", writable=True),
        "torque_enable": Register(40, 1, writable=True),
        "acceleration": Register(41, 1, writable=True),
        "goal_position": Register(42, 2, signed="sign_magnitude", sign_bit=15, writable=True),
        "goal_speed": Register(46, 2, signed="sign_magnitude", sign_bit=15, writable=True),
        "lock": Register(55, 1, writable=True),
        "present_position": Register(56, 2, signed="sign_magnitude", sign_bit=15),
        "present_velocity": Register(58, 2, signed="sign_magnitude", sign_bit=15),
        "present_load": Register(
            60, 2, signed="sign_magnitude", sign_bit=10, unit=0.1, unit_name="%"
        ),
        "present_voltage": Register(62, 1, unit=0.1, unit_name="V"),
        "present_temperature": Register(63, 1, unit=1.0, unit_name="degC"),
        "hardware_error": Register(65, 1),  # "Status" in Feetech's table
        "moving": Register(66, 1),
    },
    hardware_error_bits=_FEETECH_ERROR_BITS,
    status_error_bits=_FEETECH_ERROR_BITS,
)

# Protocol 1.0 status error byte bits that report the servo's health (the others answer the
# instruction: angle limit, range, checksum, instruction; see hardware.bus.protocol.dynamixel1).
_DYNAMIXEL1_HEALTH_BITS: Mapping[int, str] = {
    0x01: "input_voltage",
    0x04: "overheating",
    0x20: "overload",
}

DYNAMIXEL_AX = ControlTable(
    family="dynamixel_ax",
    size=50,
    ram_start=24,
    registers={
        "model_number": Register(0, 2),
        "firmware": Register(2, 1),
        "id": Register(3, 1, writable=True),
        "baud_rate": Register(4, 1, writable=True),
        "return_delay": Register(5, 1, unit=2.0, unit_name="us", writable=True),
        "min_position_limit": Register(6, 2, writable=True),  # CW Angle Limit
        "max_position_limit": Register(8, 2, writable=True),  # CCW Angle Limit
        "temperature_limit": Register(11, 1, unit=1.0, unit_name="degC", writable=True),
        "min_voltage_limit": Register(12, 1, unit=0.1, unit_name="V", writable=True),
        "max_voltage_limit": Register(13, 1, unit=0.1, unit_name="V", writable=True),
        "max_torque": Register(14, 2, writable=True),
        "status_return_level": Register(16, 1, writable=True),
        "alarm_led": Register(17, 1, writable=True),
        "shutdown": Register(18, 1, writable=True),
        "torque_enable": Register(24, 1, writable=True),
        "led": Register(25, 1, writable=True),
        "goal_position": Register(30, 2, writable=True),
        "moving_speed": Register(32, 2, writable=True),
        "torque_limit": Register(34, 2, writable=True),
        "present_position": Register(36, 2),
        "present_velocity": Register(
            38, 2, signed="sign_magnitude", sign_bit=10, unit=0.111, unit_name="rpm"
        ),
        "present_load": Register(
            40, 2, signed="sign_magnitude", sign_bit=10, unit=0.1, unit_name="%"
        ),
        "present_voltage": Register(42, 1, unit=0.1, unit_name="V"),
        "present_temperature": Register(43, 1, unit=1.0, unit_name="degC"),
        "registered": Register(44, 1),
        "moving": Register(46, 1),
        "lock": Register(47, 1, writable=True),
        "punch": Register(48, 2, writable=True),
    },
    hardware_error_bits=_DYNAMIXEL1_HEALTH_BITS,
    status_error_bits={
        0x01: "input_voltage",
        0x02: "angle_limit",
        0x04: "overheating",
        0x08: "range",
        0x10: "checksum",
        0x20: "overload",
        0x40: "instruction",
    },
)

# Protocol 1.0 model numbers whose firmware answers BULK READ (0x92): MX-12W 360, MX-28 29,
# MX-64 310, MX-106 320, EX-106+ 107 (e-Manual, Protocol 1.0 "Bulk Read": "MX series and
# EX-106+ only"); the AX-12A (12), AX-12W (300) and AX-18A (18) do not.
DYNAMIXEL1_BULK_READ_MODELS = frozenset({29, 107, 310, 320, 360})

TABLES: Mapping[str, ControlTable] = {
    "dynamixel1": DYNAMIXEL_AX,
    "dynamixel2": DYNAMIXEL_X,
    "feetech_sts": FEETECH_STS,
}


def table_for_protocol(protocol: str) -> ControlTable:
    """Control table for a catalogue protocol name ("dynamixel1", "dynamixel2", "feetech_sts")."""
    try:
        return TABLES[protocol]
    except KeyError:
        raise ValueError(
            f"no control table for protocol {protocol!r}; known: {sorted(TABLES)}"
        ) from None

"""Servo side of gaitsmith, in two layers:

- `hardware.bus`: the servo-bus layer — `ServoBus` and its vendor drivers (Dynamixel Protocol
  1.0/2.0, Feetech STS) on the vendors' SDKs, wire codecs, control tables as data, the bus time
  budget, and the byte-level virtual bus that stands in for servos in every test;
- `hardware.play`: the playback application on top of it — player, safety gate, pre-flight,
  watchdog, telemetry, calibration, fault specs and the `gaitsmith-play` commands.

`hardware.errors` is shared by both; `hardware.cli` wires the commands. Imports only numpy,
pyserial and the vendor SDKs (never casadi, mujoco or sim), so it runs on a Raspberry Pi; the
MuJoCo twin behind `--virtual sim` is found through the `gaitsmith.virtual_buses` entry point.
"""

from hardware.bus.servo_bus import BusConfig, BusStats, ServoBus, ServoInfo, ServoStatus
from hardware.errors import (
    AdapterLost,
    BusError,
    CalibrationError,
    CorruptPacket,
    HardwareError,
    InvalidSetting,
    LimitError,
    NoResponse,
    PortError,
    ServoFault,
)

__all__ = [
    "AdapterLost",
    "BusConfig",
    "BusError",
    "BusStats",
    "CalibrationError",
    "CorruptPacket",
    "HardwareError",
    "InvalidSetting",
    "LimitError",
    "NoResponse",
    "PortError",
    "ServoBus",
    "ServoFault",
    "ServoInfo",
    "ServoStatus",
]

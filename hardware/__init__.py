"""Servo side of gaitsmith: ServoBus, Dynamixel/Feetech drivers, codecs, virtual bus, calibration.

Imports only numpy, pyserial and the vendor SDKs (never casadi or mujoco), so it runs on a
Raspberry Pi. Drivers: `hardware.dynamixel.DynamixelBus`, `hardware.feetech.FeetechBus`;
emulator: `hardware.virtual.VirtualServoBus`; calibration: `hardware.calibration.Calibration`.
"""

from hardware.bus import BusConfig, BusStats, ServoBus, ServoInfo, ServoStatus
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

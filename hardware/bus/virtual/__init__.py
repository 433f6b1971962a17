"""Virtual servo bus: byte-level emulation of Dynamixel 1.0 / 2.0 and Feetech STS servos."""

from hardware.bus.virtual.bus import VirtualServoBus, WireTiming
from hardware.bus.virtual.faults import NO_FAULTS, FaultPlan
from hardware.bus.virtual.port import VirtualPort
from hardware.bus.virtual.pty import PtyServer
from hardware.bus.virtual.servo import VirtualServo

__all__ = [
    "NO_FAULTS",
    "FaultPlan",
    "PtyServer",
    "VirtualPort",
    "VirtualServo",
    "VirtualServoBus",
    "WireTiming",
]

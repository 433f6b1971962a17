"""Virtual servo bus: byte-level emulation of Dynamixel 1.0 / 2.0 and Feetech STS servos."""

from hardware.virtual.bus import VirtualServoBus, WireTiming
from hardware.virtual.faults import NO_FAULTS, FaultPlan
from hardware.virtual.port import VirtualPort
from hardware.virtual.pty import PtyServer
from hardware.virtual.servo import VirtualServo

__all__ = [
    "NO_FAULTS",
    "FaultPlan",
    "PtyServer",
    "VirtualPort",
    "VirtualServo",
    "VirtualServoBus",
    "WireTiming",
]

"""Typed errors of the `hardware` package.

Hierarchy::

    HardwareError
    ├── BusError                 something went wrong on the serial bus
    │   ├── PortError            the port cannot be opened / used
    │   ├── AdapterLost          the port failed under us (USB unplugged, EIO, port closed)
    │   ├── NoResponse           a servo did not answer within the timeout
    │   ├── CorruptPacket        a reply arrived but failed its CRC/checksum or framing
    │   └── ServoFault           a servo answered with hardware-error flags set
    ├── InvalidSetting           a bus / fault-plan setting out of bounds (also a ValueError)
    ├── CalibrationError         calibration file missing, malformed or for another robot build
    ├── ImuError                 the IMU cannot be opened, is silent or too slow, or a bad setting
    └── LimitError               a joint target lies outside the joint's limits
"""

from __future__ import annotations


class HardwareError(Exception):
    """Base class of every error raised by `hardware`."""


class BusError(HardwareError):
    """A transaction on the servo bus failed."""


class PortError(BusError):
    """The serial port (device path or injected port object) cannot be opened or used."""

    def __init__(self, port: str, problem: str) -> None:
        self.port = port
        self.problem = problem
        super().__init__(f"port {port!r}: {problem}")


class AdapterLost(BusError):
    """The serial adapter failed under us: an OSError / SerialException from read, write or
    flush, or the port closed while in use (USB unplugged, pty server gone). Not retried: every
    later call on the same bus raises it again at once until the bus is closed and reopened."""

    def __init__(self, port: str, operation: str, os_error: BaseException | str) -> None:
        self.port = port
        self.operation = operation
        self.os_error = os_error
        text = " ".join(str(os_error).split()) or type(os_error).__name__
        super().__init__(f"serial adapter on {port!r} lost during {operation}: {text}")


class NoResponse(BusError):
    """Servo `servo_id` did not answer (after `attempts` tries, each bounded by the timeout)."""

    def __init__(self, servo_id: int, attempts: int = 1, detail: str = "") -> None:
        self.servo_id = servo_id
        self.attempts = attempts
        self.detail = detail
        msg = f"servo {servo_id}: no response after {attempts} attempt(s)"
        super().__init__(f"{msg}: {detail}" if detail else msg)


class CorruptPacket(BusError):
    """A packet failed its CRC/checksum or framing (`servo_id` is None when unknown)."""

    def __init__(self, detail: str, servo_id: int | None = None, attempts: int = 1) -> None:
        self.detail = detail
        self.servo_id = servo_id
        self.attempts = attempts
        who = f"servo {servo_id}: " if servo_id is not None else ""
        super().__init__(f"{who}corrupt packet ({detail}) after {attempts} attempt(s)")


class ServoFault(BusError):
    """Servo `servo_id` reports hardware-error flags (decoded names, e.g. ("overload",))."""

    def __init__(self, servo_id: int, flags: tuple[str, ...], raw: int = 0) -> None:
        self.servo_id = servo_id
        self.flags = tuple(flags)
        self.raw = raw
        names = ", ".join(self.flags) if self.flags else f"raw 0x{raw:02X}"
        super().__init__(f"servo {servo_id}: hardware fault: {names}")


class InvalidSetting(HardwareError, ValueError):
    """A bus-layer setting (timeout, baud rate, servo id, fault magnitude...) is not finite or
    out of its bounds: `what` names the setting, `problem` says what is allowed."""

    def __init__(self, what: str, problem: str) -> None:
        self.what = what
        self.problem = problem
        super().__init__(f"{what}: {problem}")


class CalibrationError(HardwareError):
    """A calibration is missing, malformed, or belongs to another robot build."""

    def __init__(self, source: str, problem: str) -> None:
        self.source = source
        self.problem = problem
        super().__init__(f"{source}: {problem}")


class LimitError(HardwareError):
    """A joint target [rad] lies outside the joint's limits [rad] (or the servo's tick range)."""

    def __init__(self, joint: str, value_rad: float, lower_rad: float, upper_rad: float) -> None:
        self.joint = joint
        self.value_rad = value_rad
        self.lower_rad = lower_rad
        self.upper_rad = upper_rad
        super().__init__(
            f"joint {joint!r}: target {value_rad:.4f} rad outside "
            f"[{lower_rad:.4f}, {upper_rad:.4f}] rad"
        )


class ImuError(HardwareError, ValueError):
    """The IMU (`hardware.imu`) cannot be opened, sends no usable frames, sends them too
    slowly for the player, or one of its settings (baud, mount) is out of bounds."""

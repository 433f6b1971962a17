"""WitMotion serial IMU (WT901 / JY901 / HWT901B / WT61 family) as the player's `AttitudeSource`.

Wire protocol (WitMotion WT901 datasheet v20-0702 §5.1.4 "Angle Output", the same in the
WT901SDCL v20-0605 §6.1.4 and BWT61CL v20-0630 §6.1.3 sheets, wiki.wit-motion.com/english):
the IMU streams 11-byte frames ``0x55, TYPE, D0..D7, SUM`` with SUM = low byte of the sum of the
first ten bytes. TYPE 0x53 is the angle frame: D0..D5 = roll (X axis), pitch (Y axis), yaw
(Z axis), each a little-endian int16 scaled by 180/32768 degrees; D6, D7 are the version (or
temperature on older models) and are ignored. The other types (0x50 time, 0x51 acceleration,
0x52 angular rate, 0x54 magnetic field, …) are checked and skipped. The datasheet's Euler angles
are Z-Y-X ("first turn around the Z-axis, then the Y-axis, then the X-axis"), i.e. the planner's
z-y'-x'' convention (`robots.attitude.roll_pitch`: R = Rz·Ry·Rx), in the IMU's own axes.

Mounting (`ImuMount`): the IMU's axes relative to the body's (x forward, y left, z up) as
R_body←imu = Rz(yaw)·Rx(roll): `yaw_deg` turns the IMU's X axis from the body's forward axis
about the body's up axis (a WT901 whose X points to the robot's right: yaw -90), `roll_deg`
180 is a board mounted upside down. The body's attitude is then R_world←body =
R_world←imu · R_body←imuᵀ, and roll, pitch are read off it in the z-y'-x'' convention (the
world yaw cancels out of both).

Reading: `WitmotionImu.read` drains whatever bytes the port holds without blocking (pyserial,
``timeout=0``), feeds them to `FrameParser` and stamps the newest angle frame with the player's
clock at that moment (so a reading is at most one tick late). The parser resynchronises on a bad
checksum by dropping one byte and searching for the next 0x55, and keeps a partial frame until its
rest arrives. A serial exception (adapter unplugged, EIO) closes the port and `read` returns None
from then on: the `AttitudeCorrector` fades the correction out; nothing is raised into the tick
loop. `open_witmotion` opens the port and listens `probe_s` for angle frames before any servo
moves: no frames, or frames slower than the player needs, is an `ImuError`.
"""

from __future__ import annotations

import math
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from hardware.errors import ImuError
from hardware.play.attitude import AttitudeReading

FRAME_BYTES = 11
HEADER = 0x55
ANGLE_TYPE = 0x53
KNOWN_TYPES = range(0x50, 0x60)  # time, acceleration, angular rate, angle, magnetic, … quaternion
ANGLE_SCALE_DEG = 180.0 / 32768.0
BAUDS = (2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600)
DEFAULT_BAUD = 9600  # the WT901 / JY901 / HWT901B factory setting (datasheet: "9600 (default)")
DEFAULT_PROBE_S = 0.5
READ_ERRORS: tuple[type[BaseException], ...] = (OSError, ValueError, TypeError)


def checksum(first_ten: bytes) -> int:
    """SUM byte of a frame: the low byte of the sum of its first ten bytes."""
    return sum(first_ten[:10]) & 0xFF


def angle_frame(roll_deg: float, pitch_deg: float, yaw_deg: float, version: int = 0) -> bytes:
    """The 11 bytes a WitMotion IMU sends for these angles (the inverse of `FrameParser`; used
    by the virtual IMU and the tests). Angles outside [-180, 180) wrap like the device's."""
    raw = [round(a / ANGLE_SCALE_DEG) for a in (roll_deg, pitch_deg, yaw_deg)]
    wrapped = [((r + 32768) % 65536) - 32768 for r in raw]
    body = bytes([HEADER, ANGLE_TYPE]) + struct.pack("<hhhH", *wrapped, version & 0xFFFF)
    return body + bytes([checksum(body)])


@dataclass(frozen=True)
class AngleFrame:
    """One decoded 0x53 frame: the IMU's own Euler angles [deg] (Z-Y-X, its axes)."""

    roll_deg: float
    pitch_deg: float
    yaw_deg: float


class FrameParser:
    """Byte stream → angle frames, resynchronising on garbage (module docstring)."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.angle_frames = 0
        self.other_frames = 0
        self.bad_checksums = 0
        self.skipped_bytes = 0

    def feed(self, data: bytes) -> list[AngleFrame]:
        """The angle frames completed by `data`, oldest first."""
        self._buf += data
        out: list[AngleFrame] = []
        buf = self._buf
        i = 0
        while True:
            start = buf.find(HEADER, i)
            if start < 0:
                self.skipped_bytes += len(buf) - i
                i = len(buf)
                break
            self.skipped_bytes += start - i
            i = start
            if len(buf) - i < FRAME_BYTES:
                break  # a partial frame: keep it for the next feed
            frame = bytes(buf[i:i + FRAME_BYTES])
            if frame[1] not in KNOWN_TYPES or checksum(frame) != frame[10]:
                self.bad_checksums += 1
                self.skipped_bytes += 1
                i += 1  # resync: this 0x55 was not a frame start
                continue
            if frame[1] == ANGLE_TYPE:
                r, p, y = struct.unpack_from("<hhh", frame, 2)
                out.append(AngleFrame(r * ANGLE_SCALE_DEG, p * ANGLE_SCALE_DEG,
                                      y * ANGLE_SCALE_DEG))
                self.angle_frames += 1
            else:
                self.other_frames += 1
            i += FRAME_BYTES
        del buf[:i]
        return out


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class ImuMount:
    """The IMU's axes in the body's: R_body←imu = Rz(yaw_deg)·Rx(roll_deg) (module docstring)."""

    yaw_deg: float = 0.0
    roll_deg: float = 0.0

    def __post_init__(self) -> None:
        for name, value in (("yaw", self.yaw_deg), ("roll", self.roll_deg)):
            if not (math.isfinite(value) and -180.0 <= value <= 180.0):
                raise ImuError(f"IMU mount {name} must be in [-180, 180] degrees, got {value!r}")

    def body_roll_pitch(self, frame: AngleFrame) -> tuple[float, float]:
        """The body's roll, pitch [rad] (z-y'-x'') for the IMU's own Euler angles."""
        r_world_imu = (_rz(math.radians(frame.yaw_deg)) @ _ry(math.radians(frame.pitch_deg))
                       @ _rx(math.radians(frame.roll_deg)))
        r_body_imu = _rz(math.radians(self.yaw_deg)) @ _rx(math.radians(self.roll_deg))
        r = r_world_imu @ r_body_imu.T
        roll = math.atan2(r[2, 1], r[2, 2])
        pitch = -math.asin(max(-1.0, min(1.0, r[2, 0])))
        return roll, pitch


def parse_mount(spec: str) -> ImuMount:
    """``"yaw=-90"``, ``"yaw=90,roll=180"``, ``""`` → `ImuMount` (ImuError on anything else)."""
    values: dict[str, float] = {}
    for part in (p.strip() for p in spec.split(",")):
        if not part:
            continue
        key, sep, value = part.partition("=")
        key = key.strip()
        if not sep or key not in ("yaw", "roll") or key in values:
            raise ImuError(f"IMU mount {spec!r}: expected yaw=DEG and/or roll=DEG, each once "
                           "(e.g. yaw=-90,roll=180)")
        try:
            values[key] = float(value)
        except ValueError:
            raise ImuError(f"IMU mount {spec!r}: {key}={value.strip()!r} is not a number of "
                           "degrees") from None
    return ImuMount(values.get("yaw", 0.0), values.get("roll", 0.0))


class SerialLike(Protocol):
    """What `WitmotionImu` needs of a port: pyserial's `in_waiting`, `read`, `close`."""

    @property
    def in_waiting(self) -> int: ...

    def read(self, size: int = 1) -> bytes: ...

    def close(self) -> None: ...


class WitmotionImu:
    """`AttitudeSource` over a WitMotion IMU's byte stream (module docstring). `clock` is the
    player's clock (readings are stamped on it)."""

    def __init__(self, port: SerialLike, clock: Callable[[], float],
                 mount: ImuMount = ImuMount(), name: str = "") -> None:
        self.port, self.clock, self.mount, self.name = port, clock, mount, name
        self.parser = FrameParser()
        self.error: str | None = None  # why the port failed (then no more readings)
        self.last_frame: AngleFrame | None = None
        self._last: AttitudeReading | None = None

    def poll(self) -> int:
        """Drain the port into the parser; the number of new angle frames (0 after a failure)."""
        if self.error is not None:
            return 0
        try:
            data = self.port.read(self.port.in_waiting or 0)
        except READ_ERRORS as exc:  # serial.SerialException is an OSError
            self.error = " ".join(str(exc).split()) or type(exc).__name__
            self.close()
            return 0
        frames = self.parser.feed(data) if data else []
        if frames:
            self.last_frame = frames[-1]
            roll, pitch = self.mount.body_roll_pitch(frames[-1])
            self._last = AttitudeReading(roll, pitch, self.clock())
        return len(frames)

    def read(self) -> AttitudeReading | None:
        self.poll()
        return None if self.error is not None else self._last

    def close(self) -> None:
        try:
            self.port.close()
        except READ_ERRORS:
            pass

    def summary(self) -> str:
        p = self.parser
        text = (f"imu {self.name}: {p.angle_frames} angle frames, {p.other_frames} other, "
                f"{p.bad_checksums} bad checksums, {p.skipped_bytes} bytes skipped")
        return text if self.error is None else f"{text}; port lost: {self.error}"


def open_witmotion(path: str, baud: int, clock: Callable[[], float], mount: ImuMount = ImuMount(),
                   *, min_rate_hz: float, probe_s: float = DEFAULT_PROBE_S) -> WitmotionImu:
    """Open `path` at `baud`, listen `probe_s` [s] and return the source; ImuError (a
    one-line reason) when the port cannot be opened, no angle frame arrives, or they arrive
    slower than `min_rate_hz`."""
    import serial  # pyserial

    if baud not in BAUDS:
        raise ImuError(f"baud {baud} is not a WitMotion rate (one of "
                       f"{', '.join(map(str, BAUDS))})")
    try:
        port = serial.Serial(path, baud, timeout=0)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise ImuError(f"cannot open: {' '.join(str(exc).split())}") from None
    imu = WitmotionImu(port, clock, mount, name=path)
    frames = 0
    end = time.monotonic() + probe_s
    while time.monotonic() < end and imu.error is None:
        frames += imu.poll()
        time.sleep(0.002)
    rate = frames / probe_s
    problem = None
    if imu.error is not None:
        problem = f"failed while listening: {imu.error}"
    elif not frames:
        problem = (f"no WitMotion angle frames (0x55 0x53) in {probe_s:g} s at {baud} baud "
                   f"({imu.parser.skipped_bytes} bytes of noise); check the wiring and the "
                   "IMU's baud rate")
    elif rate < min_rate_hz:
        problem = (f"angle frames arrive at {rate:.0f} Hz, the player needs at least "
                   f"{min_rate_hz:.0f} Hz; set the IMU's output rate to 100 Hz or more "
                   "(WitMotion software, RATE register) and its baud to 115200")
    if problem is not None:
        imu.close()
        raise ImuError(problem)
    return imu


__all__ = [
    "ANGLE_TYPE",
    "BAUDS",
    "DEFAULT_BAUD",
    "AngleFrame",
    "FrameParser",
    "ImuMount",
    "WitmotionImu",
    "angle_frame",
    "checksum",
    "open_witmotion",
    "parse_mount",
]

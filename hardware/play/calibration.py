"""Joint ↔ servo calibration: zero offset [ticks], direction, ticks per radian, limits [rad].

    ticks = zero_offset_ticks + direction · angle_rad · ticks_per_rad        (rounded)
    angle_rad = (ticks − zero_offset_ticks) / (direction · ticks_per_rad)

A calibration belongs to one robot build: it is stored as JSON keyed by the robot's name and
fingerprint (hash of robot.xml + robot.toml) and refuses to load for another build.
Files are written atomically (temp file in the same folder + os.replace).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from hardware.errors import CalibrationError, LimitError
from robots.gait import atomic_write_text

SCHEMA = "gaitsmith.calibration/1"
ENV_DIR = "GAITSMITH_CALIBRATION_DIR"


@dataclass(frozen=True)
class JointCalibration:
    """One joint: servo `bus_id`, tick at angle 0, sign, scale and limits."""

    name: str
    bus_id: int
    direction: int
    zero_offset_ticks: int
    ticks_per_rad: float
    lower_rad: float
    upper_rad: float
    min_tick: int
    max_tick: int

    def __post_init__(self) -> None:
        if self.direction not in (1, -1):
            raise CalibrationError(self.name, f"direction must be +1 or -1, got {self.direction}")
        if not (math.isfinite(self.ticks_per_rad) and self.ticks_per_rad > 0):
            raise CalibrationError(self.name, "ticks_per_rad must be a positive number")
        if not self.lower_rad < self.upper_rad:
            raise CalibrationError(self.name, "lower_rad must be below upper_rad")

    def rad_to_ticks(self, angle_rad: float) -> int:
        """Goal ticks for `angle_rad`; LimitError (naming the joint) outside the limits."""
        if not (math.isfinite(angle_rad) and self.lower_rad <= angle_rad <= self.upper_rad):
            raise LimitError(self.name, angle_rad, self.lower_rad, self.upper_rad)
        ticks = round(self.zero_offset_ticks + self.direction * angle_rad * self.ticks_per_rad)
        if not self.min_tick <= ticks <= self.max_tick:
            lo, hi = sorted(self.ticks_to_rad(t) for t in (self.min_tick, self.max_tick))
            raise LimitError(self.name, angle_rad, lo, hi)
        return ticks

    def ticks_to_rad(self, ticks: float) -> float:
        return (ticks - self.zero_offset_ticks) / (self.direction * self.ticks_per_rad)


@dataclass(frozen=True)
class Calibration:
    """Calibration of every joint of one robot build, in the robot's joint order."""

    robot: str
    fingerprint: str
    joints: tuple[JointCalibration, ...]

    @classmethod
    def from_robot(cls, robot: Any) -> Calibration:
        """Nominal calibration from the robot description (robot.toml offsets, catalogue scale)."""
        return cls(
            robot=robot.name,
            fingerprint=robot.fingerprint,
            joints=tuple(
                JointCalibration(
                    name=j.name,
                    bus_id=j.bus_id,
                    direction=j.direction,
                    zero_offset_ticks=j.zero_offset_ticks,
                    ticks_per_rad=j.servo.ticks_per_rad,
                    lower_rad=j.lower_rad,
                    upper_rad=j.upper_rad,
                    min_tick=j.servo.position_min_tick,
                    max_tick=j.servo.position_max_tick,
                )
                for j in robot.joints
            ),
        )

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def bus_ids(self) -> tuple[int, ...]:
        return tuple(j.bus_id for j in self.joints)

    def joint(self, name: str) -> JointCalibration:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"no joint {name!r}; known: {list(self.joint_names)}")

    def rad_to_ticks(self, angles_rad: Sequence[float]) -> dict[int, int]:
        """{bus id: goal ticks} for one angle per joint (joint order); LimitError if outside."""
        if len(angles_rad) != len(self.joints):
            raise ValueError(f"expected {len(self.joints)} angles, got {len(angles_rad)}")
        return {
            j.bus_id: j.rad_to_ticks(float(q)) for j, q in zip(self.joints, angles_rad, strict=True)
        }

    def ticks_to_rad(self, ticks: Mapping[int, float]) -> tuple[float, ...]:
        """Joint angles [rad] (joint order) from {bus id: present ticks}."""
        missing = [j.bus_id for j in self.joints if j.bus_id not in ticks]
        if missing:
            raise KeyError(f"no reading for bus ids {missing}")
        return tuple(j.ticks_to_rad(ticks[j.bus_id]) for j in self.joints)

    def with_zero_offsets(self, offsets: Mapping[str, int]) -> Calibration:
        """A copy with new zero offsets [ticks] for the named joints (e.g. after homing)."""
        unknown = sorted(set(offsets) - set(self.joint_names))
        if unknown:
            raise KeyError(f"no joints {unknown}")
        return replace(
            self,
            joints=tuple(
                replace(j, zero_offset_ticks=int(offsets[j.name])) if j.name in offsets else j
                for j in self.joints
            ),
        )

    # -- persistence --------------------------------------------------------------------------
    def to_json(self) -> str:
        doc = {
            "schema": SCHEMA,
            "robot": self.robot,
            "fingerprint": self.fingerprint,
            "joints": [asdict(j) for j in self.joints],
        }
        return json.dumps(doc, indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str, source: str = "<json>") -> Calibration:
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CalibrationError(source, f"not valid JSON: {exc}") from None
        if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
            raise CalibrationError(source, f"schema must be {SCHEMA!r}")
        for key in ("robot", "fingerprint"):
            if not isinstance(doc.get(key), str):
                raise CalibrationError(source, f"{key}: missing or not a string")
        joints = doc.get("joints")
        if not isinstance(joints, list) or not joints:
            raise CalibrationError(source, "joints: missing or empty")
        parsed = []
        for i, entry in enumerate(joints):
            try:
                parsed.append(JointCalibration(**entry))
            except (TypeError, ValueError) as exc:
                raise CalibrationError(source, f"joints[{i}]: {exc}") from None
        return cls(doc["robot"], doc["fingerprint"], tuple(parsed))

    def save(self, path: str | Path) -> Path:
        """Write atomically (temp file + os.replace); returns the path."""
        path = Path(path)
        atomic_write_text(path, self.to_json())
        return path

    @classmethod
    def load(cls, path: str | Path, robot: Any | None = None) -> Calibration:
        """Read a calibration; with `robot`, refuse one made for another build."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise CalibrationError(str(path), f"cannot read: {exc.strerror or exc}") from None
        cal = cls.from_json(text, str(path))
        if robot is not None:
            cal.check_robot(robot, str(path))
        return cal

    def check_robot(self, robot: Any, source: str = "calibration") -> None:
        if self.robot != robot.name or self.fingerprint != robot.fingerprint:
            raise CalibrationError(
                source,
                f"made for {self.robot}@{self.fingerprint}, "
                f"not {robot.name}@{robot.fingerprint} (robot build changed: recalibrate)",
            )
        names = tuple(j.name for j in robot.joints)
        if self.joint_names != names:
            raise CalibrationError(source, f"joints {self.joint_names} != robot's {names}")


def default_path(robot: Any, directory: str | Path | None = None) -> Path:
    """Where a robot build's calibration lives: $GAITSMITH_CALIBRATION_DIR or
    ~/.config/gaitsmith/calibration, file `<robot>-<fingerprint>.json`."""
    base = Path(
        directory
        or os.environ.get(ENV_DIR)
        or Path.home() / ".config" / "gaitsmith" / "calibration"
    )
    return base / f"{robot.name}-{robot.fingerprint}.json"


def load_or_default(robot: Any, directory: str | Path | None = None) -> Calibration:
    """The stored calibration for this build, else the nominal one from the robot description."""
    path = default_path(robot, directory)
    if path.exists():
        return Calibration.load(path, robot)
    return Calibration.from_robot(robot)

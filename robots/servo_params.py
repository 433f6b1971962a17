"""The servo-parameters file: each joint's servo as identified on the robot (issue #18 item 6).

TOML, written by `gaitsmith identify` and read by `sim` (simulate / validate, the MuJoCo twin)
and by the planner's servo-goal output (`planner.nlp.servo_loop`)::

    schema = "gaitsmith.servo_params/1"
    robot = "quad12"                      # the robot it was identified on (checked)

    [joints.fl_knee]
    gain_scale = 1.18     # position gain × the factory gain (`robots.servo.factory_gains`)
    latency_ms = 6.1      # delay of a goal from the player's write to the servo acting on it
    strength = 0.83       # drive limit × the catalogue stall torque (torque saturation)
    # informative, written by the fit, ignored by readers:
    # servo, kp_nm_per_rad, drive_limit_nm, train_rms_deg, held_out_rms_deg, samples

What the three numbers mean in the servo model (`sim.servo`): with τ_stall the catalogue stall
torque and g_p the factory duty per radian, the drive limit is strength·τ_stall, the position
gain kp = gain_scale·g_p·strength·τ_stall [N·m/rad] and the back-EMF slope strength·τ_stall/ω₀;
the goal written at t acts from t + latency_ms. A joint the file does not list keeps the
factory servo (gain_scale 1, latency 0, strength 1). Every problem is a `RobotConfigError`
naming the file, the joint and the field.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robots.errors import RobotConfigError
from robots.files import atomic_write_text
from robots.toml_schema import check_keys, number, read_toml, string, table

if TYPE_CHECKING:
    from robots.robot import Robot

SCHEMA = "gaitsmith.servo_params/1"
MAX_GAIN_SCALE = 20.0
MAX_LATENCY_MS = 500.0
MAX_STRENGTH = 5.0
SETTING_KEYS = {"gain_scale", "latency_ms", "strength"}
INFO_KEYS = {
    "servo", "kp_nm_per_rad", "drive_limit_nm", "train_rms_deg", "held_out_rms_deg", "samples"
}  # fmt: skip


@dataclass(frozen=True)
class ServoSetting:
    """One joint's servo relative to its catalogue/factory model (see the module docstring)."""

    gain_scale: float = 1.0
    latency_ms: float = 0.0
    strength: float = 1.0

    def __post_init__(self) -> None:
        for key, lo, hi in (
            ("gain_scale", 0.0, MAX_GAIN_SCALE),
            ("strength", 0.0, MAX_STRENGTH),
        ):
            v = getattr(self, key)
            if not (math.isfinite(v) and lo < v <= hi):
                raise ValueError(f"{key} must lie in ({lo:g}, {hi:g}], got {v!r}")
        if not (math.isfinite(self.latency_ms) and 0.0 <= self.latency_ms <= MAX_LATENCY_MS):
            raise ValueError(
                f"latency_ms must lie in [0, {MAX_LATENCY_MS:g}], got {self.latency_ms!r}"
            )

    @property
    def latency_s(self) -> float:
        return self.latency_ms / 1000.0


FACTORY = ServoSetting()


@dataclass(frozen=True)
class ServoParamsFile:
    """The settings per joint name, for robot `robot` (`source`: where it was read from)."""

    robot: str
    joints: Mapping[str, ServoSetting]
    source: str = "<memory>"

    def for_robot(self, robot: Robot) -> tuple[ServoSetting, ...]:
        """One setting per joint in `robot.joints` order (unlisted joints: factory); refuses a
        file identified on another robot or naming a joint the robot does not have."""
        if self.robot != robot.name:
            raise RobotConfigError(
                self.source, "robot",
                f"identified on robot {self.robot!r}, not {robot.name!r}; identify this robot "
                "(`gaitsmith identify`) or give its own file",
            )  # fmt: skip
        names = set(robot.joint_names)
        for name in self.joints:
            if name not in names:
                raise RobotConfigError(
                    self.source, f"joints.{name}",
                    f"robot {robot.name} has no joint {name!r}; joints: "
                    f"{', '.join(robot.joint_names)}",
                )  # fmt: skip
        return tuple(self.joints.get(n, FACTORY) for n in robot.joint_names)


def parse(text: str, source: str) -> ServoParamsFile:
    """A servo-parameters file from its TOML text (errors name `source`)."""
    data = read_toml(text, source)
    check_keys(source, "<top>", data, {"schema", "robot", "joints"})
    schema = string(source, "schema", data.get("schema"))
    if schema != SCHEMA:
        raise RobotConfigError(source, "schema", f"is {schema!r}; expected {SCHEMA!r}")
    robot = string(source, "robot", data.get("robot"))
    joints: dict[str, ServoSetting] = {}
    for name, entry in table(source, "joints", data.get("joints")).items():
        where = f"joints.{name}"
        entry = table(source, where, entry)
        check_keys(source, where, entry, SETTING_KEYS | INFO_KEYS)
        values: dict[str, Any] = {}
        if "gain_scale" in entry:
            values["gain_scale"] = number(
                source, f"{where}.gain_scale", entry["gain_scale"], 0.0, MAX_GAIN_SCALE,
                lo_open=True,
            )  # fmt: skip
        if "latency_ms" in entry:
            values["latency_ms"] = number(
                source, f"{where}.latency_ms", entry["latency_ms"], 0.0, MAX_LATENCY_MS, unit="ms"
            )
        if "strength" in entry:
            values["strength"] = number(
                source, f"{where}.strength", entry["strength"], 0.0, MAX_STRENGTH, lo_open=True
            )
        joints[name] = ServoSetting(**values)
    return ServoParamsFile(robot=robot, joints=joints, source=source)


def load(path: str | Path) -> ServoParamsFile:
    """Read a servo-parameters file; a missing or unreadable file is a `RobotConfigError`."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RobotConfigError(
            str(p), "<file>", "not found; write it with `gaitsmith identify`"
        ) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotConfigError(str(p), "<file>", f"cannot read it: {exc}") from None
    return parse(text, str(p))


def _toml_value(v: Any) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    return f"{float(v):.6g}"


def dumps(
    params: ServoParamsFile, info: Mapping[str, Mapping[str, Any]] | None = None,
    header: str = "",
) -> str:  # fmt: skip
    """TOML text of `params`; `info` adds the informative keys per joint (`INFO_KEYS`)."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    lines += [f"schema = {_toml_value(SCHEMA)}", f"robot = {_toml_value(params.robot)}"]
    for name, s in params.joints.items():
        lines += ["", f'[joints."{name}"]']
        lines += [f"gain_scale = {_toml_value(s.gain_scale)}"]
        lines += [f"latency_ms = {_toml_value(s.latency_ms)}"]
        lines += [f"strength = {_toml_value(s.strength)}"]
        for key, value in (info or {}).get(name, {}).items():
            if key not in INFO_KEYS:
                raise ValueError(f"{key!r} is not an informative servo-parameter key")
            lines.append(f"{key} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


def save(
    path: str | Path, params: ServoParamsFile,
    info: Mapping[str, Mapping[str, Any]] | None = None, header: str = "",
) -> None:  # fmt: skip
    """Write the file atomically (never half-written)."""
    atomic_write_text(path, dumps(params, info, header))

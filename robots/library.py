"""The gait library file: gaits over a grid of commands for one robot build (numpy only).

JSON with ``"schema": "gaitsmith.library/1"`` (issue #15 item 2). Layout:

- ``robot``, ``robot_fingerprint``, ``joint_names``: the build, as in a gait file.
- ``family``: the schedule family every walking entry shares ("trot", "tripod", …): one contact
  schedule (touchdown phases, duty factors) and one knot count, so entries can be blended at
  equal phase (`robots.blend`). Periods may differ between entries (the period law: the blender
  interpolates the period with the same weights as the joint targets).
- ``stand``: a gait file document (``gaitsmith.gait/1``) with every foot down, zero velocity.
- ``entries``: ``[{"command": {vx_m_s, vy_m_s, yaw_rate_rad_s}, "achieved": {…}, "gait": {…}}]``
  — each gait was planned for `command` (its ``velocity``) and passed MuJoCo validation
  (``validation.passed`` true); `achieved` is what MuJoCo measured
  (``validation.metrics.achieved_*``). Commands are distinct.
- ``built``: build metadata (time per entry, the entries left out and why, versions).

The stand → walk and walk → stand transitions are not stored as samples: they are computed from
the stand and the entries by `robots.blend.GaitBlender` with `robots.ramp`'s entry blend, the
same way the player and the simulator start a single gait.

Loading checks everything and raises `LibraryFileError` with one line naming the file and the
field at fault (``entries[3].gait.joint_angles_rad[2][1]: …``); with a robot it also refuses a
different build by fingerprint, like a gait file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robots import gait as gaitfile
from robots.errors import GaitFileError, LibraryFileError
from robots.files import atomic_write_text
from robots.gait import Gait, Velocity

if TYPE_CHECKING:
    from robots.robot import Robot

SCHEMA = "gaitsmith.library/1"
MAX_LIBRARY_BYTES = 512 << 20
MAX_ENTRIES = 1000
SCHEDULE_TOL = 1e-9  # touchdown phases / duty factors must agree to this between entries
COMMAND_TOL = 1e-9  # an entry's command must be its gait's velocity to this
_KEYS = {"schema", "robot", "robot_fingerprint", "joint_names", "family", "stand", "entries",
         "built"}
_ENTRY_KEYS = {"command", "achieved", "gait"}
_VELOCITY_KEYS = ("vx_m_s", "vy_m_s", "yaw_rate_rad_s")


def velocity_tuple(v: Velocity) -> tuple[float, float, float]:
    return (float(v.vx_m_s), float(v.vy_m_s), float(v.yaw_rate_rad_s))


@dataclass(frozen=True)
class LibraryEntry:
    command: Velocity  # (vx_m_s, vy_m_s, yaw_rate_rad_s) this gait was planned for
    gait: Gait  # validated in MuJoCo (gait.validation filled, passed)
    achieved: Velocity  # what MuJoCo measured (validation.metrics.achieved_*)


@dataclass(frozen=True)
class GaitLibrary:
    robot: str
    robot_fingerprint: str
    joint_names: tuple[str, ...]
    family: str  # the schedule family shared by the walking entries
    stand: Gait  # the stand (all feet down), speed 0
    entries: tuple[LibraryEntry, ...]  # the walking grid (the stand is not in it)
    built: dict[str, Any] = field(default_factory=dict)

    def command_bounds(self) -> tuple[Velocity, Velocity]:
        """The grid's box: (min, max) of the entries' commands per axis."""
        c = np.array([velocity_tuple(e.command) for e in self.entries])
        lo, hi = c.min(axis=0), c.max(axis=0)
        return Velocity(*(float(x) for x in lo)), Velocity(*(float(x) for x in hi))

    def check_robot(self, robot: Robot, file: str = "<library>") -> None:
        """Raise LibraryFileError unless built for `robot` (fingerprint, joints, limits)."""
        if self.robot_fingerprint != robot.fingerprint:
            raise LibraryFileError(
                file,
                "robot_fingerprint",
                f"library was built for {self.robot}@{self.robot_fingerprint}, robot is "
                f"{robot.name}@{robot.fingerprint}; rebuild the library for this robot "
                "(gaitsmith library)",
            )
        for where, g in [("stand", self.stand)] + [
            (f"entries[{i}].gait", e.gait) for i, e in enumerate(self.entries)
        ]:
            try:
                g.check_robot(robot, file)
            except GaitFileError as exc:
                raise LibraryFileError(file, f"{where}.{exc.field}", exc.problem) from None


# ---------------------------------------------------------------------------------------------
# (de)serialisation


def _velocity_dict(v: Velocity) -> dict[str, float]:
    return dict(zip(_VELOCITY_KEYS, velocity_tuple(v), strict=True))


def to_dict(library: GaitLibrary, path: str | Path | None = None) -> dict[str, Any]:
    """The JSON document; `path` (where it will be written) sets the gaits' relative robot_dir."""
    return {
        "schema": SCHEMA,
        "robot": library.robot,
        "robot_fingerprint": library.robot_fingerprint,
        "joint_names": list(library.joint_names),
        "family": library.family,
        "stand": gaitfile.to_dict(library.stand, path),
        "entries": [
            {
                "command": _velocity_dict(e.command),
                "achieved": _velocity_dict(e.achieved),
                "gait": gaitfile.to_dict(e.gait, path),
            }
            for e in library.entries
        ],
        "built": library.built,
    }


def _str(file: str, d: dict[str, Any], key: str) -> str:
    return gaitfile._str(file, d, key, LibraryFileError)


def _velocity(file: str, where: str, v: Any) -> Velocity:
    if not isinstance(v, dict) or set(v) != set(_VELOCITY_KEYS):
        raise LibraryFileError(file, where, "needs exactly vx_m_s, vy_m_s, yaw_rate_rad_s")
    bounds = (gaitfile.MAX_SPEED_M_S, gaitfile.MAX_SPEED_M_S, gaitfile.MAX_YAW_RATE_RAD_S)
    try:
        return Velocity(*(gaitfile._num(file, f"{where}.{k}", v[k], b)
                          for k, b in zip(_VELOCITY_KEYS, bounds, strict=True)))
    except LibraryFileError:
        raise
    except GaitFileError as exc:
        raise LibraryFileError(file, exc.field, exc.problem) from None


def _gait(file: str, where: str, d: Any) -> Gait:
    try:
        return gaitfile.from_dict(d, file)
    except GaitFileError as exc:
        raise LibraryFileError(file, f"{where}.{exc.field}", exc.problem) from None


def _check_same_build(file: str, where: str, g: Gait, fingerprint: str,
                      names: tuple[str, ...]) -> None:
    if g.robot_fingerprint != fingerprint:
        raise LibraryFileError(
            file, f"{where}.robot_fingerprint",
            f"{g.robot_fingerprint!r} differs from the library's {fingerprint!r}",
        )
    if g.joint_names != names:
        raise LibraryFileError(file, f"{where}.joint_names", "differ from the library's")


def _entry(file: str, i: int, d: Any, fingerprint: str, names: tuple[str, ...]) -> LibraryEntry:
    where = f"entries[{i}]"
    if not isinstance(d, dict):
        raise LibraryFileError(file, where, "must be a JSON object")
    if set(d) != _ENTRY_KEYS:
        raise LibraryFileError(file, where, "needs exactly command, achieved, gait")
    command = _velocity(file, f"{where}.command", d["command"])
    achieved = _velocity(file, f"{where}.achieved", d["achieved"])
    g = _gait(file, f"{where}.gait", d["gait"])
    _check_same_build(file, f"{where}.gait", g, fingerprint, names)
    gap = np.abs(np.subtract(velocity_tuple(command), velocity_tuple(g.velocity)))
    if float(gap.max()) > COMMAND_TOL:
        raise LibraryFileError(
            file, f"{where}.command", f"{velocity_tuple(command)} is not the gait's velocity "
            f"{velocity_tuple(g.velocity)}",
        )
    if not (isinstance(g.validation, dict) and g.validation.get("passed") is True):
        raise LibraryFileError(
            file, f"{where}.gait.validation",
            "missing or not passed: a library holds only gaits that passed MuJoCo validation",
        )
    return LibraryEntry(command=command, gait=g, achieved=achieved)


def _check_family(file: str, family: str, entries: tuple[LibraryEntry, ...]) -> None:
    ref = entries[0].gait
    for i, e in enumerate(entries):
        g, where = e.gait, f"entries[{i}].gait"
        if g.gait_label != family:
            raise LibraryFileError(
                file, f"{where}.gait_label", f"{g.gait_label!r} is not the family {family!r}"
            )
        if g.n_knots != ref.n_knots:
            raise LibraryFileError(
                file, f"{where}.joint_angles_rad",
                f"has {g.n_knots} knots, entries[0] {ref.n_knots}: blending at equal phase "
                "needs one knot count",
            )
        s, r = g.schedule, ref.schedule
        same = s.feet == r.feet and all(
            abs(a - b) <= SCHEDULE_TOL
            for a, b in zip(s.touchdown_phase + s.duty_factor, r.touchdown_phase + r.duty_factor,
                            strict=True)
        )
        if not same:
            raise LibraryFileError(
                file, f"{where}.schedule",
                "touchdown phases / duty factors differ from entries[0]'s: blending at equal "
                "phase needs one schedule",
            )
    seen: dict[tuple[float, float, float], int] = {}
    for i, e in enumerate(entries):
        key = velocity_tuple(e.command)
        if key in seen:
            raise LibraryFileError(
                file, f"entries[{i}].command", f"{key} repeats entries[{seen[key]}]'s"
            )
        seen[key] = i


def from_dict(d: Any, file: str = "<library>") -> GaitLibrary:
    """Validate a parsed library document; raises LibraryFileError naming the field at fault."""
    d = gaitfile.check_document(d, file, SCHEMA, _KEYS, LibraryFileError)
    robot = _str(file, d, "robot")
    fingerprint = _str(file, d, "robot_fingerprint")
    family = _str(file, d, "family")
    raw_names = d.get("joint_names")
    if not (isinstance(raw_names, list) and raw_names
            and all(isinstance(n, str) and n for n in raw_names)):
        raise LibraryFileError(file, "joint_names", "must be a non-empty list of joint names")
    names = tuple(raw_names)
    if "stand" not in d:
        raise LibraryFileError(file, "stand", "missing: a library needs its stand")
    stand = _gait(file, "stand", d["stand"])
    _check_same_build(file, "stand", stand, fingerprint, names)
    if any(x != 0.0 for x in velocity_tuple(stand.velocity)):
        raise LibraryFileError(file, "stand.velocity", "must be zero")
    if any(f < 1.0 for f in stand.schedule.duty_factor):
        raise LibraryFileError(file, "stand.schedule.duty_factor", "must be 1 (all feet down)")
    raw_entries = d.get("entries")
    if not isinstance(raw_entries, list) or not raw_entries:
        raise LibraryFileError(file, "entries", "must be a non-empty list of walking entries")
    if len(raw_entries) > MAX_ENTRIES:
        raise LibraryFileError(
            file, "entries", f"has {len(raw_entries)} entries; at most {MAX_ENTRIES}"
        )
    entries = tuple(_entry(file, i, e, fingerprint, names) for i, e in enumerate(raw_entries))
    _check_family(file, family, entries)
    built = d.get("built", {})
    if not isinstance(built, dict):
        raise LibraryFileError(file, "built", "must be a JSON object")
    return GaitLibrary(robot, fingerprint, names, family, stand, entries, dict(built))


def loads(text: str, file: str = "<library>") -> GaitLibrary:
    doc = gaitfile.parse_json_text(text, file, MAX_LIBRARY_BYTES, LibraryFileError)
    return from_dict(doc, file)


def load(path: str | Path, robot: Robot | None = None) -> GaitLibrary:
    """Read and validate a library file; with `robot`, also check it was built for that build."""
    file, doc = gaitfile.read_json_file(path, MAX_LIBRARY_BYTES, LibraryFileError)
    library = from_dict(doc, file)
    if robot is not None:
        library.check_robot(robot, file)
    return library


def dumps(library: GaitLibrary, path: str | Path | None = None) -> str:
    try:
        return json.dumps(to_dict(library, path), indent=None, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise LibraryFileError("<library>", "built/planner/validation",
                               f"not JSON-serialisable: {exc}") from None


def save(library: GaitLibrary, path: str | Path) -> None:
    """Write the library atomically (temp file + rename): never a half-written file."""
    text = dumps(library, path)
    from_dict(json.loads(text), str(path))  # never write a file `load` would refuse
    atomic_write_text(path, text + "\n")


def robot_for(
    library: GaitLibrary,
    library_path: str | Path | None = None,
    robot: str | Path | None = None,
    servo_catalogue: str | Path | None = None,
) -> Robot:
    """The robot a library was built for (found like a gait's, `robots.gait.robot_for`),
    checked against its fingerprint."""
    file = str(library_path) if library_path is not None else "<library>"
    try:
        found = gaitfile.robot_for(library.stand, library_path, robot, servo_catalogue)
    except LibraryFileError:
        raise
    except GaitFileError as exc:
        raise LibraryFileError(file, f"stand.{exc.field}", exc.problem) from None
    library.check_robot(found, file)
    return found

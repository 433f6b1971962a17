"""The gait file: the contract between planner, simulator and player.

JSON with ``"schema": "gaitsmith.gait/1"``. Layout (all angles in radians, SI units):

- ``robot``, ``robot_fingerprint``: the build it was planned for (see `Robot.fingerprint`).
- ``joint_names``: the order of the sample columns.
- ``period_s``; ``velocity``: ``{"vx_m_s", "vy_m_s", "yaw_rate_rad_s"}`` commanded.
- ``joint_angles_rad``: N+1 rows at phases k/N, k = 0..N; the last row closes the cycle and must
  repeat the first (|Δ| ≤ 1e-6 rad) — that is how a file proves it is periodic. Consumers
  interpolate the first N rows with a periodic cubic spline (`Gait.joint_targets`).
- ``schedule``: ``{"feet", "touchdown_phase", "duty_factor"}`` (see `ContactSchedule`).
- ``gait_label``: "trot", "tripod", ….
- ``expected_joint_angles_rad`` (optional, N × J over the N knots): when the samples are servo
  *goals* (a servo's position loop sags and lags, so the planner commands goals that make it
  reach the planned motion), the joint angles the robot is expected to reach. Absent: the
  samples are themselves the expected angles. `Gait.expected_joint_angles` interpolates either.
- optional per-knot arrays over the N knots: ``base_pose`` (N × 6: x, y, z [m], roll, pitch, yaw
  [rad], treadmill frame — the forward progress v·t removed), ``contact_forces_n`` (N × feet × 3,
  world frame), ``joint_torques_nm`` (N × joints).
- ``planner``: metadata (objective terms, solver stats, seed, package versions);
  ``validation``: written by `sim` (verdict, metrics), or null.
- ``robot_dir`` (optional): where the user's robot folder is, ``{"absolute": "/…/mybot",
  "relative": "../mybot"}`` (relative to the gait file's folder); absent for built-in robots.
  `robot_for` finds the robot: ``--robot`` override > relative to the gait file > the stored
  absolute path > the robot name (built-in, or a folder of that name in the working directory);
  the fingerprint still refuses a different build.

Loading bounds sizes and magnitudes (issue #12): at most `MAX_KNOTS` knots, `MAX_JOINTS` joints,
`MAX_FEET` feet, `MAX_GAIT_BYTES` of text; numbers must be JSON numbers (not strings) of
plausible size (`period_s` ≤ `MAX_PERIOD_S`, angles ≤ `MAX_ANGLE_RAD`, …); anything else is a
`GaitFileError` naming the field.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robots.errors import GaitFileError, RobotsError
from robots.files import atomic_write_text
from robots.schedule import ContactSchedule, ScheduleError
from robots.spline import PeriodicSpline

if TYPE_CHECKING:
    from robots.robot import Robot

SCHEMA = "gaitsmith.gait/1"
PERIODIC_TOL_RAD = 1e-6
MAX_GAIT_BYTES = 64 << 20  # 1000 knots × 256 joints with every optional array fits
MAX_KNOTS = 1000  # the periodic spline solves a dense N × N system (8 MB at the bound)
MAX_JOINTS = 256
MAX_FEET = 64
MAX_NAME_CHARS = 256
MAX_INT_DIGITS = 30  # JSON integers longer than this are refused before float conversion
MAX_METADATA_DEPTH = 32  # nesting of the planner / validation objects
#: planner["entry_blend_cycles"]: the fewest cycles of entry blend the gait asks the player and
#: the simulator for (`robots.ramp`; `gaitsmith plan --entry-cycles`)
ENTRY_CYCLES_KEY = "entry_blend_cycles"
MAX_ENTRY_CYCLES = 20  # a longer entry is a slow start, not a blend
MAX_PERIOD_S = 60.0
MAX_SPEED_M_S = 50.0
MAX_YAW_RATE_RAD_S = 50.0
MAX_ANGLE_RAD = 4.0 * math.pi
# per-knot optional arrays: field → largest magnitude accepted
_ARRAY_BOUNDS = {
    "joint_angles_rad": MAX_ANGLE_RAD,
    "expected_joint_angles_rad": MAX_ANGLE_RAD,
    "base_pose": 1e4,  # m (treadmill frame) and rad
    "contact_forces_n": 1e7,
    "joint_torques_nm": 1e5,
}
_KEYS = {
    "schema",
    "robot",
    "robot_fingerprint",
    "joint_names",
    "period_s",
    "velocity",
    "joint_angles_rad",
    "schedule",
    "gait_label",
    "base_pose",
    "contact_forces_n",
    "joint_torques_nm",
    "expected_joint_angles_rad",
    "planner",
    "validation",
    "robot_dir",
}


@dataclass(frozen=True)
class Velocity:
    vx_m_s: float = 0.0
    vy_m_s: float = 0.0
    yaw_rate_rad_s: float = 0.0


@dataclass(frozen=True, eq=False)
class Gait:
    """One periodic gait for one robot build. Construct through `Gait.create` or `load`."""

    robot: str
    robot_fingerprint: str
    joint_names: tuple[str, ...]
    period_s: float
    velocity: Velocity
    joint_angles_rad: np.ndarray  # (N+1, J), last row == first row
    schedule: ContactSchedule
    gait_label: str
    base_pose: np.ndarray | None = None  # (N, 6)
    contact_forces_n: np.ndarray | None = None  # (N, F, 3)
    joint_torques_nm: np.ndarray | None = None  # (N, J)
    planner: dict[str, Any] = field(default_factory=dict)
    validation: dict[str, Any] | None = None
    expected_joint_angles_rad: np.ndarray | None = None  # (N, J), see the module docstring
    robot_dir: str | None = None  # absolute robot folder (None: built-in robot)
    robot_dir_relative: str | None = None  # as stored: relative to the gait file's folder

    @staticmethod
    def create(
        *,
        robot: Robot,
        knots_rad: np.ndarray,
        schedule: ContactSchedule,
        velocity: Velocity,
        gait_label: str,
        base_pose: np.ndarray | None = None,
        contact_forces_n: np.ndarray | None = None,
        joint_torques_nm: np.ndarray | None = None,
        planner: dict[str, Any] | None = None,
        expected_knots_rad: np.ndarray | None = None,
    ) -> Gait:
        """Build a gait from N knots (N × J, phases k/N); the closing row is appended here."""
        knots = np.asarray(knots_rad, dtype=float)
        gait = Gait(
            robot=robot.name,
            robot_fingerprint=robot.fingerprint,
            joint_names=robot.joint_names,
            period_s=float(schedule.period_s),
            velocity=velocity,
            joint_angles_rad=np.vstack([knots, knots[:1]]),
            schedule=schedule,
            gait_label=gait_label,
            base_pose=base_pose,
            contact_forces_n=contact_forces_n,
            joint_torques_nm=joint_torques_nm,
            planner=dict(planner or {}),
            expected_joint_angles_rad=expected_knots_rad,
            robot_dir=_robot_dir_of(robot),
        )
        return from_dict(to_dict(gait), "<new gait>")  # one validation path for all gaits

    @property
    def n_knots(self) -> int:
        return int(self.joint_angles_rad.shape[0] - 1)

    @property
    def knots_rad(self) -> np.ndarray:
        """The N knots (without the closing row), N × J."""
        return self.joint_angles_rad[:-1]

    @cached_property
    def _spline(self) -> PeriodicSpline:
        return PeriodicSpline(self.knots_rad)

    def joint_targets(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint angles [rad] at time `t_s` (periodic cubic spline; (J,) or (K, J))."""
        return self._spline(np.asarray(t_s, dtype=float) / self.period_s)

    @cached_property
    def _expected_spline(self) -> PeriodicSpline:
        if self.expected_joint_angles_rad is None:
            return self._spline
        return PeriodicSpline(self.expected_joint_angles_rad)

    def expected_joint_angles(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint angles [rad] the robot should reach at `t_s` (the samples, or the expected
        angles when the samples are servo goals; see the module docstring)."""
        return self._expected_spline(np.asarray(t_s, dtype=float) / self.period_s)

    def joint_velocities(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint speeds [rad/s] of the same spline at time `t_s`."""
        return self._spline.derivative(np.asarray(t_s, dtype=float) / self.period_s) / self.period_s

    def with_validation(self, validation: dict[str, Any]) -> Gait:
        return replace(self, validation=dict(validation))

    def check_robot(self, robot: Robot, file: str = "<gait>") -> None:
        """Raise GaitFileError unless planned for `robot` (fingerprint, joints, limits)."""
        if self.robot_fingerprint != robot.fingerprint:
            raise GaitFileError(
                file,
                "robot_fingerprint",
                f"gait was planned for build {self.robot}@{self.robot_fingerprint}, robot is "
                f"{robot.name}@{robot.fingerprint}; re-plan the gait for this robot",
            )
        if self.joint_names != robot.joint_names:
            raise GaitFileError(
                file,
                "joint_names",
                f"{list(self.joint_names)} do not match robot {list(robot.joint_names)}",
            )
        if tuple(self.schedule.feet) != robot.foot_names:
            raise GaitFileError(
                file,
                "schedule.feet",
                f"{list(self.schedule.feet)} do not match legs {list(robot.foot_names)}",
            )
        lo = np.array([j.lower_rad for j in robot.joints])
        hi = np.array([j.upper_rad for j in robot.joints])
        bad = np.argwhere((self.joint_angles_rad < lo - 1e-6) | (self.joint_angles_rad > hi + 1e-6))
        if bad.size:
            k, j = (int(x) for x in bad[0])
            raise GaitFileError(
                file,
                f"joint_angles_rad[{k}][{j}]",
                f"{self.joint_angles_rad[k, j]:.4f} rad is outside {robot.joint_names[j]}'s limits "
                f"[{lo[j]:.4f}, {hi[j]:.4f}]",
            )


# ---------------------------------------------------------------------------------------------
# (de)serialisation


def _arr(a: np.ndarray | None) -> Any:
    return None if a is None else np.asarray(a, dtype=float).tolist()


def _robot_dir_of(robot: Robot) -> str | None:
    from robots.robot import BUILTIN_DIR

    root = Path(robot.root_dir).resolve()
    return None if root.parent == BUILTIN_DIR.resolve() else str(root)


def to_dict(gait: Gait, path: str | Path | None = None) -> dict[str, Any]:
    """The JSON document; `path` (where it will be written) sets ``robot_dir.relative``."""
    out: dict[str, Any] = {
        "schema": SCHEMA,
        "robot": gait.robot,
        "robot_fingerprint": gait.robot_fingerprint,
        "joint_names": list(gait.joint_names),
        "period_s": float(gait.period_s),
        "velocity": {
            "vx_m_s": gait.velocity.vx_m_s,
            "vy_m_s": gait.velocity.vy_m_s,
            "yaw_rate_rad_s": gait.velocity.yaw_rate_rad_s,
        },
        "joint_angles_rad": _arr(gait.joint_angles_rad),
        "schedule": {
            "feet": list(gait.schedule.feet),
            "touchdown_phase": list(gait.schedule.touchdown_phase),
            "duty_factor": list(gait.schedule.duty_factor),
        },
        "gait_label": gait.gait_label,
        "base_pose": _arr(gait.base_pose),
        "contact_forces_n": _arr(gait.contact_forces_n),
        "joint_torques_nm": _arr(gait.joint_torques_nm),
        "expected_joint_angles_rad": _arr(gait.expected_joint_angles_rad),
        "planner": gait.planner,
        "validation": gait.validation,
    }
    if gait.robot_dir is not None:
        rel = gait.robot_dir_relative
        if path is not None:
            try:
                rel = os.path.relpath(gait.robot_dir, Path(path).resolve().parent)
            except ValueError:  # another drive (Windows)
                rel = None
        out["robot_dir"] = {"absolute": gait.robot_dir, "relative": rel}
    return out


def _str(
    file: str, d: dict[str, Any], key: str, error: type[GaitFileError] = GaitFileError
) -> str:
    v = d.get(key)
    if not isinstance(v, str) or not v:
        raise error(file, key, "missing or not a non-empty string")
    if len(v) > MAX_NAME_CHARS:
        raise error(file, key, f"longer than {MAX_NAME_CHARS} characters")
    return v


def _num(file: str, where: str, v: Any, bound: float = math.inf) -> float:
    """A JSON number (not a string, not a boolean), finite and |v| ≤ `bound`."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise GaitFileError(file, where, f"must be a JSON number, got {type(v).__name__} {v!r:.40}")
    try:
        x = float(v)
    except OverflowError:
        raise GaitFileError(file, where, "is too large a number") from None
    if not math.isfinite(x):
        raise GaitFileError(file, where, f"must be a finite number, got {v!r}")
    if abs(x) > bound:
        raise GaitFileError(file, where, f"is {x:g}; at most {bound:g} in magnitude")
    return x


def _check_numeric(file: str, where: str, v: Any, shape: tuple[int, ...]) -> None:
    """Nested JSON lists of exactly `shape` holding JSON numbers only (no strings, booleans)."""
    if not shape:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise GaitFileError(
                file, where, f"must be a JSON number, got {type(v).__name__} {v!r:.40}"
            )
        return
    if not isinstance(v, list):
        raise GaitFileError(file, where, f"must be a list (array of shape {shape})")
    if len(v) != shape[0]:
        raise GaitFileError(file, where, f"has {len(v)} entries, expected {shape[0]}")
    for i, item in enumerate(v):
        _check_numeric(file, f"{where}[{i}]", item, shape[1:])


def _matrix(
    file: str, where: str, v: Any, shape: tuple[int, ...], bound: float = math.inf
) -> np.ndarray:
    _check_numeric(file, where, v, shape)
    with np.errstate(over="ignore"):
        try:
            a = np.asarray(v, dtype=float)
        except OverflowError:
            a = np.full(shape, np.inf)
    if a.shape != shape:  # pragma: no cover - _check_numeric guarantees it
        raise GaitFileError(file, where, f"has shape {a.shape}, expected {shape}")
    bad = ~np.isfinite(a)
    if np.any(bad):
        idx = tuple(int(x) for x in np.argwhere(bad)[0])
        raise GaitFileError(file, f"{where}{list(idx)}", "is NaN, infinite or too large")
    big = np.abs(a) > bound
    if np.any(big):
        idx = tuple(int(x) for x in np.argwhere(big)[0])
        raise GaitFileError(
            file, f"{where}{list(idx)}", f"is {a[idx]:g}; at most {bound:g} in magnitude"
        )
    return a


def _depth(v: Any, limit: int) -> int:
    """Nesting depth of a JSON value, stopping early past `limit`."""
    if limit < 0:
        return 1
    if isinstance(v, dict):
        return 1 + max((_depth(x, limit - 1) for x in v.values()), default=0)
    if isinstance(v, list):
        return 1 + max((_depth(x, limit - 1) for x in v), default=0)
    return 0


def _json_obj(file: str, where: str, v: Any, *, nullable: bool) -> dict[str, Any] | None:
    if v is None and nullable:
        return None
    if not isinstance(v, dict):
        raise GaitFileError(file, where, "must be a JSON object" + (" or null" if nullable else ""))
    if _depth(v, MAX_METADATA_DEPTH) > MAX_METADATA_DEPTH:
        raise GaitFileError(file, where, f"nested more than {MAX_METADATA_DEPTH} levels deep")
    return v


def _robot_dir(file: str, v: Any) -> tuple[str | None, str | None]:
    if v is None:
        return None, None
    if not isinstance(v, dict) or not set(v) <= {"absolute", "relative"} or "absolute" not in v:
        raise GaitFileError(
            file, "robot_dir", 'must be {"absolute": path, "relative": path or null}'
        )
    out: list[str | None] = []
    for key in ("absolute", "relative"):
        p = v.get(key)
        if p is None and key == "relative":
            out.append(None)
            continue
        if not isinstance(p, str) or not p or len(p) > 4096 or "\0" in p:
            raise GaitFileError(file, f"robot_dir.{key}", "must be a folder path (a string)")
        out.append(p)
    if not os.path.isabs(str(out[0])):
        raise GaitFileError(file, "robot_dir.absolute", "must be an absolute path")
    return out[0], out[1]


def check_document(
    d: Any, file: str, schema: str, keys: set[str] | frozenset[str],
    error: type[GaitFileError] = GaitFileError,
) -> dict[str, Any]:
    """`d` as a JSON object of `schema` with no field outside `keys` (gait and library files)."""
    if not isinstance(d, dict):
        raise error(file, "<root>", "must be a JSON object")
    if d.get("schema") != schema:
        raise error(file, "schema", f"unknown schema {d.get('schema')!r:.60}; expected {schema!r}")
    unknown = sorted(set(d) - keys)
    if unknown:
        raise error(file, unknown[0][:60], "unknown field")
    return d


def from_dict(d: Any, file: str = "<gait>") -> Gait:
    """Validate a parsed gait JSON document; raises GaitFileError naming the field at fault."""
    d = check_document(d, file, SCHEMA, _KEYS)
    names = d.get("joint_names")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) and n for n in names):
        raise GaitFileError(file, "joint_names", "must be a non-empty list of joint names")
    if len(names) > MAX_JOINTS or max(len(n) for n in names) > MAX_NAME_CHARS:
        raise GaitFileError(
            file, "joint_names", f"at most {MAX_JOINTS} names of ≤ {MAX_NAME_CHARS} characters"
        )
    if len(set(names)) != len(names):
        raise GaitFileError(file, "joint_names", "has duplicates")
    n_j = len(names)
    period = _num(file, "period_s", d.get("period_s"), MAX_PERIOD_S)
    if period <= 0:
        raise GaitFileError(file, "period_s", "must be positive")
    vel = _json_obj(file, "velocity", d.get("velocity"), nullable=False)
    assert vel is not None
    if set(vel) != {"vx_m_s", "vy_m_s", "yaw_rate_rad_s"}:
        raise GaitFileError(file, "velocity", "needs exactly vx_m_s, vy_m_s, yaw_rate_rad_s")
    velocity = Velocity(
        _num(file, "velocity.vx_m_s", vel["vx_m_s"], MAX_SPEED_M_S),
        _num(file, "velocity.vy_m_s", vel["vy_m_s"], MAX_SPEED_M_S),
        _num(file, "velocity.yaw_rate_rad_s", vel["yaw_rate_rad_s"], MAX_YAW_RATE_RAD_S),
    )
    raw = d.get("joint_angles_rad")
    if not isinstance(raw, list) or len(raw) < 4:
        raise GaitFileError(
            file, "joint_angles_rad", "must be a list of at least 3 knots + the closing row"
        )
    if len(raw) > MAX_KNOTS + 1:
        raise GaitFileError(
            file, "joint_angles_rad", f"has {len(raw) - 1} knots; at most {MAX_KNOTS}"
        )
    samples = _matrix(
        file, "joint_angles_rad", raw, (len(raw), n_j), _ARRAY_BOUNDS["joint_angles_rad"]
    )
    gap = np.abs(samples[-1] - samples[0])
    if np.max(gap) > PERIODIC_TOL_RAD:
        j = int(np.argmax(gap))
        raise GaitFileError(
            file,
            f"joint_angles_rad[{len(raw) - 1}][{j}]",
            f"samples are not periodic: the closing row differs from the first by {gap[j]:.3g} rad "
            f"({names[j]})",
        )
    n_k = len(raw) - 1
    sch = _json_obj(file, "schedule", d.get("schedule"), nullable=False)
    assert sch is not None
    if set(sch) != {"feet", "touchdown_phase", "duty_factor"}:
        raise GaitFileError(file, "schedule", "needs exactly feet, touchdown_phase, duty_factor")
    feet = sch["feet"]
    if not isinstance(feet, list) or not feet or not all(isinstance(f, str) for f in feet):
        raise GaitFileError(file, "schedule.feet", "must be a non-empty list of foot names")
    if len(feet) > MAX_FEET or max(len(f) for f in feet) > MAX_NAME_CHARS:
        raise GaitFileError(
            file, "schedule.feet", f"at most {MAX_FEET} names of ≤ {MAX_NAME_CHARS} characters"
        )
    phases = [
        _num(file, f"schedule.touchdown_phase[{i}]", v, 1.0)
        for i, v in enumerate(
            _list(file, "schedule.touchdown_phase", sch["touchdown_phase"], len(feet))
        )
    ]
    duties = [
        _num(file, f"schedule.duty_factor[{i}]", v, 1.0)
        for i, v in enumerate(_list(file, "schedule.duty_factor", sch["duty_factor"], len(feet)))
    ]
    try:
        schedule = ContactSchedule(period, tuple(feet), tuple(phases), tuple(duties))
    except ScheduleError as exc:
        raise GaitFileError(file, "schedule", str(exc)) from None
    n_f = len(feet)
    optional: dict[str, np.ndarray | None] = {}
    for key, shape in (
        ("base_pose", (n_k, 6)),
        ("contact_forces_n", (n_k, n_f, 3)),
        ("joint_torques_nm", (n_k, n_j)),
        ("expected_joint_angles_rad", (n_k, n_j)),
    ):
        optional[key] = (
            None if d.get(key) is None else _matrix(file, key, d[key], shape, _ARRAY_BOUNDS[key])
        )
    planner = _json_obj(file, "planner", d.get("planner", {}), nullable=False)
    _check_entry_cycles(file, planner or {})
    validation = _json_obj(file, "validation", d.get("validation"), nullable=True)
    robot_dir, robot_dir_rel = _robot_dir(file, d.get("robot_dir"))
    return Gait(
        robot=_str(file, d, "robot"),
        robot_fingerprint=_str(file, d, "robot_fingerprint"),
        joint_names=tuple(names),
        period_s=period,
        velocity=velocity,
        joint_angles_rad=samples,
        schedule=schedule,
        gait_label=_str(file, d, "gait_label"),
        planner=dict(planner or {}),
        validation=validation,
        robot_dir=robot_dir,
        robot_dir_relative=robot_dir_rel,
        **optional,
    )


def valid_entry_cycles(value: Any) -> bool:
    """A planner.entry_blend_cycles value: a whole number (not a bool) in 1..MAX_ENTRY_CYCLES."""
    return (not isinstance(value, bool) and isinstance(value, int)
            and 1 <= value <= MAX_ENTRY_CYCLES)


def _check_entry_cycles(file: str, planner: dict[str, Any]) -> None:
    """planner.entry_blend_cycles, if present: a whole number of cycles, 1..MAX_ENTRY_CYCLES."""
    if ENTRY_CYCLES_KEY not in planner:
        return
    v = planner[ENTRY_CYCLES_KEY]
    if not valid_entry_cycles(v):
        raise GaitFileError(file, f"planner.{ENTRY_CYCLES_KEY}",
                            f"must be a whole number of cycles from 1 to {MAX_ENTRY_CYCLES}, "
                            f"got {v!r:.40}")


def _list(file: str, where: str, v: Any, length: int) -> list[Any]:
    if not isinstance(v, list):
        raise GaitFileError(file, where, "must be a list")
    if len(v) != length:
        raise GaitFileError(file, where, f"has {len(v)} entries; needs one per foot ({length})")
    return v


class _HugeInteger(ValueError):
    pass


def _parse_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise _HugeInteger(text[:20])
    return int(text)


def parse_json_text(
    text: str, file: str, max_chars: int, error: type[GaitFileError] = GaitFileError
) -> Any:
    """The JSON document of a gait (or gait-library) file, bounded in size and integer length;
    `error` (a `GaitFileError`) names the file and what is wrong."""
    if len(text) > max_chars:
        raise error(file, "<file>", f"is {len(text)} characters; at most {max_chars}")
    try:
        # NaN/Infinity parse; field checks reject them by name
        return json.loads(text, parse_int=_parse_int)
    except _HugeInteger as exc:
        problem = f"integer {exc}… has more than {MAX_INT_DIGITS} digits"
        raise error(file, "<json>", problem) from None
    except (ValueError, RecursionError) as exc:
        raise error(file, "<json>", f"not valid JSON: {exc}") from None


def read_json_file(
    path: str | Path, max_bytes: int, error: type[GaitFileError] = GaitFileError
) -> tuple[str, Any]:
    """(file name, JSON document) of a gait or gait-library file, read with a size bound."""
    p = Path(path)
    try:
        if p.stat().st_size > max_bytes:
            raise error(str(p), "<file>", f"larger than {max_bytes} bytes")
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise error(str(p), "<file>", f"cannot read: {exc}") from None
    return str(p), parse_json_text(text, str(p), max_bytes, error)


def loads(text: str, file: str = "<gait>") -> Gait:
    return from_dict(parse_json_text(text, file, MAX_GAIT_BYTES), file)


def load(path: str | Path, robot: Robot | None = None) -> Gait:
    """Read and validate a gait file; with `robot`, also check it was planned for that build."""
    file, doc = read_json_file(path, MAX_GAIT_BYTES)
    gait = from_dict(doc, file)
    if robot is not None:
        gait.check_robot(robot, file)
    return gait


def robot_for(
    gait: Gait,
    gait_path: str | Path | None = None,
    robot: str | Path | None = None,
    servo_catalogue: str | Path | None = None,
) -> Robot:
    """The robot a gait was planned for, checked against its fingerprint.

    Found by: `robot` (the ``--robot`` override) > ``robot_dir.relative`` to the gait file's
    folder > ``robot_dir.absolute`` > the gait's robot name (built-in, or a folder of that name in
    the working directory). Raises GaitFileError (or RobotConfigError) saying what to do.
    """
    from robots.robot import load as load_robot

    file = str(gait_path) if gait_path is not None else "<gait>"
    if robot is not None:
        found = load_robot(robot, servo_catalogue)
        gait.check_robot(found, file)
        return found
    candidates: list[Path] = []
    if gait.robot_dir_relative is not None and gait_path is not None:
        candidates.append((Path(gait_path).resolve().parent / gait.robot_dir_relative).resolve())
    if gait.robot_dir is not None:
        candidates.append(Path(gait.robot_dir))
    for folder in candidates:
        if (folder / "robot.toml").is_file() and (folder / "robot.xml").is_file():
            found = load_robot(folder, servo_catalogue)
            gait.check_robot(found, file)
            return found
    try:
        found = load_robot(gait.robot, servo_catalogue)
    except RobotsError:
        where = ", ".join(str(c) for c in candidates) or "no robot_dir stored"
        raise GaitFileError(
            file,
            "robot_dir" if candidates else "robot",
            f"cannot find robot {gait.robot!r} (looked in: {where}; not a built-in robot); "
            "give its folder with --robot FOLDER",
        ) from None
    gait.check_robot(found, file)
    return found


def dumps(gait: Gait, path: str | Path | None = None) -> str:
    try:
        return json.dumps(to_dict(gait, path), indent=1, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise GaitFileError(
            "<gait>", "planner/validation", f"not JSON-serialisable: {exc}"
        ) from None


def save(gait: Gait, path: str | Path) -> None:
    """Write the gait file atomically (temp file + rename); ``robot_dir.relative`` is computed
    from the file's folder."""
    atomic_write_text(path, dumps(gait, path) + "\n")

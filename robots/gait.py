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
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robots.errors import GaitFileError
from robots.files import atomic_write_text
from robots.schedule import ContactSchedule, ScheduleError
from robots.spline import PeriodicSpline

if TYPE_CHECKING:
    from robots.robot import Robot

SCHEMA = "gaitsmith.gait/1"
PERIODIC_TOL_RAD = 1e-6
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


def to_dict(gait: Gait) -> dict[str, Any]:
    return {
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


def _str(file: str, d: dict[str, Any], key: str) -> str:
    v = d.get(key)
    if not isinstance(v, str) or not v:
        raise GaitFileError(file, key, "missing or not a non-empty string")
    return v


def _num(file: str, where: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise GaitFileError(file, where, f"must be a finite number, got {v!r}")
    return float(v)


def _matrix(file: str, where: str, v: Any, shape: tuple[int, ...]) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise GaitFileError(file, where, f"must be a numeric array of shape {shape}") from None
    if a.shape != shape:
        raise GaitFileError(file, where, f"has shape {a.shape}, expected {shape}")
    if not np.all(np.isfinite(a)):
        idx = tuple(int(x) for x in np.argwhere(~np.isfinite(a))[0])
        raise GaitFileError(file, f"{where}{list(idx)}", "is NaN or infinite")
    return a


def _json_obj(file: str, where: str, v: Any, *, nullable: bool) -> dict[str, Any] | None:
    if v is None and nullable:
        return None
    if not isinstance(v, dict):
        raise GaitFileError(file, where, "must be a JSON object" + (" or null" if nullable else ""))
    return v


def from_dict(d: Any, file: str = "<gait>") -> Gait:
    """Validate a parsed gait JSON document; raises GaitFileError naming the field at fault."""
    if not isinstance(d, dict):
        raise GaitFileError(file, "<root>", "must be a JSON object")
    if d.get("schema") != SCHEMA:
        raise GaitFileError(
            file, "schema", f"unknown schema {d.get('schema')!r}; expected {SCHEMA!r}"
        )
    unknown = sorted(set(d) - _KEYS)
    if unknown:
        raise GaitFileError(file, unknown[0], "unknown field")
    names = d.get("joint_names")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) and n for n in names):
        raise GaitFileError(file, "joint_names", "must be a non-empty list of joint names")
    if len(set(names)) != len(names):
        raise GaitFileError(file, "joint_names", "has duplicates")
    n_j = len(names)
    period = _num(file, "period_s", d.get("period_s"))
    if period <= 0:
        raise GaitFileError(file, "period_s", "must be positive")
    vel = _json_obj(file, "velocity", d.get("velocity"), nullable=False)
    assert vel is not None
    if set(vel) != {"vx_m_s", "vy_m_s", "yaw_rate_rad_s"}:
        raise GaitFileError(file, "velocity", "needs exactly vx_m_s, vy_m_s, yaw_rate_rad_s")
    velocity = Velocity(
        *(_num(file, f"velocity.{k}", vel[k]) for k in ("vx_m_s", "vy_m_s", "yaw_rate_rad_s"))
    )
    raw = d.get("joint_angles_rad")
    if not isinstance(raw, list) or len(raw) < 4:
        raise GaitFileError(
            file, "joint_angles_rad", "must be a list of at least 3 knots + the closing row"
        )
    samples = _matrix(file, "joint_angles_rad", raw, (len(raw), n_j))
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
    phases = [
        _num(file, f"schedule.touchdown_phase[{i}]", v)
        for i, v in enumerate(_list(file, "schedule.touchdown_phase", sch["touchdown_phase"]))
    ]
    duties = [
        _num(file, f"schedule.duty_factor[{i}]", v)
        for i, v in enumerate(_list(file, "schedule.duty_factor", sch["duty_factor"]))
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
        optional[key] = None if d.get(key) is None else _matrix(file, key, d[key], shape)
    planner = _json_obj(file, "planner", d.get("planner", {}), nullable=False)
    validation = _json_obj(file, "validation", d.get("validation"), nullable=True)
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
        **optional,
    )


def _list(file: str, where: str, v: Any) -> list[Any]:
    if not isinstance(v, list):
        raise GaitFileError(file, where, "must be a list")
    return v


def loads(text: str, file: str = "<gait>") -> Gait:
    try:
        doc = json.loads(text)  # NaN/Infinity parse; field checks reject them by name
    except (ValueError, RecursionError) as exc:
        raise GaitFileError(file, "<json>", f"not valid JSON: {exc}") from None
    return from_dict(doc, file)


def load(path: str | Path, robot: Robot | None = None) -> Gait:
    """Read and validate a gait file; with `robot`, also check it was planned for that build."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise GaitFileError(str(p), "<file>", f"cannot read: {exc}") from None
    gait = loads(text, str(p))
    if robot is not None:
        gait.check_robot(robot, str(p))
    return gait


def dumps(gait: Gait) -> str:
    try:
        return json.dumps(to_dict(gait), indent=1, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise GaitFileError(
            "<gait>", "planner/validation", f"not JSON-serialisable: {exc}"
        ) from None


def save(gait: Gait, path: str | Path) -> None:
    """Write the gait file atomically (temp file + rename)."""
    atomic_write_text(path, dumps(gait) + "\n")

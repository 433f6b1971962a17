"""Pre-flight checks before a gait touches the servos; each failure names the servo / field.

Offline (no bus): the gait was planned for this robot build (fingerprint, joint names, limits),
the calibration belongs to the same build and joint order, the time scaling keeps every joint
below the speed the safety gate enforces at the requested rate (`SafetyGate.enforced_speed_rad_s`:
the same number the step limiter uses, so pre-flight and enforcement agree), one gait cycle
lasts at most `MAX_CYCLE_S` and a finite run at most `MAX_RUN_S` (a gait file with period_s =
1e300 is refused, not played for ever), and the gait's `validation` verdict is a pass (else
`force` turns the refusal into a warning). On the bus: every servo answers a ping with the
catalogue model number, voltage and temperature are in range with no hardware-error flags, and
the present pose lies within the joint limits (± `pose_tolerance_rad`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hardware.bus import ServoBus
from hardware.calibration import Calibration
from hardware.errors import BusError, CalibrationError, NoResponse, ServoFault
from hardware.play_errors import PreflightError, SpeedScaleError
from hardware.watchdog import WatchdogLimits
from robots.errors import GaitFileError
from robots.gait import Gait
from robots.robot import Robot

SPEED_SAMPLES_PER_KNOT = 8
MAX_CYCLE_S = 120.0  # one gait cycle at the requested speed scale, at most [s]
MAX_RUN_S = 24 * 3600.0  # a run of a given number of cycles, at most [s] (0 cycles: no bound)


@dataclass(frozen=True)
class PreflightReport:
    """What the checks found: warnings to show, and the present pose when a bus was checked."""

    warnings: tuple[str, ...]
    present_ticks: Mapping[int, int] | None
    peak_speed_rad_s: tuple[float, ...]  # per joint, at the requested speed scale


def validation_passed(validation: Mapping[str, Any] | None) -> bool:
    """A gait's sim verdict: `passed: true` (or `verdict: "pass"`); missing means not passed."""
    if not validation:
        return False
    if isinstance(validation.get("passed"), bool):
        return bool(validation["passed"])
    verdict = validation.get("verdict")
    return isinstance(verdict, str) and verdict.lower() in ("pass", "passed")


def gait_peak_speeds_rad_s(gait: Gait) -> np.ndarray:
    """Largest |joint speed| [rad/s] of the gait's spline at speed scale 1 (dense sampling)."""
    n = max(64, gait.n_knots * SPEED_SAMPLES_PER_KNOT)
    t = np.arange(n) * (gait.period_s / n)
    return np.asarray(np.max(np.abs(gait.joint_velocities(t)), axis=0))


def check_offline(
    robot: Robot,
    gait: Gait,
    calibration: Calibration,
    speed_scale: float,
    allowed_speed_rad_s: np.ndarray,
    force: bool,
    rate_hz: float | None = None,
    cycles: float | None = None,
) -> tuple[list[str], np.ndarray]:
    """Checks that need no bus; returns (warnings, peak speeds at `speed_scale`).

    `allowed_speed_rad_s`: the speed the gate enforces (at `rate_hz`, named in the refusal);
    `cycles`: cycles to play (None: until stopped)."""
    try:
        gait.check_robot(robot)
    except GaitFileError as exc:
        raise PreflightError("gait", str(exc)) from None
    try:
        calibration.check_robot(robot)
    except CalibrationError as exc:
        raise PreflightError("calibration", str(exc)) from None
    if calibration.joint_names != gait.joint_names:
        raise PreflightError(
            "calibration", f"joints {calibration.joint_names} differ from the gait's"
        )
    if not (np.isfinite(speed_scale) and speed_scale > 0):
        raise PreflightError("--speed-scale", f"must be a positive number, got {speed_scale}")
    cycle_s = gait.period_s / speed_scale
    if not (np.isfinite(cycle_s) and cycle_s <= MAX_CYCLE_S):
        raise PreflightError(
            "gait period_s",
            f"{gait.period_s:g} s at --speed-scale {speed_scale:g} makes one cycle last "
            f"{cycle_s:g} s, over the {MAX_CYCLE_S:g} s the player accepts; is the file right?",
        )
    if cycles is not None and not cycles * cycle_s <= MAX_RUN_S:
        raise PreflightError(
            "--cycles",
            f"{cycles:g} cycles of {cycle_s:g} s would run {cycles * cycle_s:g} s, over "
            f"{MAX_RUN_S:g} s; ask for fewer, or 0 to play until stopped",
        )
    peaks = gait_peak_speeds_rad_s(gait) * speed_scale
    over = peaks / allowed_speed_rad_s
    worst = int(np.argmax(over))
    if over[worst] > 1.0:
        raise SpeedScaleError(
            gait.joint_names[worst],
            float(peaks[worst]),
            float(allowed_speed_rad_s[worst]),
            speed_scale,
            rate_hz,
        )
    warnings = []
    if not validation_passed(gait.validation):
        what = "has no sim validation" if not gait.validation else "FAILED sim validation"
        if not force:
            raise PreflightError(
                "gait validation",
                f"gait {what}; run `gaitsmith simulate` first, or pass --force to play it anyway",
            )
        warnings.append(f"WARNING: gait {what}; playing it anyway because of --force")
    return warnings, peaks


def check_bus(
    robot: Robot,
    calibration: Calibration,
    bus: ServoBus,
    limits: WatchdogLimits,
    pose_tolerance_rad: float = 0.05,
) -> dict[int, int]:
    """Ping + model, health, present pose; returns the present pose {bus id: ticks}."""
    ids = [j.bus_id for j in robot.joints]
    for j in robot.joints:
        who = f"servo {j.bus_id} ({j.name})"
        try:
            info = bus.ping(j.bus_id, retries=2)
        except BusError as exc:
            problem = "does not answer ping" if isinstance(exc, NoResponse) else str(exc)
            raise PreflightError(who, problem) from None
        if info.model_number != j.servo.model_number:
            raise PreflightError(
                who,
                f"model number {info.model_number}, expected {j.servo.model_number} "
                f"({j.servo.name})",
            )
    try:
        statuses = bus.read_status(ids)
    except BusError as exc:
        raise PreflightError("status read", str(exc)) from None
    for j in robot.joints:
        st, m = statuses[j.bus_id], j.servo
        who = f"servo {j.bus_id} ({j.name})"
        if st.error_flags:
            raise PreflightError(who, f"hardware error flags: {', '.join(st.error_flags)}")
        v_min = m.voltage_min_v + limits.voltage_margin_v
        if not v_min <= st.voltage_v <= m.voltage_max_v:
            raise PreflightError(
                who, f"voltage {st.voltage_v:.1f} V outside [{v_min:.1f}, {m.voltage_max_v:.1f}] V"
            )
        t_max = m.max_temperature_c - limits.temperature_margin_c
        if st.temperature_c >= t_max:
            raise PreflightError(who, f"temperature {st.temperature_c:.0f} °C ≥ {t_max:.0f} °C")
    try:
        present = bus.sync_read_positions(ids)
    except ServoFault as exc:
        raise PreflightError(f"servo {exc.servo_id}", str(exc)) from None
    except BusError as exc:
        raise PreflightError("present position read", str(exc)) from None
    for jc in calibration.joints:
        q = jc.ticks_to_rad(present[jc.bus_id])
        lo, hi = jc.lower_rad - pose_tolerance_rad, jc.upper_rad + pose_tolerance_rad
        if not lo <= q <= hi:
            raise PreflightError(
                f"joint {jc.name} (servo {jc.bus_id})",
                f"present angle {q:.3f} rad outside its limits [{jc.lower_rad:.3f}, "
                f"{jc.upper_rad:.3f}] rad; move it by hand (torque off) or recalibrate",
            )
    return {i: int(present[i]) for i in ids}

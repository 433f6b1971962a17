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

Supply (`check_supply`): at the supply voltage — measured (the lowest servo reading) or given
(`--supply-v`) — the servos' stall torque is τ_stall·V/V_nominal (`robots.voltage`); the gait's
peak torque per joint (the larger of the planned torques and the simulated peaks the validation
block carries) is reported against it ("at 7.00 V the peak knee torque is 83 %
of stall (78 % at 7.40 V nominal)"), warned about above the sim verdict's 80 %, and refused
above 100 % (the servo cannot deliver it; `force` turns the refusal into a warning).

Heating (`check_heating`): with the gait's predicted heating per servo
(`hardware.play.thermal_watch.predicted_heating`), a servo predicted to reach its stop temperature
within the run — from its present reading, the coolest servo's reading taken as the room — is
warned about (the watchdog will stop the run there).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hardware.bus.servo_bus import ServoBus, ServoStatus
from hardware.errors import BusError, CalibrationError, NoResponse, ServoFault
from hardware.play.calibration import Calibration
from hardware.play.errors import PreflightError, SpeedScaleError
from hardware.play.thermal_watch import PredictedHeating
from hardware.play.watchdog import WatchdogLimits
from robots.attitude import validated_attitude_gain
from robots.errors import GaitFileError
from robots.gait import Gait
from robots.robot import Robot
from robots.voltage import voltage_margin, voltage_range_v

SPEED_SAMPLES_PER_KNOT = 8
MAX_CYCLE_S = 120.0  # one gait cycle at the requested speed scale, at most [s]
MAX_RUN_S = 24 * 3600.0  # a run of a given number of cycles, at most [s] (0 cycles: no bound)
SUPPLY_WARN_FRACTION = 0.80  # sim.validate.PassCriteria.max_peak_torque_fraction (no sim import)


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
    attitude_gain: float | None = None,
) -> tuple[list[str], np.ndarray]:
    """Checks that need no bus; returns (warnings, peak speeds at `speed_scale`).

    `allowed_speed_rad_s`: the speed the gate enforces (at `rate_hz`, named in the refusal);
    `cycles`: cycles to play (None: until stopped); `attitude_gain`: the IMU feedback's gain
    the run will use (None: open loop; `check_attitude`)."""
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
    warnings += check_attitude(gait, attitude_gain, force)
    return warnings, peaks


def check_attitude(gait: Gait, attitude_gain: float | None, force: bool) -> list[str]:
    """A gait validated closed loop (``validation.conditions.attitude_gain`` > 0) is refused
    open loop unless `force`; a different gain than validated is a warning."""
    validated = validated_attitude_gain(gait.validation)
    if validated > 0.0 and not attitude_gain:
        what = (f"gait was validated closed loop (attitude gain {validated:g}) and this run has "
                "no IMU feedback")
        if not force:
            raise PreflightError("gait validation", f"{what}; pass --force to play it open loop")
        return [f"WARNING: {what}; playing it open loop because of --force"]
    if attitude_gain and abs(attitude_gain - validated) > 1e-9:
        return [f"WARNING: attitude gain {attitude_gain:g} differs from the {validated:g} the "
                "gait was validated with"]
    return []


def check_bus(
    robot: Robot,
    calibration: Calibration,
    bus: ServoBus,
    limits: WatchdogLimits,
    pose_tolerance_rad: float = 0.05,
    on_status: Callable[[Mapping[int, ServoStatus]], None] | None = None,
) -> dict[int, int]:
    """Ping + model, health, present pose; returns the present pose {bus id: ticks}.
    `on_status` receives the status read (e.g. for `check_supply`'s measured voltage)."""
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
    if on_status is not None:
        on_status(statuses)
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


def measured_supply_v(robot: Robot, statuses: Mapping[int, ServoStatus]) -> tuple[float, str]:
    """The lowest servo voltage reading and where it comes from (the supply the servos see)."""
    readings = [(statuses[j.bus_id].voltage_v, j) for j in robot.joints if j.bus_id in statuses]
    if not readings:
        raise PreflightError("status read", "no servo reported its voltage")
    v, j = min(readings, key=lambda r: r[0])
    return v, f"measured, lowest reading servo {j.bus_id} ({j.name})"


def _peak_torques_nm(robot: Robot, gait: Gait) -> np.ndarray | None:
    """Rows of per-joint torques to judge: the planned ones (`joint_torques_nm`) and the
    simulated peaks (validation block `supply`, from `gaitsmith simulate`); None if neither."""
    rows = []
    if gait.joint_torques_nm is not None and gait.joint_torques_nm.shape[1] == robot.dof:
        rows.append(np.abs(gait.joint_torques_nm))
    block: Any = (gait.validation or {}).get("supply")
    if isinstance(block, dict) and isinstance(block.get("joints"), list):
        sim = {j.get("joint"): j.get("peak_torque_nm") for j in block["joints"]
               if isinstance(j, dict)}
        row = [sim.get(name) for name in robot.joint_names]
        if all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)
               for x in row):
            rows.append(np.abs(np.array(row, dtype=float))[None, :])
    return np.vstack(rows) if rows else None


def check_supply(robot: Robot, gait: Gait, supply_v: float, source: str, force: bool
                 ) -> tuple[str, list[str]]:
    """The gait's planned peak torques against the envelope at `supply_v` (module docstring):
    (the margin line to show, warnings); raises PreflightError if the servos cannot deliver
    them (unless `force`)."""
    lo, hi = voltage_range_v(robot)
    if not (np.isfinite(supply_v) and lo <= supply_v <= hi):
        raise PreflightError(
            "supply voltage", f"{supply_v:g} V ({source}) outside the servos' range "
            f"[{lo:g}, {hi:g}] V",
        )
    warnings = []
    planned_v = gait.planner.get("supply_v")
    if isinstance(planned_v, (int, float)) and supply_v < float(planned_v) - 0.05:
        warnings.append(f"WARNING: supply {supply_v:.2f} V ({source}) is below the "
                        f"{float(planned_v):.2f} V the gait was planned at")
    peaks = _peak_torques_nm(robot, gait)
    if peaks is None:
        return (f"supply {supply_v:.2f} V ({source}): the gait carries no planned or simulated "
                "torques, torque margin not checked", warnings)
    margin = voltage_margin(robot, peaks, supply_v)
    frac = margin.worst.fraction_at_supply
    line = f"supply ({source}): {margin.summary()}"
    if frac > 1.0:
        problem = (f"{line}: more than the servo can give; charge the pack, or re-plan with "
                   f"--supply-v {supply_v:.1f}")
        if not force:
            raise PreflightError("supply voltage", problem)
        warnings.append(f"WARNING: {problem}; playing anyway because of --force")
    elif frac > SUPPLY_WARN_FRACTION:
        warnings.append(f"WARNING: {line}, over the {100 * SUPPLY_WARN_FRACTION:.0f} % the sim "
                        "verdict allows")
    return line, warnings


def check_heating(
    robot: Robot,
    predictions: Mapping[int, PredictedHeating],
    statuses: Mapping[int, ServoStatus],
    limits: WatchdogLimits,
    run_s: float | None,
) -> list[str]:
    """Warnings for servos predicted to reach their stop temperature within `run_s` (None:
    until stopped) — see the module docstring."""
    temps = [st.temperature_c for st in statuses.values()]
    if not temps:
        return []
    room_c = min(temps)
    warnings = []
    for j in robot.joints:
        pred, st = predictions.get(j.bus_id), statuses.get(j.bus_id)
        if pred is None or st is None:
            continue
        stop_c = j.servo.max_temperature_c - limits.temperature_margin_c
        t = pred.model.time_to_limit_s(pred.mean_power_w, room_c, start_c=st.temperature_c,
                                       limit_c=stop_c)
        if t is not None and (run_s is None or t < run_s):
            warnings.append(
                f"WARNING: servo {j.bus_id} ({j.name}): predicted to reach {stop_c:.0f} °C after "
                f"{t / 60:.1f} min of this gait (now {st.temperature_c:.0f} °C, "
                f"{pred.mean_power_w:.1f} W mean heat); the watchdog will stop it there"
            )
    return warnings

"""Planner metadata written into gait files: objective terms, solver stats, weights, versions."""

from __future__ import annotations

import platform
from importlib import metadata as importlib_metadata
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from planner.nlp.spacetime import GaitPlanner, PlanResult


def distribution_version(name: str) -> str:
    """`importlib.metadata.version(name)`, read from the first "Version:" header of the
    distribution's METADATA instead of parsing the whole file with the email parser (≈ 1.3 ms
    a package; 7.7 → 1.3 ms for the five of `package_versions`: docs/results/
    planner_speed_startup.md, session 44); the full lookup if that file has none. Raises
    `importlib.metadata.PackageNotFoundError` as `version` does."""
    dist = importlib_metadata.distribution(name)
    text = dist.read_text("METADATA")
    for line in (text or "").splitlines():
        if not line.strip():
            break  # the headers end at the first blank line
        if line.startswith("Version:"):
            return line[len("Version:"):].strip()
    return dist.version


def package_versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for dist in ("gaitsmith", "casadi", "mujoco", "numpy", "scipy"):
        try:
            out[dist] = distribution_version(dist)
        except importlib_metadata.PackageNotFoundError:
            out[dist] = "not installed"
    return out


def servo_load(planner: GaitPlanner, result: PlanResult) -> dict[str, dict[str, float]]:
    """Per joint: peak |τ|/τ_stall and peak |q̇|/ω₀ over the cycle."""
    out = {}
    for j, joint in enumerate(planner.robot.joints):
        out[joint.name] = {
            "peak_torque_over_stall": float(
                np.max(np.abs(result.joint_torques_nm[:, j])) / joint.servo.stall_torque_nm
            ),
            "peak_speed_over_no_load": float(
                np.max(np.abs(result.joint_speeds_rad_s[:, j])) / joint.servo.no_load_speed_rad_s
            ),
        }
    return out


def joint_limit_clearance(planner: GaitPlanner, result: PlanResult) -> dict[str, dict[str, float]]:
    """Per joint: the closest approach of the planned angles (and, with servo goals, of the
    streamed goals) to the joint's lower and upper limits over the cycle, and the margin the
    planner kept (`PlannerOptions.joint_limit_margins_rad`). All in rad; `closest_rad` is the
    smaller of the two distances, `closest_fraction_of_range` the same over the joint's range."""
    lo, hi = planner.model.joint_limits_rad()
    margin = planner.options.joint_limit_margins_rad(lo, hi)
    q = np.asarray(result.joint_angles_rad)
    series = [q]
    if planner.options.servo_goals:
        from planner.nlp.servo_loop import servo_goals_rad, servo_loops

        series.append(servo_goals_rad(q, result.joint_speeds_rad_s, result.joint_torques_nm,
                                      servo_loops(planner.robot, planner.options.servo_settings)))
    allq = np.concatenate(series, axis=0)
    out = {}
    for j, joint in enumerate(planner.robot.joints):
        to_lower = float(np.min(allq[:, j]) - lo[j])
        to_upper = float(hi[j] - np.max(allq[:, j]))
        closest = min(to_lower, to_upper)
        out[joint.name] = {
            "to_lower_rad": to_lower,
            "to_upper_rad": to_upper,
            "closest_rad": closest,
            "closest_fraction_of_range": closest / float(hi[j] - lo[j]),
            "margin_rad": float(margin[j]),
        }
    return out


def joint_angle_semantics(planner: GaitPlanner, result: PlanResult) -> dict[str, Any]:
    """What the gait file's joint samples mean, and what the consumer needs to check them.

    ``joint_angles``: ``"servo_goal"`` — goals for the servos' position loops, which then
    achieve the gait file's ``expected_joint_angles_rad`` (N × J, the planned motion that
    `base_pose`, the contact forces and the joint torques belong to) through
    τ = kp·(goal − q) − damping·q̇ (per joint in ``servo_loop``); ``"achieved"`` — the planned
    angles themselves (ideal servos).
    """
    if not planner.options.servo_goals:
        return {"joint_angles": "achieved"}
    from planner.nlp.servo_loop import servo_loops

    loops = servo_loops(planner.robot, planner.options.servo_settings)
    return {
        "joint_angles": "servo_goal",
        "servo_loop": {
            "law": "goal = q + (tau + damping*qd)/kp (servo: tau = kp*(goal - q) - damping*qd)",
            "kp_nm_per_rad": [s.kp_nm_per_rad for s in loops],
            "damping_nm_s_per_rad": [s.damping_nm_s_per_rad for s in loops],
            **(
                {"latency_s": [s.latency_s for s in loops], "identified": True}
                if planner.options.servo_settings is not None
                else {}
            ),
        },
    }


def planner_metadata(planner: GaitPlanner, result: PlanResult) -> dict[str, Any]:
    o = planner.options
    weights = o.weights.as_dict()
    return {
        "method": "spacetime (Wampler & Popovic 2009 eqs 1-16), CasADi + IPOPT",
        "n_knots": planner.n_knots,
        "mu": o.mu,
        "torque_margin": o.torque_margin,
        "speed_margin": o.speed_margin,
        "swing_clearance_m": planner.swing_clearance_m,
        "body_clearance_m": planner.body_clearance_m,
        "treadmill": "stance feet move at -v along x; base_pose x excludes the progress v*t",
        "base_orientation": "R = Rz(yaw) Ry(pitch) Rx(roll)",
        "weights": weights,
        "objective": result.cost,
        "objective_terms": dict(result.cost_terms),
        "weighted_terms": {k: weights[k] * v for k, v in result.cost_terms.items()},
        "solver": {
            "status": result.status,
            "iterations": result.iterations,
            "solve_time_s": result.solve_time_s,
            "build_time_s": planner.build_time_s,
            "max_violation": result.max_violation,
            "optimal": result.optimal,
            "message": result.message,
            "inactive_rows": o.inactive_rows,
            # solved on the first half of the knots (`planner.nlp.half_cycle`)
            "half_cycle": bool(result.stats.get("half_cycle", False)),
            # a half-cycle solve whose plan broke the full cycle's rows, dropped for a full one
            # (`planner.nlp.spacetime._half_cycle_broken`): how far it broke them
            **({"half_cycle_dropped_violation": float(
                result.stats["half_cycle_fallback"]["max_violation"])}
               if result.stats.get("half_cycle_fallback") else {}),
            # a body whose joints and feet mirror but whose NLP does not (masses, inertias,
            # servo limits): never solved on half the knots (`nlp_mirror_defect`)
            **({"half_cycle_asymmetry": dict(result.stats["half_cycle_asymmetry"])}
               if result.stats.get("half_cycle_asymmetry") else {}),
            # how the solve held the swing feet's wrench at 0 (`GaitPlanner.solve(swing_wrench=)`:
            # the search's final re-solves may differ from the options)
            "swing_wrench": str(result.stats.get("swing_wrench", o.swing_wrench)),
        },
        "active_limits": [[name, float(v)] for name, v in result.binding],
        "servo_load": servo_load(planner, result),
        "joint_limit_clearance": joint_limit_clearance(planner, result),
        "joint_limit_margin_rad": o.joint_limit_margin_rad,
        "joint_limit_margin_fraction": o.joint_limit_margin_fraction,
        "nondimensional": o.nondimensional,
        "sideways_slip_leg_lengths": o.sideways_slip_leg_lengths,
        **({} if o.rotor_reserve is None else {"rotor_reserve": o.rotor_reserve}),
        **({} if o.separation_unit_leg_lengths is None
           else {"separation_unit_leg_lengths": o.separation_unit_leg_lengths}),
        **({} if o.line_capture_margin_leg_lengths is None
           else {"line_capture_margin_leg_lengths": o.line_capture_margin_leg_lengths}),
        **joint_angle_semantics(planner, result),
        "versions": package_versions(),
    }

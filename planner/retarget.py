"""Retarget a planned gait to another body (Murphy, Carr & O'Neill 2008).

Dynamic similarity (M,C&O §2.2, after Alexander): two legged bodies move alike at the same
Froude number ``Fr = v² / (g·L)`` (L the leg length, `Robot.leg_length_m`). At equal Fr the speed
scales as ``v_B = v_A·√(L_B/L_A)`` and, since stride length scales with L, the period as
``T_B = T_A·√(L_B/L_A)``; duty factors and relative phases are kept.

Leg roles are matched by position, never by name: each robot's foot stance positions in the body
frame (x, y), centred and divided by the half-extent of the foot polygon, are paired by the
least total squared distance (Hungarian assignment, `scipy.optimize.linear_sum_assignment`).
Joints are matched along matched legs in order from the body outwards, each target joint taking
the next source joint whose axis at the nominal stance (world frame) is parallel to its own (so
equal chains match joint by joint, and a 2-joint leg takes the pitch joints of a roll-pitch-pitch
leg); the axes give the sign, and the
motion is carried over as an offset from the nominal stance, ``q_B = q̄_B ± (q_A − q̄_A)``, so
two robots whose joint zeros differ still get the same shape of motion.

Incremental retargeting (M,C&O §3, the horse–dog hybrids): with `steps` K > 1 and a shared tree,
K − 1 hybrid bodies (`planner.hybrid_body`, linear interpolations of link lengths, masses and
inertias) are solved in turn, each warm-started from the one before at its own Froude-scaled
speed and period, and the target last. The hybrids blend geometry and inertia only: they keep
the source's servos and joint conventions (`planner.hybrid_body._rezero`), so the target's servo
envelope first appears in the last solve. With K = 1, or when the trees differ, the target's NLP
starts directly from the source's motion mapped by role.

What it buys (measured, N=16, 2-core shared box, `gaitsmith retarget`): IPOPT iterations of the
target's solve against a cold start of the same schedule and speed — quad12 trot → 0.6× copy
36 vs 38, hex18 tripod → 0.8× copy 16 vs 28 (but a local optimum 12 % dearer: a warm start keeps
the source's motion style, M,C&O's point, not the cheapest gait), a body retargeted to itself 7
vs 19. Hybrid series (K = 3) took more iterations in total than one direct warm start.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planner.errors import PlannerError
from planner.nlp.config import PlannerOptions
from planner.nlp.servo_loop import servo_goals_rad, servo_loops
from planner.nlp.spacetime import GaitPlanner, PlanResult, WarmStart
from planner.stance import stance_kinematics
from planner.templates import stance_foot_positions_m
from robots import ContactSchedule, Gait, Robot
from robots.spline import PeriodicSpline

GRAVITY_M_S2 = 9.81
_AXIS_MATCH_MIN_COS = 0.7  # joints whose stance axes are further apart than ~45° do not match


class RetargetError(PlannerError, ValueError):
    """The gait cannot be carried over to this body (e.g. different number of legs)."""


def froude_number(speed_m_s: float, leg_length_m: float) -> float:
    """Fr = v² / (g·L) (M,C&O §2.2)."""
    return speed_m_s**2 / (GRAVITY_M_S2 * leg_length_m)


def froude_factor(source: Robot, target: Robot) -> float:
    """√(L_target / L_source): the factor on speed and on period at equal Froude number."""
    return math.sqrt(target.leg_length_m / source.leg_length_m)


@dataclass(frozen=True)
class LegMatch:
    """How the source's legs and joints land on the target.

    `target_foot[i]`: the target foot index of source foot i. `joint_source[j]`: the source joint
    index whose motion target joint j takes, or -1 (held at its nominal stance); `joint_sign[j]`
    is +1 or -1 (axes parallel or opposed at the stance).
    """

    target_foot: tuple[int, ...]
    joint_source: tuple[int, ...]
    joint_sign: tuple[float, ...]

    @property
    def source_foot(self) -> tuple[int, ...]:
        """`source_foot[t]`: the source foot whose timing target foot t takes."""
        inverse = [0] * len(self.target_foot)
        for s, t in enumerate(self.target_foot):
            inverse[t] = s
        return tuple(inverse)

    @property
    def joints_mapped(self) -> bool:
        return all(j >= 0 for j in self.joint_source)

    @staticmethod
    def identity(robot: Robot) -> LegMatch:
        return LegMatch(
            tuple(range(len(robot.legs))),
            tuple(range(len(robot.joints))),
            (1.0,) * len(robot.joints),
        )


def normalised_stance_xy(robot: Robot) -> np.ndarray:
    """F × 2 foot stance positions (x, y, body frame), centred, divided by the half-extents."""
    xy = stance_foot_positions_m(robot)[:, :2]
    xy = xy - xy.mean(axis=0)
    half = np.max(np.abs(xy), axis=0)
    return xy / np.where(half > 1e-9, half, 1.0)


def _stance_axes(robot: Robot) -> np.ndarray:
    """J × 3 joint axes in the world frame at the nominal stance (base at the origin, level)."""
    stance = stance_kinematics(robot)
    return np.array(stance.data.xaxis[list(stance.joint_ids)], dtype=float)


def match_legs(source: Robot, target: Robot) -> LegMatch:
    """Pair legs by normalised stance position and joints by order along matched legs."""
    if len(source.legs) != len(target.legs):
        raise RetargetError(
            f"cannot retarget {source.name} ({len(source.legs)} legs) to {target.name} "
            f"({len(target.legs)} legs): leg roles match only between bodies with as many legs"
        )
    # scipy.optimize is imported here, not at module level: it is 0.6 s of every `gaitsmith`
    # command's start-up (the CLI registers `retarget`), and only this function needs it
    from scipy.optimize import linear_sum_assignment

    a, b = normalised_stance_xy(source), normalised_stance_xy(target)
    cost = ((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2)
    rows, cols = linear_sum_assignment(cost)
    target_foot = [0] * len(source.legs)
    for r, c in zip(rows, cols, strict=True):
        target_foot[int(r)] = int(c)
    s_index = {n: i for i, n in enumerate(source.joint_names)}
    t_index = {n: i for i, n in enumerate(target.joint_names)}
    axes_s, axes_t = _stance_axes(source), _stance_axes(target)
    joint_source = [-1] * len(target.joints)
    joint_sign = [1.0] * len(target.joints)
    for i, leg in enumerate(source.legs):
        other = target.legs[target_foot[i]]
        # in chain order, each target joint takes the next source joint about a parallel axis
        # (equal chains: joint k ↔ joint k; a 2-joint leg takes the pitch joints of a 3-joint
        # one); a target joint with none holds its stance
        source_chain = [s_index[n] for n in leg.joints]
        k = 0
        for jt_name in other.joints:
            jt = t_index[jt_name]
            for k2 in range(k, len(source_chain)):
                js = source_chain[k2]
                cos = float(np.dot(axes_s[js], axes_t[jt]))
                if abs(cos) >= _AXIS_MATCH_MIN_COS:
                    joint_source[jt] = js
                    joint_sign[jt] = 1.0 if cos > 0 else -1.0
                    k = k2 + 1
                    break
    return LegMatch(tuple(target_foot), tuple(joint_source), tuple(joint_sign))


@dataclass(frozen=True, eq=False)
class Motion:
    """One gait cycle of one robot sampled at N knots (conventions: `planner.nlp.variables`)."""

    robot: Robot
    schedule: ContactSchedule
    speed_m_s: float
    base_pose: np.ndarray  # N × 6, treadmill frame
    joint_angles_rad: np.ndarray  # N × J
    forces_mg: np.ndarray  # N × F × 3, units of the robot's weight
    joint_torques_nm: np.ndarray  # N × J

    @property
    def n_knots(self) -> int:
        return int(self.joint_angles_rad.shape[0])


def _static_forces(schedule: ContactSchedule, n_knots: int) -> np.ndarray:
    contact = schedule.contact_matrix(n_knots).astype(float)
    f = np.zeros((n_knots, schedule.n_feet, 3))
    f[:, :, 2] = contact / np.maximum(contact.sum(axis=1, keepdims=True), 1.0)
    return f


def _resample_periodic(a: np.ndarray, n_knots: int) -> np.ndarray:
    """Linear periodic resampling of per-knot rows (phases k/N) to `n_knots` rows."""
    n = a.shape[0]
    if n == n_knots:
        return a.copy()
    flat = a.reshape(n, -1)
    src = np.arange(n + 1) / n
    closed = np.vstack([flat, flat[:1]])
    dst = np.arange(n_knots) / n_knots
    out = np.column_stack([np.interp(dst, src, closed[:, c]) for c in range(flat.shape[1])])
    return out.reshape((n_knots, *a.shape[1:]))


def motion_from_gait(gait: Gait, robot: Robot, n_knots: int) -> Motion:
    """The gait file's cycle at `n_knots` knots (the expected joint angles, not servo goals)."""
    t = np.arange(n_knots) / n_knots * gait.period_s
    q = np.asarray(gait.expected_joint_angles(t), dtype=float).reshape(n_knots, -1)
    if gait.base_pose is not None:
        base = _resample_periodic(np.asarray(gait.base_pose, dtype=float), n_knots)
        base[:, 3:] = np.arctan2(np.sin(base[:, 3:]), np.cos(base[:, 3:]))
    else:
        base = np.zeros((n_knots, 6))
        base[:, 2] = robot.stance_base_height_m
    weight_n = robot.mass_kg * GRAVITY_M_S2
    if gait.contact_forces_n is not None:
        forces = _resample_periodic(np.asarray(gait.contact_forces_n, dtype=float), n_knots)
        forces = forces / weight_n
        forces *= gait.schedule.contact_matrix(n_knots)[:, :, None]
    else:
        forces = _static_forces(gait.schedule, n_knots)
    torques = (
        _resample_periodic(np.asarray(gait.joint_torques_nm, dtype=float), n_knots)
        if gait.joint_torques_nm is not None
        else np.zeros_like(q)
    )
    return Motion(robot, gait.schedule, gait.velocity.vx_m_s, base, q, forces, torques)


def motion_from_result(result: PlanResult, robot: Robot) -> Motion:
    weight_n = robot.mass_kg * GRAVITY_M_S2
    return Motion(
        robot,
        result.schedule,
        result.speed_m_s,
        result.base_pose,
        result.joint_angles_rad,
        result.contact_forces_n / weight_n,
        result.joint_torques_nm,
    )


def _cyclic_rate(a: np.ndarray, dt_s: float) -> np.ndarray:
    return (np.roll(a, -1, axis=0) - np.roll(a, 1, axis=0)) / (2.0 * dt_s)


def map_motion(motion: Motion, target: Robot, match: LegMatch) -> Motion:
    """The motion carried onto `target` at the same Froude number (see the module docstring)."""
    source = motion.robot
    factor = froude_factor(source, target)
    ratio = target.leg_length_m / source.leg_length_m
    s_foot = match.source_foot
    schedule = ContactSchedule(
        motion.schedule.period_s * factor,
        target.foot_names,
        tuple(motion.schedule.touchdown_phase[s] for s in s_foot),
        tuple(motion.schedule.duty_factor[s] for s in s_foot),
    )
    base = motion.base_pose.copy()
    base[:, 0:2] *= ratio
    base[:, 2] = target.stance_base_height_m + (base[:, 2] - source.stance_base_height_m) * ratio
    stance_s = np.asarray(source.nominal_stance_rad)
    stance_t = np.asarray(target.nominal_stance_rad)
    q = np.tile(stance_t, (motion.n_knots, 1))
    tau = np.zeros_like(q)
    torque_scale = (target.mass_kg * target.leg_length_m) / (source.mass_kg * source.leg_length_m)
    for jt, (js, sign) in enumerate(zip(match.joint_source, match.joint_sign, strict=True)):
        if js >= 0:
            q[:, jt] = stance_t[jt] + sign * (motion.joint_angles_rad[:, js] - stance_s[js])
            tau[:, jt] = sign * motion.joint_torques_nm[:, js] * torque_scale
    lo = np.array([j.lower_rad for j in target.joints])
    hi = np.array([j.upper_rad for j in target.joints])
    q = np.clip(q, lo + 0.02, hi - 0.02)
    forces = motion.forces_mg[:, list(s_foot), :]
    return Motion(target, schedule, motion.speed_m_s * factor, base, q, forces, tau)


def warm_start(motion: Motion, planner: GaitPlanner) -> WarmStart:
    """An IPOPT start point for `planner` (same robot and N as `motion`): poses, forces,
    torques, and the lifted rates and servo-goal slopes they imply (zero multipliers: the
    planner restarts them, `planner.nlp.spacetime.WARM_START_DUALS`)."""
    if motion.robot.joint_names != planner.robot.joint_names or motion.n_knots != planner.n_knots:
        raise RetargetError("internal: motion and planner differ in joints or knots")
    n, dt_s = motion.n_knots, motion.schedule.period_s / motion.n_knots
    pose = np.hstack([motion.base_pose, motion.joint_angles_rad])
    pose[:, 3:6] = np.unwrap(pose[:, 3:6], axis=0)
    # the planner's own differences (planner.nlp.constraints): central first, second differences
    vel = _cyclic_rate(pose, dt_s)
    acc = (np.roll(pose, -1, axis=0) - 2.0 * pose + np.roll(pose, 1, axis=0)) / dt_s**2
    slopes = np.zeros_like(motion.joint_angles_rad)
    if planner.options.servo_goals:  # knot slopes of the spline through the servo goals
        goals = servo_goals_rad(motion.joint_angles_rad, vel[:, 6:], motion.joint_torques_nm,
                                servo_loops(planner.robot, planner.options.servo_settings))
        slopes = PeriodicSpline(goals).derivative(np.arange(n) / n) / motion.schedule.period_s
    x = planner.layout.pack(motion.base_pose, motion.joint_angles_rad, motion.forces_mg,
                            vel=vel, acc=acc, tau=motion.joint_torques_nm, goal_slope=slopes)
    return planner.primal_start(x, clip_to_bounds=True)


@dataclass(frozen=True)
class SolveRecord:
    """One solve of a retargeting run (a hybrid at `alpha`, or the target at alpha 1)."""

    robot: str
    alpha: float
    speed_m_s: float
    period_s: float
    iterations: int
    solve_time_s: float
    build_time_s: float
    cost: float
    feasible: bool


@dataclass(frozen=True, eq=False)
class RetargetResult:
    planner: GaitPlanner  # the target's
    result: PlanResult
    match: LegMatch
    records: tuple[SolveRecord, ...]
    hybrid_note: str  # why the hybrid series was left out, "" when it ran (or K = 1)

    @property
    def n_solves(self) -> int:
        return len(self.records)

    @property
    def iterations(self) -> int:
        return sum(r.iterations for r in self.records)

    @property
    def solve_time_s(self) -> float:
        return sum(r.solve_time_s for r in self.records)

    @property
    def build_time_s(self) -> float:
        return sum(r.build_time_s for r in self.records)


def _record(planner: GaitPlanner, result: PlanResult, alpha: float, build_s: float) -> SolveRecord:
    return SolveRecord(
        planner.robot.name,
        alpha,
        result.speed_m_s,
        result.schedule.period_s,
        result.iterations,
        result.solve_time_s,
        build_s,
        result.cost,
        result.feasible,
    )


def retarget(
    motion: Motion,
    target: Robot,
    *,
    n_knots: int,
    options: PlannerOptions | None = None,
    steps: int = 1,
    progress: Callable[[SolveRecord], None] | None = None,
    target_planner: GaitPlanner | None = None,
) -> RetargetResult:
    """Plan `target`'s gait from `motion` (another robot's cycle at `n_knots` knots).

    `steps` K: solves in the series, the last on the target (K − 1 hybrids before it). The
    target's planner may be passed in to share its NLP with a from-scratch comparison.
    """
    from planner.hybrid_body import HybridBodyError, hybrid_robot, match_bodies

    if steps < 1:
        raise RetargetError(f"steps must be ≥ 1, got {steps}")
    if motion.n_knots != n_knots:
        raise RetargetError("internal: resample the motion to n_knots first")
    source = motion.robot
    match = match_legs(source, target)
    records: list[SolveRecord] = []
    note = ""
    current = motion
    if steps > 1:
        try:
            pairs = match_bodies(source, target, match.target_foot)
        except HybridBodyError as exc:
            note = f"hybrid series left out: {exc}"
            pairs = None
        if pairs is not None:
            with tempfile.TemporaryDirectory(prefix="gaitsmith-hybrid-") as tmp:
                for k in range(1, steps):
                    alpha = k / steps
                    try:
                        body = hybrid_robot(source, target, pairs, alpha, Path(tmp) / f"h{k}")
                    except HybridBodyError as exc:
                        note = f"hybrid series stopped before α={alpha:.2f}: {exc}"
                        break
                    planner = GaitPlanner(body, n_knots=n_knots, options=options,
                                          background_compile=False)  # a one-off body
                    start = map_motion(current, body, LegMatch.identity(body))
                    result = planner.solve(start.schedule, start.speed_m_s,
                                           warm_start(start, planner))
                    records.append(_record(planner, result, alpha, planner.build_time_s))
                    if progress:
                        progress(records[-1])
                    # an infeasible hybrid is skipped: the next one starts from the last good
                    # motion, rescaled to its own body
                    current = motion_from_result(result, body) if result.feasible else start
    planner = target_planner or GaitPlanner(target, n_knots=n_knots, options=options)
    build_s = 0.0 if target_planner is not None else planner.build_time_s
    # hybrids keep the source's joints and legs, so the source's role match applies to them
    start = map_motion(current, target, match)
    result = planner.solve(start.schedule, start.speed_m_s, warm_start(start, planner))
    records.append(_record(planner, result, 1.0, build_s))
    if progress:
        progress(records[-1])
    return RetargetResult(planner, result, match, tuple(records), note)


def plan_from_scratch(
    planner: GaitPlanner, schedule: ContactSchedule, speed_m_s: float
) -> PlanResult:
    """The comparison: the same schedule and speed solved cold (nominal-stance start)."""
    return planner.solve(schedule, speed_m_s, warm_start=False)

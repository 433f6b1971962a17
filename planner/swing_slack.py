"""How fast a schedule asks the servos to swing a leg, against the fastest swing they can make.

A foot in swing returns the stride the body travelled over it in stance: s = v·d·T at speed v,
duty d and period T, in the swing time t_s = (1 − d)·T. Moving the foot forward by s at the
stance pose turns each of its leg's joints by Δq_j = e_j·s, where e_j = |∂q_j/∂x| is the
joint's share of a forward foot motion (least-norm inverse of the foot's position Jacobian at
the nominal stance; a flat foot also keeps its sole's orientation).

The fastest rest-to-rest move of Δq that the planner's servo envelope allows
(`planner.nlp.constraints.envelope_faces`: |τ|/(m·τ_stall) + |q̇|/ω₀ ≤ 1, |q̇| ≤ m_v·ω₀) on a
joint of inertia I (the leg's own inertia about the joint at stance plus the rotor's armature:
the diagonal of MuJoCo's joint-space mass matrix) is bang-bang: full torque
m·τ_stall·(1 − q̇/ω₀) to mid-way and the mirror image back (time-optimal control of a double
integrator with a bounded input, Pontryagin's principle; Bryson & Ho 1975 §7.2, with the
speed-dependent bound). Accelerating from rest, q̇(t) = ω₀·(1 − e^(−t/τ_c)) with the mechanical
time constant τ_c = I·ω₀/(m·τ_stall), so half the move takes t₁ with

    Δq/2 = ω₀·(t₁ − τ_c·(1 − e^(−t₁/τ_c)))                         (until q̇ reaches m_v·ω₀,
                                                                      then it cruises there)

and the fastest swing is t_min = 2·t₁ (+ the cruise). The *swing slack* of a schedule is
t_s / t_min on its tightest joint: below 1 the servo cannot make the swing at all (the NLP is
infeasible or sits on its envelope at the swing's ends); the rest of the envelope is what the
plan has for gravity, the lift, the body's motion and MuJoCo's tracking error.

It is a figure of the stride alone: it ignores the lift (the swing clearance), gravity on the
swinging leg and the body's own motion, so it is an estimate, not a bound (the NLP may rotate
the body to shorten a joint's excursion). Measured on the zoo in docs/results/heavy_rotor.md
("Session 26").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.stance import stance_kinematics
from robots import ContactSchedule, Robot


@dataclass(frozen=True)
class JointSwing:
    """One leg joint's part in a swing: its excursion per metre of forward foot motion and the
    figures of its servo that bound how fast it can make it."""

    joint: str
    leg: int  # index in `robot.legs`
    excursion_rad_per_m: float  # e = |∂q/∂x| at the stance
    inertia_kg_m2: float  # joint-space inertia at the stance (links + armature)
    armature_kg_m2: float
    stall_torque_nm: float
    no_load_speed_rad_s: float


@dataclass(frozen=True)
class SwingSlack:
    """Swing time over the fastest swing the servo envelope allows, on the tightest joint."""

    ratio: float  # t_s / t_min (inf: nothing to swing, e.g. speed 0)
    joint: str  # the tightest joint ("" when ratio is inf)
    swing_s: float  # its leg's swing time (1 − d)·T
    fastest_swing_s: float  # t_min of its excursion
    excursion_rad: float  # Δq = e·v·d·T


def joint_swings(robot: Robot) -> tuple[JointSwing, ...]:
    """`JointSwing` of every leg joint of `robot` at its nominal stance (cached per model)."""
    key = (str(robot.mjcf_path), robot.fingerprint)
    cached = _CACHE.get(key)
    if cached is not None:
        return cached
    stance = stance_kinematics(robot)
    model = stance.model
    data = mujoco.MjData(model)
    data.qpos[:] = stance.data.qpos
    mujoco.mj_forward(model, data)
    mass = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass)
    names = [j.name for j in robot.joints]
    dof = [int(model.jnt_dofadr[jid]) for jid in stance.joint_ids]
    out: list[JointSwing] = []
    for leg_index, leg in enumerate(robot.legs):
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
        jac_pos = np.zeros((3, model.nv))
        jac_rot = np.zeros((3, model.nv))
        mujoco.mj_jacSite(model, data, jac_pos, jac_rot, site)
        cols = [dof[names.index(n)] for n in leg.joints]
        jac = np.vstack([jac_pos[:, cols], jac_rot[:, cols]]) if leg.is_flat else jac_pos[:, cols]
        forward = np.zeros(jac.shape[0])
        forward[0] = 1.0
        share = np.linalg.pinv(jac) @ forward
        for name, e in zip(leg.joints, share, strict=True):
            j = names.index(name)
            servo = robot.joints[j].servo
            out.append(JointSwing(name, leg_index, float(abs(e)), float(mass[dof[j], dof[j]]),
                                  float(model.dof_armature[dof[j]]), servo.stall_torque_nm,
                                  servo.no_load_speed_rad_s))
    result = tuple(out)
    _CACHE[key] = result
    return result


_CACHE: dict[tuple[str, str], tuple[JointSwing, ...]] = {}


def fastest_swing_s(excursion_rad: float, inertia_kg_m2: float, torque_nm: float,
                    no_load_speed_rad_s: float, speed_fraction: float = 1.0) -> float:
    """The time-optimal rest-to-rest move of `excursion_rad` under |τ| ≤ torque·(1 − |q̇|/ω₀)
    and |q̇| ≤ speed_fraction·ω₀ (module docstring)."""
    if not (inertia_kg_m2 > 0 and torque_nm > 0 and no_load_speed_rad_s > 0
            and 0 < speed_fraction <= 1):
        raise PlannerConfigError("fastest_swing_s needs a positive inertia, torque and speed")
    dq = abs(excursion_rad)
    if dq == 0:
        return 0.0
    w0 = no_load_speed_rad_s
    tc = inertia_kg_m2 * w0 / torque_nm

    def half(t: float) -> float:  # angle covered accelerating from rest for t
        return w0 * (t - tc * -math.expm1(-t / tc))

    t_cap = math.inf if speed_fraction >= 1 else -tc * math.log1p(-speed_fraction)
    if t_cap < math.inf and 2 * half(t_cap) < dq:  # reaches the speed cap: cruise between
        return 2 * t_cap + (dq - 2 * half(t_cap)) / (speed_fraction * w0)
    lo, hi = 0.0, max(tc, dq / w0)
    while 2 * half(hi) < dq:
        hi *= 2
    for _ in range(100):  # bisection: half() is increasing
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if 2 * half(mid) < dq else (lo, mid)
    return 2.0 * hi  # t_min = 2·t₁


def swing_slack(robot: Robot, schedule: ContactSchedule, speed_m_s: float,
                options: PlannerOptions | None = None) -> SwingSlack:
    """The schedule's swing slack at `speed_m_s` on the planner's envelope (`options`'
    torque and speed margins): min over the leg joints of (1 − d_f)·T / t_min(e·|v|·d_f·T)."""
    options = options or PlannerOptions()
    best = SwingSlack(math.inf, "", 0.0, 0.0, 0.0)
    for js in joint_swings(robot):
        duty = float(schedule.duty_factor[js.leg])
        swing_s = (1.0 - duty) * schedule.period_s
        excursion = js.excursion_rad_per_m * abs(speed_m_s) * duty * schedule.period_s
        fastest = fastest_swing_s(excursion, js.inertia_kg_m2,
                                  options.torque_margin * js.stall_torque_nm,
                                  js.no_load_speed_rad_s, options.speed_margin)
        if fastest <= 0:
            continue
        ratio = swing_s / fastest
        if ratio < best.ratio:
            best = SwingSlack(ratio, js.joint, swing_s, fastest, excursion)
    return best

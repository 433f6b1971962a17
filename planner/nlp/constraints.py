"""Constraints of the spacetime NLP (TOWR-style "constraints" module), W&P 2009 eqs 1-10.

Finite differences are cyclic over the N knots (h = T/N): q̇_k = (q_{k+1} − q_{k−1})/2h,
q̈_k = (q_{k+1} − 2q_k + q_{k−1})/h². Treadmill convention (W&P §3), generalised to the command
frame of `planner.nlp.command` (vx, vy, yaw rate W): the robot stays in place on average in a frame
that moves with the commanded planar motion, neighbouring knots are compared in one frame
(knot k±1 as Δ(±h)∘b_{k±1}; at W = vy = 0 a shift by ±v·h along x), so **stance feet move
with −Δ(h)** (−v along x on a treadmill); the dynamics see the true base velocity ẋ + v, ẏ + vy
and yaw rate + W (Galilean shift, so the torques are the ground-frame ones).

Every group is a column of MX expressions with numeric bounds; the contact schedule switches rows
on and off through the activity parameter C (stance rows are multiplied by C, the force bound is
scaled by C), so the NLP is built once per (robot, N).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from planner.nlp.assembled_jacobian import KnotCall
from planner.nlp.capture_margin import com_with_neighbours
from planner.nlp.command import MotionSymbols
from planner.nlp.config import PlannerOptions
from planner.nlp.flat_foot import (
    contact_offsets,
    flat_foot_groups,
    flat_foot_labels,
    moments_world,
    spare_flat_foot_ankles,
)
from planner.nlp.foot_separation import foot_separation_labels, foot_separation_rows
from planner.nlp.force_rate import force_rate_bounds, force_rate_labels, force_rate_rows
from planner.nlp.line_capture import (
    capture_point,
    line_capture_labels,
    line_capture_rows,
    lip_rate_s,
)
from planner.nlp.mirror import joint_mirror, mirror_labels, mirror_rows
from planner.nlp.model import RobotModel
from planner.nlp.sideways_locked import lateral_slip_bounds_m
from planner.nlp.solver_cache import same_function
from planner.nlp.variables import Layout, Symbols, cyclic_shift, time_unit_s, variable_scale
from robots.robot import Robot

GOAL_SPEED_SAMPLES_PER_KNOT = 8  # as the player's pre-flight (hardware.play.preflight)
GOAL_SPEED_INSIDE = 0.98  # the slope is quadratic between samples: measured overshoot ≈ 0.6 %


@dataclass(frozen=True)
class Group:
    """One named block of constraint rows lb ≤ expr ≤ ub; `unit` scales violations for reports."""

    name: str
    expr: Any
    lb: np.ndarray
    ub: np.ndarray
    #: typical magnitude of a row (group units); the solver sees expr / scale (see
    #: `row_scales`), reports and bounds stay in group units
    scale: float | np.ndarray = 1.0
    #: the schedule's factor on each row of an equality group (a column of MX in the contact
    #: parameters C, as many rows as `expr`) or None: where it is 0 the row reads 0 = 0 whatever
    #: x is (`planner.nlp.inactive_rows`, `PlannerOptions.inactive_rows`)
    activity: Any = None


@dataclass(frozen=True)
class KnotQuantities:
    """Mapped per-knot expressions (each with N columns)."""

    base_rows: Any  # 6 × N: residual of the whole-body Newton–Euler balance (scaled)
    tau_nm: Any  # J × N joint torques (the lifted variables)
    tau_rnea_nm: Any  # J × N joint torques by inverse dynamics
    feet_m: Any  # 3F × N foot-sphere centres (treadmill frame)
    body_z_m: Any  # B × N body-origin heights
    qd: Any  # J × N
    qdd: Any  # J × N
    base_d: Any  # 6 × N base pose rates
    omega_world: Any  # 3 × N: base ω in the world minus the commanded turn (0, 0, W)
    #: the knot map's call as these expressions use it (`planner.nlp.assembled_jacobian`)
    knot_call: KnotCall | None = None


def knot_function(model: RobotModel) -> ca.Function:
    """SX function of one knot: dynamics residual, torques, feet, body heights, ω.

    With flat feet it takes their contact moments too (last input "m", `planner.nlp.flat_foot`).
    """
    nj, nf = model.n_joints, model.n_feet
    b, bd, bdd = ca.SX.sym("b", 6), ca.SX.sym("bd", 6), ca.SX.sym("bdd", 6)
    q, qd, qdd = ca.SX.sym("q", nj), ca.SX.sym("qd", nj), ca.SX.sym("qdd", nj)
    f = ca.SX.sym("f", 3 * nf)
    v, vy, yaw_rate = ca.SX.sym("v"), ca.SX.sym("vy"), ca.SX.sym("yaw_rate")
    weight_n = model.total_mass_kg * float(np.linalg.norm(model.gravity_m_s2))
    turn = ca.vertcat(0, 0, yaw_rate)  # the command frame's yaw rate (rpy rates and ω alike)
    w, dw = model.base_rates(b[3:], bd[3:] + turn, bdd[3:])
    v_base = bd[:3] + ca.vertcat(v, vy, 0)
    forces = ca.reshape(f, 3, nf) * weight_n
    inputs = [b, q, bd, qd, bdd, qdd, f, v, vy, yaw_rate]
    names = ["b", "q", "bd", "qd", "bdd", "qdd", "f", "v", "vy", "yaw_rate"]
    if model.flat_feet:
        m = ca.SX.sym("m", 3 * len(model.flat_feet))
        inputs, names = [*inputs, m], [*names, "m"]
        base_rows, tau = model.inverse_dynamics_wrench(
            b[:3], b[3:], q, v_base, w, qd, bdd[:3], dw, qdd, forces, moments_world(model, m)
        )
    else:
        base_rows, tau = model.inverse_dynamics(
            b[:3], b[3:], q, v_base, w, qd, bdd[:3], dw, qdd, forces
        )
    feet, origins, _ = model.fk(b[:3], b[3:], q)
    scale = ca.DM([1, 1, 1, *[1.0 / model.robot.leg_length_m] * 3]) / weight_n
    return ca.Function(
        "knot",
        inputs,
        [base_rows * scale, tau, ca.reshape(feet, 3 * nf, 1), origins[2, :].T, w - turn],
        names,
        ["base_rows", "tau", "feet", "body_z", "w"],
    )


def knot_output_rows(model: RobotModel) -> tuple[int, ...]:
    """Rows of `knot_function`'s outputs, in order (base_rows, tau, feet, body_z, w)."""
    n_origins = int(model.fk.size_out(1)[1])  # body_z: the height of every origin `fk` gives
    return (6, model.n_joints, 3 * model.n_feet, n_origins, 3)


def stacked_knot(knot: ca.Function) -> ca.Function:
    """`knot` (dense column inputs and outputs) with its inputs stacked into one column u and its
    outputs into one column y: the same SX operations, so the same values.

    CasADi 3.8 checks which outputs of a call can be non-zero whenever its MX AD creates a call
    node (``Function::activity``), at a cost of (inputs × input non-zeros): with the knot's 10–11
    inputs (its forward and adjoint derivatives take three times as many) that was 44 % of
    IPOPT's construction for humanoid20 (docs/results/planner_speed_startup.md, session 26)."""
    sx_in = knot.sx_in()
    for i, v in enumerate([*sx_in, *knot.sx_out()]):
        if not v.sparsity().is_dense() or v.shape[1] != 1:
            raise ValueError(f"knot function {knot.name()}: argument {i} is not a dense column")
    u = ca.vertcat(*sx_in)
    return ca.Function(knot.name(), [u], [ca.vertcat(*knot.call(sx_in))], ["u"], ["y"])


def knot_quantities(
    model: RobotModel,
    sym: Symbols,
    n_knots: int,
    knot: ca.Function | None = None,
    threads: int = 1,
) -> KnotQuantities:
    """The knot function mapped over the knots; `knot`: a `knot_function(model)` or its
    `stacked_knot` to use instead (e.g. one with precomputed derivatives,
    `planner.nlp.solver_cache`); a stacked one is called with its arguments stacked and its
    output split (the same values). `threads` > 1: the
    knots are split into that many chunks evaluated on parallel threads (CasADi's "thread"
    map; its derivatives are threaded maps of the knot's derivatives too). The knot is
    evaluated with the base at x = y = 0 and its feet shifted by the base's x, y afterwards
    (the same values to rounding as the base through the knot, tested)."""
    bd, qd = sym.vel[:6, :], sym.vel[6:, :]
    bdd, qdd = sym.acc[:6, :], sym.acc[6:, :]
    fn = mapped_knots(knot if knot is not None else knot_function(model), n_knots, threads)
    flat = [sym.moments] if model.flat_feet else []
    yaw_rate = _motion(sym).yaw_rate_rad_s
    # the knot's rows do not depend on the base's x, y (translation invariance, tested) and
    # its feet move with them: evaluated at x = y = 0 the knot has 2 NLP-variable inputs
    # fewer (quad12: 64, one batch of forward directions for the NLP Jacobian instead of
    # 64 + 2, i.e. one evaluation of every knot's J instead of two)
    base = ca.vertcat(ca.MX.zeros(2, n_knots), sym.base[2:, :])
    arguments = (
        base, sym.q, bd, qd, bdd, qdd, sym.forces, sym.speed_m_s, _motion(sym).vy_m_s, yaw_rate,
        *flat,
    )
    stacked = fn.n_in() == 1 and len(arguments) > 1  # a `stacked_knot`
    if stacked:
        u = ca.vertcat(*[a if int(a.shape[1]) == n_knots else ca.repmat(a, 1, n_knots)
                         for a in arguments])
        offsets = np.cumsum((0, *knot_output_rows(model))).tolist()
        outputs = tuple(ca.vertsplit(fn(u), offsets))
    else:
        outputs = tuple(fn(*arguments))
    base_rows, tau, feet, body_z, _ = outputs
    shift = ca.vertcat(sym.base[0:2, :], ca.MX.zeros(1, n_knots))
    feet = feet + ca.repmat(shift, model.n_feet, 1)
    # ω from its own small function, not the knot's "w" output: the objective's gradient then
    # differentiates a few dozen instructions instead of the knot's whole Jacobian
    w = omega_function(model).map(n_knots)(sym.base[3:6, :], bd[3:6, :], yaw_rate)
    return KnotQuantities(
        base_rows, sym.tau, tau, feet, body_z, qd, qdd, bd, w,
        KnotCall(arguments, outputs, knot if stacked else None),
    )


def omega_function(model: RobotModel) -> ca.Function:
    """SX function of one knot's base ω in the world minus the commanded turn (0, 0, W): the
    knot function's "w" output alone, the same operations (so the same values). The objective's
    angular-velocity term uses it; through the knot's "w" its gradient evaluated the knot's
    whole Jacobian at every iteration (quad12 N = 30: 11 ms of 150; issue #16)."""
    rpy, rpy_rate = ca.SX.sym("rpy", 3), ca.SX.sym("rpy_rate", 3)
    yaw_rate = ca.SX.sym("yaw_rate")
    turn = ca.vertcat(0, 0, yaw_rate)
    w, _ = model.base_rates(rpy, rpy_rate + turn, ca.SX.zeros(3))
    return ca.Function(
        "omega", [rpy, rpy_rate, yaw_rate], [w - turn], ["rpy", "rpy_rate", "yaw_rate"], ["w"]
    )


def mapped_knots(knot: ca.Function, n_knots: int, threads: int = 1) -> ca.Function:
    """`knot` over `n_knots` knots: a serial map, or with `threads` > 1 a "thread" map of
    equal chunks: the largest divisor of `n_knots` that is ≤ `threads` (serial if none is > 1).
    CasADi pads an uneven split and wraps it in a helper function whose derivatives
    `planner.nlp.solver_cache.used_directions` cannot name."""
    chunks = max(d for d in range(1, max(1, min(threads, n_knots)) + 1) if n_knots % d == 0)
    if chunks <= 1:
        return knot.map(n_knots)
    return knot.map(n_knots, "thread", chunks)


def _motion(sym: Symbols) -> MotionSymbols:
    if sym.motion is None:
        raise ValueError("the NLP symbols carry no velocity command block (make_symbols)")
    return sym.motion


def finite_difference_rates(sym: Symbols, n_knots: int) -> tuple[Any, Any]:
    """The cyclic central differences of the poses, (6+J) × N each: rates (the base's relative
    to the command: world velocity − (vx, vy), yaw rate − W) and accelerations. Linear in the
    poses; knot k's neighbours are compared in its command frame (`planner.nlp.command`)."""
    motion = _motion(sym)
    n, nj = n_knots, int(sym.q.shape[0])
    pose = ca.vertcat(sym.base, sym.q)
    # neighbours in the command frame of knot k (`planner.nlp.command`): only base x, y change
    nxt, prv = cyclic_shift(pose, 1), cyclic_shift(pose, -1)
    nxt = _in_frame(nxt, *motion.next_in_frame(nxt[0, :], nxt[1, :]))
    prv = _in_frame(prv, *motion.previous_in_frame(prv[0, :], prv[1, :]))
    command_rate = ca.repmat(ca.vertcat(motion.vx_m_s, motion.vy_m_s, ca.DM.zeros(4 + nj)), 1, n)
    inv_h = n / sym.period_s
    return (nxt - prv) * (0.5 * inv_h) - command_rate, (nxt - 2 * pose + prv) * (inv_h * inv_h)


def _in_frame(rows: Any, x: Any, y: Any) -> Any:
    """`rows` (poses, N columns) with its first two rows replaced by x, y."""
    return ca.vertcat(x, y, rows[2:, :])


def build_groups(
    model: RobotModel,
    sym: Symbols,
    kq: KnotQuantities,
    n_knots: int,
    options: PlannerOptions,
    derived: Callable[[ca.Function], ca.Function] = same_function,
) -> list[Group]:
    """All constraint groups, in the order they appear in g. `derived`: what the NLP calls in
    place of a per-knot SX function other than the knot (the flat feet's, the soles'), e.g. one
    carrying its own derivatives (`planner.nlp.solver_cache.DerivedFunctions`)."""
    n, nf = n_knots, model.n_feet
    r = contact_offsets(model, n)  # foot radius; 0 for a flat foot's sole centre
    c = sym.contact
    feet_x = kq.feet_m[0::3, :]
    feet_y = kq.feet_m[1::3, :]
    feet_z = kq.feet_m[2::3, :]
    stick = c * cyclic_shift(c, 1)  # foot in stance at k and k+1
    if options.vertical_contact_transitions:
        # stance at k or k+1 (C is 0/1): the foot is also still over the interval that ends at
        # touchdown and the one that starts at lift-off, so it sets down / lifts off vertically
        stick = c + cyclic_shift(c, 1) - stick
    motion = _motion(sym)
    fx, fy, fz = sym.forces[0::3, :], sym.forces[1::3, :], sym.forces[2::3, :]
    mu = options.mu / math.sqrt(2.0)  # inscribed pyramid of the cone (eq 9)
    servos = [j.servo for j in model.robot.joints]
    # identified servos (`robots.servo_params`): the envelope of the fitted drive limit
    strength = [1.0] * len(servos) if options.servo_settings is None else [
        st.strength for st in options.servo_settings
    ]  # fmt: skip
    stall = ca.DM([s.stall_torque_nm * k for s, k in zip(servos, strength, strict=True)])
    omega0 = ca.DM([s.no_load_speed_rad_s for s in servos])
    tau_n = kq.tau_nm / ca.repmat(stall * options.torque_margin, 1, n)
    qd_n = kq.qd / ca.repmat(omega0, 1, n)
    nj = model.n_joints
    zeros = np.zeros
    inf = np.inf

    def col(e: Any) -> Any:
        return ca.vec(e)

    clearance = options.body_clearance_for(model.robot.leg_length_m)
    vel_fd, acc_fd = finite_difference_rates(sym, n)
    inv_h = n / sym.period_s
    # row scales (nondimensional NLP, see `planner.nlp.variables.variable_scale`): lengths in leg
    # lengths, times in √(L/g); the rows vel − D₁·pose, acc − D₂·pose as the rates they equal
    length = model.robot.leg_length_m
    t0 = time_unit_s(length, float(np.linalg.norm(model.gravity_m_s2)) or 9.81)
    layout = Layout.of(model, n)
    n_rates = layout.n_rates
    scale = variable_scale(layout, model)
    fd_scale = np.r_[layout.view(scale, "vel").ravel(), layout.view(scale, "acc").ravel()]
    next_feet_x, next_feet_y = motion.next_in_frame(cyclic_shift(feet_x, 1),
                                                    cyclic_shift(feet_y, 1))
    lateral_lb, lateral_ub = lateral_slip_bounds_m(
        model.robot, n, options.sideways_slip_leg_lengths
    )
    # cyclic central differences tie the lifted rates to the poses (linear in x)
    differences = Group(
        "finite differences",
        ca.vertcat(col(sym.vel - vel_fd), col(sym.acc - acc_fd)),
        zeros(2 * n_rates),
        zeros(2 * n_rates),
        fd_scale,
    )
    groups = [
        differences,
        # W&P eqs 7-8: the floating base is unactuated — whole-body linear/angular momentum rate
        # equals gravity + contact forces (the six base rows of the inverse dynamics vanish).
        Group("dynamics", col(kq.base_rows), zeros(6 * n), zeros(6 * n)),
        # joint torques by inverse dynamics of the floating-base tree (scaled by τ_stall)
        Group(
            "inverse dynamics",
            col((kq.tau_nm - kq.tau_rnea_nm) / ca.repmat(stall, 1, n)),
            zeros(nj * n),
            zeros(nj * n),
        ),
        # eq 2: stance foot-sphere centre at the sphere radius
        Group("stance height", col(c * (feet_z - r)), zeros(nf * n), zeros(nf * n), length,
              col(c)),
        # eq 3: stance feet stay put in the world: knot k+1's foot, in the command frame of knot
        # k, is where it was at k (on a treadmill: moves at −v along x, not sideways); with
        # `vertical_contact_transitions` also over the last swing interval before touchdown and
        # the first one after lift-off
        # (the lateral rows of feet that cannot move sideways relative to the body get a band
        # of ±ε: `planner.nlp.sideways_locked`)
        Group(
            "stance no-slip",
            ca.vertcat(
                col(stick * (next_feet_x - feet_x)),
                col(stick * (next_feet_y - feet_y)),
            ),
            np.r_[zeros(nf * n), lateral_lb],
            np.r_[zeros(nf * n), lateral_ub],
            length,
            ca.vertcat(col(stick), col(stick)),
        ),
        # eq 1 for feet + anti-scuffing clearance profile in swing
        Group(
            "swing clearance",
            col(feet_z - r - sym.min_height_m),
            zeros(nf * n),
            np.full(nf * n, inf),
            length,
        ),
        # eq 1: the body stays clear of the ground; links closer to their foot than the
        # clearance (ankles, soles: `RobotModel.foot_distance_m`) only keep their origin above it
        Group(
            "body clearance",
            col(kq.body_z_m - clearance),
            np.tile(np.where(model.foot_distance_m < clearance, -clearance, 0.0), n),
            np.full(model.n_bodies * n, inf),
            length,
        ),
        *_servo_goal_groups(model, sym, kq, n, options, inv_h),
        # eq 9: friction pyramid inscribed in the cone µ
        Group(
            "friction",
            ca.vertcat(col(mu * fz - fx), col(mu * fz + fx), col(mu * fz - fy), col(mu * fz + fy)),
            zeros(4 * nf * n),
            np.full(4 * nf * n, inf),
        ),
        # unilateral contact with zero force in swing: 0 ≤ f_z ≤ C·f_max (f_z ≥ 0 is a bound;
        # with `compact_rows` "swing force" the upper side is a per-solve bound too)
        *([] if "swing force" in options.compact_rows else [Group(
            "swing force",
            col(c * options.max_force_body_weights - fz),
            zeros(nf * n),
            np.full(nf * n, inf),
        )]),
        # servo no-load speed |q̇| ≤ margin·ω₀ (a bound of the lifted rates with
        # `compact_rows` "joint speed", `planner.nlp.variables.variable_bounds`)
        *([] if "joint speed" in options.compact_rows else [Group(
            "joint speed",
            col(qd_n),
            np.full(nj * n, -options.speed_margin),
            np.full(nj * n, options.speed_margin),
        )]),
        # torque–speed envelope |τ| ≤ margin·τ_stall·(1 − |q̇|/ω₀), the four faces of the diamond
        envelope_group("torque envelope", tau_n, qd_n, "torque envelope" in options.compact_rows),
        # eq 6: remove the treadmill's translation invariance (mean base x, y at the origin)
        Group(
            "drift",
            ca.vertcat(ca.sum2(sym.base[0, :]), ca.sum2(sym.base[1, :])) / n,
            zeros(2),
            zeros(2),
        ),
        *_rotor_reserve_groups(model, kq, n, options, stall, qd_n),
        *_line_capture_groups(model, sym, n, options, kq, inv_h),
        *_force_rate_groups(model, sym, n, options, inv_h, t0),
        *flat_foot_groups(model, sym, n, options, stick, Group, derived),
        *_static_margin_groups(model, sym, kq, n, options),
        *_mean_footprint_groups(model, sym, n, options),
        *_mirror_groups(model, sym, n, options),
    ]
    # neighbouring feet do not cross (`planner.nlp.foot_separation`), in rows counted in
    # `separation_unit_m` (metres unless `PlannerOptions.separation_unit_leg_lengths` is set)
    unit_m = options.separation_unit_m(length)
    separation, separation_lb = foot_separation_rows(model, sym, kq.feet_m, derived, unit_m)
    if separation_lb.size:
        groups.append(Group("foot separation", separation, separation_lb,
                            np.full(separation_lb.size, inf), length / unit_m))
    return spare_flat_foot_ankles(model, groups, n)


def envelope_group(name: str, tau_n: Any, qd_n: Any, ranged: bool) -> Group:
    """The torque–speed diamond |τ/τ_s| + |q̇/ω₀| ≤ 1 as its four faces ≤ 1 (`envelope_faces`)
    or, `ranged`, as the same set in two ranged rows −1 ≤ τ/τ_s ± q̇/ω₀ ≤ 1
    (`envelope_ranges`): IPOPT gives a ranged row one slack, so the KKT system loses two rows
    per face pair."""
    if ranged:
        size = 2 * int(tau_n.numel())
        return Group(name, envelope_ranges(tau_n, qd_n), -np.ones(size), np.ones(size))
    size = 4 * int(tau_n.numel())
    return Group(name, envelope_faces(tau_n, qd_n), np.full(size, -np.inf), np.ones(size))


def envelope_ranges(tau_n: Any, qd_n: Any) -> Any:
    """τ/τ_s + q̇/ω₀ and τ/τ_s − q̇/ω₀ (J × N each, stacked): the diamond is both in [−1, 1]
    (faces 1 and 4 of `envelope_faces` are the first's two sides, faces 2 and 3 the second's)."""
    return ca.vertcat(ca.vec(tau_n + qd_n), ca.vec(tau_n - qd_n))


def envelope_faces(tau_n: Any, qd_n: Any) -> Any:
    """The four faces of the torque–speed diamond |τ/τ_s| + |q̇/ω₀| ≤ 1, each ≤ 1 (τ and q̇
    already divided by the margined stall torque and the no-load speed; J × N each)."""
    return ca.vertcat(ca.vec(tau_n + qd_n), ca.vec(tau_n - qd_n), ca.vec(-tau_n + qd_n),
                      ca.vec(-tau_n - qd_n))


def _rotor_reserve_groups(model: RobotModel, kq: KnotQuantities, n: int,
                          options: PlannerOptions, stall: Any, qd_n: Any) -> list[Group]:
    """Rotor reserve (`PlannerOptions.rotor_reserve`): the torque–speed envelope also holds for
    τ + ρ·I_a·q̈, the knot torque with the rotor's share (armature × joint acceleration) taken
    1 + ρ times, so joints whose torque is mostly the rotor's keep a reserve for the tracking
    error the servo loop adds to it in MuJoCo (docs/results/heavy_rotor.md)."""
    rho = options.rotor_reserve
    arm = np.asarray(model.armature[6:], dtype=float)
    if rho is None or not np.any(arm > 0):
        return []
    tau = kq.tau_nm + rho * ca.diag(ca.DM(arm)) @ kq.qdd
    tau_n = tau / ca.repmat(stall * options.torque_margin, 1, n)
    return [envelope_group("rotor reserve", tau_n, qd_n,
                           "torque envelope" in options.compact_rows)]


def _line_capture_groups(model: RobotModel, sym: Symbols, n: int, options: PlannerOptions,
                         kq: KnotQuantities, inv_h: Any) -> list[Group]:
    """Line-capture margin (`PlannerOptions.line_capture_margin_leg_lengths`,
    `planner.nlp.line_capture`): on two-foot support the capture point lies on the side of the
    support line where the next swing foot lands, at least m = margin·L from it."""
    margin = options.line_capture_margin_leg_lengths
    if margin is None or model.n_feet < 3:
        return []
    from planner.templates import stance_foot_positions_m

    length = model.robot.leg_length_m
    com, nxt, prv = com_with_neighbours(model, sym, n)
    icp = capture_point(com, nxt, prv, inv_h, lip_rate_s(model.robot.stance_base_height_m))
    expr = line_capture_rows(sym.contact, kq.feet_m, icp,
                             stance_foot_positions_m(model.robot)[:, :2], margin * length)
    size = int(expr.shape[0])
    return [Group("line capture", expr, np.zeros(size), np.full(size, np.inf), length)]


def _force_rate_groups(model: RobotModel, sym: Symbols, n: int, options: PlannerOptions,
                       inv_h: Any, t0_s: float) -> list[Group]:
    """Normal-force rate bound (`PlannerOptions.normal_force_rate_weights_per_t0`,
    `planner.nlp.force_rate`): a foot's load changes by at most ρ body weights per √(L/g)."""
    rho = options.normal_force_rate_weights_per_t0
    if rho is None:
        return []
    lb, ub = force_rate_bounds(rho, model.n_feet, n)
    return [Group("normal force rate", force_rate_rows(sym.forces[2::3, :], inv_h, t0_s), lb, ub)]


def footprint_unheld_by_symmetry(robot: Robot) -> bool:
    """Is some stance foot not in a mirror pair (on the sagittal plane, or no mirror image at
    all, `planner.templates.mirror_permutation`)? Then no gait of the robot is half-cycle
    mirror symmetric (a midline foot would be its own image half a cycle later), and nothing
    holds its mean footprint's yaw about the body
    (`PlannerOptions.unmirrored_mean_footprint_leg_lengths`)."""
    from planner.templates import mirror_permutation

    perm = mirror_permutation(robot)
    return perm is None or any(g == f for f, g in enumerate(perm))


def _mean_footprint_groups(model: RobotModel, sym: Symbols, n: int, options: PlannerOptions
                           ) -> list[Group]:
    """Mean footprint (`PlannerOptions.mean_footprint_leg_lengths`): the cycle mean of each
    foot's x, y in the base frame — the forward kinematics of the joints alone, base at the
    origin and level — within ±t of its nominal stance position
    (`planner.templates.stance_foot_positions_m`) shifted by `mean_footprint_offset_m`."""
    t = options.mean_footprint_leg_lengths
    if t is None and footprint_unheld_by_symmetry(model.robot) and not (
        model.flat_feet and options.flat_mean_footprint_leg_lengths is not None
    ):  # the rule on the body (`PlannerOptions.unmirrored_mean_footprint_leg_lengths`)
        t = options.unmirrored_mean_footprint_leg_lengths
    if t is None:
        return []
    from planner.templates import stance_foot_positions_m

    nominal = stance_foot_positions_m(model.robot)
    tol_m = t * model.robot.leg_length_m
    feet, _, _ = model.fk.map(n)(ca.DM.zeros(3, n), ca.DM.zeros(3, n), sym.q)
    nf = model.n_feet
    # 3 × (N·F), knot-major: the mean over knots of foot f is the mean of columns f, f+F, …
    mean = sum((feet[:2, k * nf:(k + 1) * nf] for k in range(n)), ca.MX.zeros(2, nf)) / n
    dx, dy = options.mean_footprint_offset_m
    centre = np.r_[nominal[:, 0] + dx, nominal[:, 1] + dy]
    return [Group("mean footprint", ca.vertcat(mean[0, :].T, mean[1, :].T), centre - tol_m,
                  centre + tol_m, model.robot.leg_length_m)]


def _mirror_groups(model: RobotModel, sym: Symbols, n: int, options: PlannerOptions
                   ) -> list[Group]:
    """Half-cycle mirror symmetry (`PlannerOptions.half_cycle_mirror`, `planner.nlp.mirror`)."""
    if not options.half_cycle_mirror:
        return []
    mirror = joint_mirror(model.robot)
    held = tuple(j for j, joint in enumerate(model.robot.joints) if joint.held)
    rows, kinds = mirror_rows(mirror, held, sym.base, sym.q, n)
    zero = np.zeros(kinds.size)
    scale = np.where(kinds == 0, model.robot.leg_length_m, 1.0)
    return [Group("half-cycle mirror", rows, zero, zero, scale)]


def _static_margin_groups(
    model: RobotModel, sym: Symbols, kq: KnotQuantities, n: int, options: PlannerOptions
) -> list[Group]:
    """Static stability margin (`PlannerOptions.static_margin_leg_lengths`): at every knot the
    ground projection c of the centre of mass lies at least d inside each edge i → j of the
    stance polygon, cross(p_j − p_i, c − p_i) ≥ d·|p_j − p_i| with the knot's own foot
    positions p. Which pairs are edges follows from the contact parameters C
    (`planner.search.support.PolygonEdge`): the row of edge e at knot k is multiplied by
    C_i·C_j·Π_between(1 − C_l)·(1 − Π_beyond(1 − C_l)), 1 exactly when i → j is an edge of a
    polygon of ≥ 3 feet, so line, single-foot and flight knots have no rows in force and one
    build still serves every schedule.
    """
    if options.static_margin_leg_lengths is None:
        return []
    from planner.search.support import polygon_edges
    from planner.templates import stance_foot_positions_m

    margin_m = options.static_margin_leg_lengths * model.robot.leg_length_m
    edges = polygon_edges(stance_foot_positions_m(model.robot)[:, :2])
    _, _, com = model.fk.map(n)(sym.base[:3, :], sym.base[3:, :], sym.q)
    c = sym.contact
    fx, fy = kq.feet_m[0::3, :], kq.feet_m[1::3, :]
    rows = []
    for e in edges:
        active = c[e.i, :] * c[e.j, :]
        for f in e.between:
            active = active * (1 - c[f, :])
        lone = ca.MX.ones(1, n)
        for f in e.beyond:
            lone = lone * (1 - c[f, :])
        active = active * (1 - lone)
        ux, uy = fx[e.j, :] - fx[e.i, :], fy[e.j, :] - fy[e.i, :]
        cross = ux * (com[1, :] - fy[e.i, :]) - uy * (com[0, :] - fx[e.i, :])
        rows.append(active * (cross - margin_m * ca.sqrt(ux * ux + uy * uy + 1e-12)))
    length = model.robot.leg_length_m
    return [Group("static margin", ca.vec(ca.vertcat(*rows).T), np.zeros(len(edges) * n),
                  np.full(len(edges) * n, np.inf), length * length)]


def row_scales(groups: list[Group]) -> np.ndarray:
    """One scale per row of g, in the order of `groups`."""
    return np.concatenate(
        [np.broadcast_to(np.asarray(grp.scale, dtype=float), grp.lb.shape) for grp in groups]
    )


def _servo_goal_groups(
    model: RobotModel,
    sym: Symbols,
    kq: KnotQuantities,
    n: int,
    options: PlannerOptions,
    inv_h: Any,
) -> list[Group]:
    """Servo goals (`planner.nlp.servo_loop`) inside the joint limits and the player's speed limit.

    goal = q + (τ + d·q̇)/kp is linear in the lifted variables, and so are the spline's knot
    slopes (lifted too, see `planner.nlp.variables`) and its slope between knots: all rows are
    linear
    and sparse. The player clips goals to the joint limits and their change to `speed_margin`·ω₀
    per tick (and its pre-flight refuses a faster gait); a goal the player clips is a torque the
    servo does not produce, so the plan must not need it.
    """
    if not options.servo_goals:
        return []
    from planner.nlp.servo_loop import loop_arrays, servo_loops

    kp, damping = loop_arrays(servo_loops(model.robot, options.servo_settings))
    nj = model.n_joints
    goal = (
        sym.q
        + kq.tau_nm / ca.repmat(ca.DM(kp), 1, n)
        + kq.qd * ca.repmat(ca.DM(damping / kp), 1, n)
    )
    lifted: list[Group] = []
    if sym.goal is not None:
        # `PlannerOptions.servo_goal_form` "lifted": the goal is a variable tied to its
        # formula; the rows below read it (one entry per joint and knot instead of three)
        lifted = [Group("servo goal", ca.vec(sym.goal - goal), np.zeros(nj * n),
                        np.zeros(nj * n))]
        goal = sym.goal
    lo, hi = model.joint_limits_rad()
    margin = options.joint_limit_margins_rad(lo, hi)
    omega0 = ca.DM([j.servo.no_load_speed_rad_s for j in model.robot.joints])
    # the player streams the periodic cubic spline through the goals (`Gait.joint_targets`) and its
    # pre-flight rejects a gait whose spline is faster than margin·ω₀ anywhere. Knot slopes s_k of
    # the C² periodic spline [rad/s]: s_{k−1} + 4 s_k + s_{k+1} = 3 (g_{k+1} − g_{k−1}) N/T; on
    # the interval k…k+1 at u ∈ [0, 1) the Hermite form gives the slope
    # 6(u − u²)(g_{k+1} − g_k) N/T + (1 − 4u + 3u²) s_k + (3u² − 2u) s_{k+1}, sampled like the
    # pre-flight (GOAL_SPEED_SAMPLES_PER_KNOT per interval).
    slope = sym.goal_slope
    tridiagonal = cyclic_shift(slope, -1) + 4 * slope + cyclic_shift(slope, 1)
    spline = tridiagonal - 3 * (cyclic_shift(goal, 1) - cyclic_shift(goal, -1)) * inv_h
    chord = (cyclic_shift(goal, 1) - goal) * inv_h
    samples = []
    # with `compact_rows` "goal slope" the sample at u = 0 (the slope s_k itself) is a bound of
    # s_k instead (`planner.nlp.variables.variable_bounds`)
    first = 1 if "goal slope" in options.compact_rows else 0
    for u in np.arange(first, GOAL_SPEED_SAMPLES_PER_KNOT) / GOAL_SPEED_SAMPLES_PER_KNOT:
        d = 6 * (u - u * u) * chord + (1 - 4 * u + 3 * u * u) * slope
        samples.append(d + (3 * u * u - 2 * u) * cyclic_shift(slope, 1))
    # rows ordered (sample, knot, joint); labels in group_labels follow the same order
    rate = ca.vertcat(*[ca.vec(d / ca.repmat(omega0, 1, n)) for d in samples])
    rows = nj * n * len(samples)
    return [
        *lifted,
        Group("servo goal limits", ca.vec(goal), np.tile(lo + margin, n), np.tile(hi - margin, n)),
        Group(
            "servo goal spline",
            ca.vec(spline / ca.repmat(omega0, 1, n)),
            np.zeros(nj * n),
            np.zeros(nj * n),
        ),
        Group(
            "servo goal speed",
            ca.vec(rate),
            np.full(rows, -GOAL_SPEED_INSIDE * options.speed_margin),
            np.full(rows, GOAL_SPEED_INSIDE * options.speed_margin),
        ),
    ]


def fill_servo_goals(layout: Layout, model: RobotModel, options: PlannerOptions,
                     x: np.ndarray) -> np.ndarray:
    """`x` (physical units) with its servo-goal block (`Layout.lifted_goals`) set to
    q + τ/k_p + (d/k_p)·q̇ of its own q, τ and lifted q̇: a start on the "servo goal" rows
    (unchanged without the block)."""
    if not layout.lifted_goals:
        return x
    from planner.nlp.servo_loop import loop_arrays, servo_loops

    kp, damping = loop_arrays(servo_loops(model.robot, options.servo_settings))
    out = np.array(x, dtype=float).ravel()
    qd = layout.view(out, "vel")[:, 6:]
    layout.view(out, "goal")[:] = (layout.view(out, "q") + layout.view(out, "tau") / kp
                                   + qd * (damping / kp))
    return out


def group_labels(
    model: RobotModel, n_knots: int, compact_rows: tuple[str, ...] = ()
) -> dict[str, list[str]]:
    """Human-readable row labels for the groups that need them in reports; `compact_rows`:
    `PlannerOptions.compact_rows` (the envelopes' ranged rows: two per joint and knot). Rows
    given as bounds keep their labels (`planner.nlp.diagnostics.BoundRows` reports them)."""
    faces = 2 if "torque envelope" in compact_rows else 4
    joints = model.robot.joint_names
    feet = model.robot.foot_names
    per_joint = [f"{j}@knot {k}" for k in range(n_knots) for j in joints]
    per_foot = [f"foot {f}@knot {k}" for k in range(n_knots) for f in feet]
    dofs = ["x", "y", "z", "roll", "pitch", "yaw", *joints]
    return {
        "finite differences": [
            f"{d}@knot {k}" for _ in range(2) for k in range(n_knots) for d in dofs
        ],
        "velocity differences": [f"{d}@knot {k}" for k in range(n_knots) for d in dofs],
        "base xy differences": [
            f"{d}@knot {k}" for d2 in ("d/dt", "d2/dt2") for k in range(n_knots)
            for d in (f"{d2} x", f"{d2} y")
        ],
        "dynamics": [
            f"{a}@knot {k}" for k in range(n_knots) for a in ("fx", "fy", "fz", "mx", "my", "mz")
        ],
        "inverse dynamics": per_joint,
        "stance height": per_foot,
        "stance no-slip": per_foot * 2,
        "swing clearance": per_foot,
        "swing force": per_foot,
        "friction": per_foot * 4,
        "joint speed": per_joint,
        "servo goal": per_joint,
        "servo goal limits": per_joint,
        "servo goal spline": per_joint,
        "servo goal speed": [
            f"{j}@knot {k + i / GOAL_SPEED_SAMPLES_PER_KNOT:g}"
            for i in range(GOAL_SPEED_SAMPLES_PER_KNOT)
            for k in range(n_knots)
            for j in joints
        ],
        "torque envelope": per_joint * faces,
        "rotor reserve": per_joint * faces,
        "line capture": line_capture_labels(feet, n_knots),
        "body clearance": [
            f"body {b}@knot {k}" for k in range(n_knots) for b in range(model.n_bodies)
        ],
        "static margin": _static_margin_labels(model, n_knots),
        "mean footprint": [f"foot {f} mean {a}" for a in "xy" for f in feet],
        "half-cycle mirror": mirror_labels(model.robot, n_knots),
        **flat_foot_labels(model, n_knots),
        "foot separation": foot_separation_labels(model, n_knots),
        "normal force rate": force_rate_labels(feet, n_knots),
    }


def _static_margin_labels(model: RobotModel, n_knots: int) -> list[str]:
    from planner.search.support import polygon_edges
    from planner.templates import stance_foot_positions_m

    feet = model.robot.foot_names
    edges = polygon_edges(stance_foot_positions_m(model.robot)[:, :2])
    return [f"edge {feet[e.i]}-{feet[e.j]}@knot {k}" for e in edges for k in range(n_knots)]

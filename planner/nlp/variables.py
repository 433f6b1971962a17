"""Decision variables and parameters of the spacetime NLP (TOWR-style "variables" module).

Per knot k = 0…N−1 (phase k/N of one period, treadmill frame):

- base pose ``b_k = (x, y, z, roll, pitch, yaw)`` [m, rad] — x with the forward progress v·t
  removed, so every variable is N-periodic;
- joint angles ``q_k`` [rad] in `Robot.joints` order;
- contact forces ``f_k`` (3 per foot, world frame) in units of body weight m·g (W&P §3.2 mass
  normalisation — keeps the NLP well scaled for any robot mass);
- lifted rates ``v_k = (ḃ_k, q̇_k)`` and ``a_k = (b̈_k, q̈_k)``, tied to the poses by the cyclic
  finite-difference equalities (a linear constraint group). Lifting makes every nonlinear term
  depend on one knot only, so the Hessian of the Lagrangian is block-diagonal: cheaper to
  evaluate and to factorise than the banded Hessian of the direct substitution;
- lifted joint torques ``τ_k`` [N·m], tied to the inverse dynamics by an equality group, so the
  servo-envelope rows are linear (2 non-zeros each instead of a dense RNEA row);
- lifted servo-goal spline slopes ``s_k`` [rad/s]: the knot slopes of the periodic cubic spline
  the player streams through the servo goals (`planner.nlp.servo_loop`), tied to the goals by the
  spline's cyclic tridiagonal equations; its speed anywhere in an interval is then a sparse row
  (two goals, two slopes) instead of a dense one. Fixed at 0 when `servo_goals` is off.

Parameters (change between solves without rebuilding): contact activity C (F×N, 0/1), swing
minimum foot height H (F×N) [m], speed v [m/s], period T [s], then the rest of the velocity
command (lateral speed vy, yaw rate W and the planar motion over one knot interval,
`planner.nlp.command.motion_parameters`). Poses are relative to the command frame
(`planner.nlp.command`), the treadmill frame when vy = W = 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.command import (
    N_MOTION_PARAMETERS,
    MotionSymbols,
    VelocityCommand,
    motion_parameters,
)
from planner.nlp.config import PlannerOptions
from planner.nlp.model import RobotModel
from robots import ContactSchedule


def cyclic_shift(m: Any, k: int) -> Any:
    """Cyclic column shift of a knot-major matrix (one column per knot): column i of the result
    is column (i + k) mod N of m (k = 1: each knot's next neighbour, k = −1: its previous)."""
    n = m.shape[1]
    k %= n
    return m if k == 0 else ca.horzcat(m[:, k:], m[:, :k])

#: The decision vector's blocks in packing order (`Layout`); the names are `Symbols`' fields.
BLOCKS = ("base", "q", "forces", "vel", "acc", "tau", "goal_slope", "moments", "goal")
_POSE_DOFS = ("x", "y", "z", "roll", "pitch", "yaw")


@dataclass(frozen=True)
class Layout:
    """Sizes and packing order of the decision vector: the one place that knows its offsets.

    Order: `BLOCKS` = [vec(B), vec(Q), vec(F), vec(V), vec(A), vec(τ), vec(S), vec(M)], each
    knot-major (knot k's entries together, `width` of them per knot): base pose (6), joint
    angles (J), contact forces (3 per foot), pose rates and accelerations (6 + J each), joint
    torques (J), servo-goal slopes (J), and M the flat feet's contact moments (3 per flat foot,
    units of m·g·L; `planner.nlp.flat_foot`), absent without flat feet, and G the servo goals
    [rad] (one per joint, `PlannerOptions.servo_goal_form` "lifted"), absent otherwise: last,
    so every other block sits where it does without them. `block`, `indices` and `view`
    locate a block; every module reads and writes x through them.
    """

    n_knots: int
    n_joints: int
    n_feet: int
    n_flat_feet: int = 0
    lifted_goals: bool = False

    @classmethod
    def of(cls, model: RobotModel, n_knots: int, lifted_goals: bool = False) -> Layout:
        """The layout of `model`'s NLP at `n_knots` knots (its joints, feet and flat feet);
        `lifted_goals`: with the servo goals' block (`PlannerOptions.lifted_goals`)."""
        return cls(n_knots, model.n_joints, model.n_feet, len(model.flat_feet), lifted_goals)

    def width(self, name: str) -> int:
        """Entries per knot of block `name` (one of `BLOCKS`)."""
        nj = self.n_joints
        widths = {"base": 6, "q": nj, "forces": 3 * self.n_feet, "vel": 6 + nj, "acc": 6 + nj,
                  "tau": nj, "goal_slope": nj, "moments": 3 * self.n_flat_feet,
                  "goal": nj if self.lifted_goals else 0}
        if name not in widths:
            raise PlannerConfigError(
                f"decision vector block {name!r}: use one of {', '.join(BLOCKS)}")
        return widths[name]

    def block(self, name: str) -> slice:
        """Where block `name` sits in the flat vector."""
        width = self.width(name)  # refuses an unknown name
        start = sum(self.width(b) for b in BLOCKS[: BLOCKS.index(name)]) * self.n_knots
        return slice(start, start + width * self.n_knots)

    def indices(self, name: str) -> np.ndarray:
        """N × width indices of block `name` in the flat vector (row k: knot k's entries)."""
        sl = self.block(name)
        return np.arange(sl.start, sl.stop).reshape(self.n_knots, self.width(name))

    def view(self, x: np.ndarray, name: str) -> np.ndarray:
        """Block `name` of the flat vector `x` as N × width: a view, so writing it writes x."""
        return x[self.block(name)].reshape(self.n_knots, self.width(name))

    @property
    def n_m(self) -> int:
        return self.width("moments") * self.n_knots

    @property
    def n_base(self) -> int:
        return self.width("base") * self.n_knots

    @property
    def n_q(self) -> int:
        return self.width("q") * self.n_knots

    @property
    def n_f(self) -> int:
        return self.width("forces") * self.n_knots

    @property
    def n_rates(self) -> int:
        return self.width("vel") * self.n_knots

    @property
    def size(self) -> int:
        return self.block(BLOCKS[-1]).stop

    def unpack_moments(self, x: np.ndarray) -> np.ndarray:
        """N × F_flat × 3 flat-foot moments (units of m·g·L) from the flat vector."""
        x = np.asarray(x, dtype=float).ravel()
        return self.view(x, "moments").reshape(self.n_knots, self.n_flat_feet, 3)

    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(base N×6, joints N×J, forces N×F×3 in units of m·g) from the flat vector."""
        x = np.asarray(x, dtype=float).ravel()
        f = self.view(x, "forces").reshape(self.n_knots, self.n_feet, 3)
        return self.view(x, "base"), self.view(x, "q"), f

    def labels(self, joints: tuple[str, ...], flat_feet: tuple[int, ...] | None = None
               ) -> list[str]:
        """A name for every entry of the decision vector (for reports); `flat_feet`: the flat
        feet's foot indices (`RobotModel.flat_feet`; 0, 1, … if not given)."""
        dofs = [*_POSE_DOFS, *joints]
        feet = range(self.n_feet)
        flat = range(self.n_flat_feet) if flat_feet is None else flat_feet
        per_knot = {
            "base": [f"base {d}" for d in _POSE_DOFS],
            "q": list(joints),
            "forces": [f"foot {f} f{a}" for f in feet for a in "xyz"],
            "vel": [f"d/dt {d}" for d in dofs],
            "acc": [f"d2/dt2 {d}" for d in dofs],
            "tau": [f"torque {j}" for j in joints],
            "goal_slope": [f"goal slope {j}" for j in joints],
            "moments": [f"foot {f} m{a}" for f in flat for a in "xyz"],
            "goal": [f"servo goal {j}" for j in joints] if self.lifted_goals else [],
        }
        out = []
        for name in BLOCKS:
            if len(per_knot[name]) != self.width(name):
                raise PlannerConfigError(
                    f"labels: {len(per_knot[name])} names for block {name!r} of width "
                    f"{self.width(name)} (joints or flat feet do not match the layout)")
            out += [f"{e}@knot {k}" for k in range(self.n_knots) for e in per_knot[name]]
        return out

    def pack(
        self,
        base: np.ndarray,
        q: np.ndarray,
        forces: np.ndarray,
        *,
        vel: np.ndarray | None = None,
        acc: np.ndarray | None = None,
        tau: np.ndarray | None = None,
        goal_slope: np.ndarray | None = None,
        moments: np.ndarray | None = None,
        goal: np.ndarray | None = None,
    ) -> np.ndarray:
        """Flat vector from its blocks (each N × width, or anything of that size, knot-major);
        a block not given is zeros (the lifted ones: consistent with a constant pose at rest;
        not the servo goals, which `GaitPlanner.solve` sets from q, τ, q̇ before a solve)."""
        x = np.zeros(self.size)
        given = {"base": base, "q": q, "forces": forces, "vel": vel, "acc": acc, "tau": tau,
                 "goal_slope": goal_slope, "moments": moments, "goal": goal}
        for name, value in given.items():
            if value is None:
                continue
            value = np.asarray(value, dtype=float)
            expected = self.n_knots * self.width(name)
            if value.size != expected:
                raise PlannerConfigError(
                    f"Layout.pack: block {name!r} has {value.size} entries, expected {expected} "
                    f"({self.n_knots} knots × {self.width(name)})")
            self.view(x, name)[...] = value.reshape(self.n_knots, self.width(name))
        return x


@dataclass(frozen=True)
class Symbols:
    """The CasADi symbols: matrices with one column per knot."""

    x: Any  # flat decision vector of the solver (scaled by `variable_scale` if given)
    base: Any  # 6 × N
    q: Any  # J × N
    forces: Any  # 3F × N (units of m·g)
    vel: Any  # (6+J) × N: base pose rates then joint speeds
    acc: Any  # (6+J) × N
    tau: Any  # J × N joint torques [N·m]
    goal_slope: Any  # J × N servo-goal spline slopes at the knots [rad/s]
    p: Any  # flat parameter vector
    contact: Any  # F × N
    min_height_m: Any  # F × N
    speed_m_s: Any
    period_s: Any
    moments: Any = None  # 3·F_flat × N flat-foot moments (units of m·g·L), None without
    motion: MotionSymbols | None = None  # the velocity command's block (`planner.nlp.command`)
    goal: Any = None  # J × N servo goals [rad] (`Layout.lifted_goals`), None without


def time_unit_s(leg_length_m: float, gravity_m_s2: float = 9.81) -> float:
    """√(L/g): the pendulum time of the leg, the time unit of dynamic similarity."""
    return float(np.sqrt(leg_length_m / gravity_m_s2))


def variable_scale(layout: Layout, model: RobotModel) -> np.ndarray:
    """Typical magnitude of every decision variable, in the units of `Layout`.

    The solver works on x̃ = x / scale (W&P §3.2 normalise forces by body weight; we also
    normalise the rest): lengths by the leg length L, times by √(L/g), torques by m·g·L, angles
    and forces (already in m·g) by 1. Used with `PlannerOptions.nondimensional` (see there for
    the iteration counts measured with and without it).
    """
    length = model.robot.leg_length_m
    t0 = time_unit_s(length, float(np.linalg.norm(model.gravity_m_s2)) or 9.81)
    torque = model.total_mass_kg * float(np.linalg.norm(model.gravity_m_s2)) * length
    rate = np.r_[[length / t0] * 3, [1.0 / t0] * 3, [1.0 / t0] * layout.n_joints]
    # angles, forces (already in m·g) and the flat feet's moments (in m·g·L) keep scale 1
    scale = np.ones(layout.size)
    layout.view(scale, "base")[:] = np.r_[[length] * 3, [1.0] * 3]
    layout.view(scale, "vel")[:] = rate
    layout.view(scale, "acc")[:] = rate / t0
    layout.view(scale, "tau")[:] = torque
    layout.view(scale, "goal_slope")[:] = 1.0 / t0
    return scale


def make_symbols(layout: Layout, scale: np.ndarray | None = None) -> Symbols:
    """Symbols of the NLP. With `scale`, `Symbols.x` is the solver's scaled vector x̃ and every
    other symbol is the physical quantity x = scale·x̃."""
    n, nf = layout.n_knots, layout.n_feet
    xs = ca.MX.sym("x", layout.size)
    x = xs if scale is None else xs * ca.DM(np.asarray(scale, dtype=float))

    def block(name: str) -> Any:  # knot-major packing: column k holds knot k (column-major)
        return ca.reshape(x[layout.block(name)], layout.width(name), n)

    base, q, forces, vel, acc, tau, goal_slope = (
        block(name) for name in ("base", "q", "forces", "vel", "acc", "tau", "goal_slope"))
    moments = block("moments") if layout.n_flat_feet else None
    p = ca.MX.sym("p", 2 * nf * n + 2 + N_MOTION_PARAMETERS)
    contact = ca.reshape(p[: nf * n], nf, n)
    min_height = ca.reshape(p[nf * n : 2 * nf * n], nf, n)
    return Symbols(
        xs,
        base,
        q,
        forces,
        vel,
        acc,
        tau,
        goal_slope,
        p,
        contact,
        min_height,
        p[2 * nf * n],
        p[2 * nf * n + 1],
        moments,
        MotionSymbols.from_parameters(p[2 * nf * n], p[2 * nf * n + 2 :]),
        block("goal") if layout.lifted_goals else None,
    )


def parameter_vector(
    schedule: ContactSchedule,
    n_knots: int,
    speed_m_s: float,
    swing_clearance_m: float,
    vy_m_s: float = 0.0,
    yaw_rate_rad_s: float = 0.0,
) -> np.ndarray:
    """Numeric p for a schedule: C (F×N), H (F×N) column-major, then v (= vx) and T, then the
    command block (`planner.nlp.command.motion_parameters`)."""
    command = VelocityCommand(speed_m_s, vy_m_s, yaw_rate_rad_s)
    contact = schedule.contact_matrix(n_knots).astype(float)  # N × F
    return np.concatenate(
        [
            contact.ravel(),
            swing_height_profile(schedule, n_knots, swing_clearance_m).ravel(),
            [speed_m_s, schedule.period_s],
            motion_parameters(command, schedule.period_s, n_knots),
        ]
    )


def swing_height_profile(schedule: ContactSchedule, n_knots: int, clearance_m: float) -> np.ndarray:
    """N × F minimum foot height above touching [m]: h·sin(π·swing progress), 0 in stance."""
    phase = np.arange(n_knots)[:, None] / n_knots
    td = np.asarray(schedule.touchdown_phase)[None, :]
    duty = np.asarray(schedule.duty_factor)[None, :]
    since_td = (phase - td) % 1.0
    stance = schedule.contact_matrix(n_knots)
    swing_len = np.maximum(1.0 - duty, 1e-9)
    progress = np.clip((since_td - duty) / swing_len, 0.0, 1.0)
    return np.where(stance, 0.0, clearance_m * np.sin(np.pi * progress))


def variable_bounds(
    layout: Layout, model: RobotModel, options: PlannerOptions
) -> tuple[np.ndarray, np.ndarray]:
    """Box bounds: joint limits (minus a margin), held joints fixed at stance, tilt, unilateral
    normal force f_z ≥ 0."""
    tilt, inf = options.max_tilt_rad, np.inf
    lo, hi = np.full(layout.size, -inf), np.full(layout.size, inf)
    base_lo, base_hi = layout.view(lo, "base"), layout.view(hi, "base")
    base_lo[:, 2] = options.min_base_height_fraction * model.robot.stance_base_height_m
    base_hi[:, 2] = 2.0 * model.robot.leg_length_m + 0.5
    base_lo[:, 3:], base_hi[:, 3:] = -tilt, tilt
    q_lo, q_hi = model.joint_limits_rad()
    margin = options.joint_limit_margins_rad(q_lo, q_hi)
    layout.view(lo, "q")[:], layout.view(hi, "q")[:] = q_lo + margin, q_hi - margin
    # held joints (role = "hold": a head, arm, tail …) stay at their stance angle at every knot;
    # their torque is still the inverse dynamics' and still bounded by their servo's envelope
    held = np.array([j.held for j in model.robot.joints], dtype=bool)
    stance = np.asarray(model.robot.nominal_stance_rad, dtype=float)
    layout.view(lo, "q")[:, held] = layout.view(hi, "q")[:, held] = stance[held]
    layout.view(lo, "forces").reshape(layout.n_knots, layout.n_feet, 3)[:, :, 2] = 0.0
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in model.robot.joints], dtype=float)
    if "joint speed" in options.compact_rows:
        # |q̇| ≤ margin·ω₀ on the lifted joint rates (the "joint speed" rows as bounds)
        layout.view(hi, "vel")[:, 6:] = options.speed_margin * omega0
        layout.view(lo, "vel")[:, 6:] = -layout.view(hi, "vel")[:, 6:]
    if not options.servo_goals:
        layout.view(hi, "goal_slope")[:] = 0.0  # no goals: slopes fixed (IPOPT drops them)
        layout.view(lo, "goal_slope")[:] = -layout.view(hi, "goal_slope")
    elif "goal slope" in options.compact_rows:
        # the servo-goal speed at u = 0 of interval k is the knot slope s_k itself
        # (`planner.nlp.constraints._servo_goal_groups`): that sample's rows as bounds
        layout.view(hi, "goal_slope")[:] = goal_slope_bound_rad_s(omega0, options)
        layout.view(lo, "goal_slope")[:] = -layout.view(hi, "goal_slope")
    # the moments stay free: the contact wrench cone bounds them (planner.nlp.flat_foot)
    return lo, hi


def goal_slope_bound_rad_s(omega0_rad_s: np.ndarray, options: PlannerOptions) -> np.ndarray:
    """Per joint: the servo-goal spline's speed limit GOAL_SPEED_INSIDE·margin·ω₀ [rad/s]."""
    from planner.nlp.constraints import GOAL_SPEED_INSIDE

    return GOAL_SPEED_INSIDE * options.speed_margin * np.asarray(omega0_rad_s, dtype=float)


def force_indices(layout: Layout, axis: int) -> np.ndarray:
    """Indices in the decision vector of every foot's force component `axis` (0 x, 1 y, 2 z),
    knot-major (knot k's feet in order), i.e. N × F in C order."""
    return layout.indices("forces")[:, axis::3].ravel()


def swing_force_upper_bounds(
    layout: Layout, ubx: np.ndarray, contact: np.ndarray, max_force_body_weights: float
) -> np.ndarray:
    """`ubx` with every normal force bounded by C·f_max for the contact matrix `contact`
    (N × F, 0/1): the "swing force" rows 0 ≤ C·f_max − f_z as bounds of one solve. In swing the
    bound is 0 = the lower bound, so IPOPT removes the variable."""
    contact = np.asarray(contact, dtype=float)
    if contact.shape != (layout.n_knots, layout.n_feet):
        raise PlannerConfigError(f"swing force bounds: contact matrix {contact.shape}, expected "
                                 f"{(layout.n_knots, layout.n_feet)}")
    out = np.array(ubx, dtype=float, copy=True)
    out[force_indices(layout, 2)] = contact.ravel() * max_force_body_weights
    return out


def initial_guess(layout: Layout, model: RobotModel, schedule: ContactSchedule) -> np.ndarray:
    """Cold start: nominal stance at the nominal height, weight shared by the stance feet."""
    n = layout.n_knots
    base = np.zeros((n, 6))
    base[:, 2] = model.robot.stance_base_height_m
    q = np.tile(np.asarray(model.robot.nominal_stance_rad), (n, 1))
    lo, hi = model.joint_limits_rad()
    held = np.array([j.held for j in model.robot.joints], dtype=bool)
    q = np.where(held, q, np.clip(q, lo + 0.05, hi - 0.05))
    contact = schedule.contact_matrix(n).astype(float)
    f = np.zeros((n, layout.n_feet, 3))
    f[:, :, 2] = contact / np.maximum(contact.sum(axis=1, keepdims=True), 1.0)
    return layout.pack(base, q, f)


def retimed_start(
    layout: Layout,
    x: np.ndarray,
    period_from_s: float,
    period_to_s: float,
    contact_from: np.ndarray,
    contact_to: np.ndarray,
) -> np.ndarray:
    """A solved primal point `x` (physical units, period `period_from_s`) mapped onto another
    schedule at the same knots, to warm-start that schedule's solve (the search's coarse samples,
    `planner.search.gait_search.SEARCH_WARM_STARTS`).

    Knot k stays at phase k/N of the cycle, so poses, joint angles and torques are kept; the
    time derivatives follow d/dt = (1/T)·d/dφ: velocities and servo-goal slopes scale by
    T_from/T_to, accelerations by its square. Forces follow the contact matrices (N × F, of the
    solved schedule and of the new one): kept where the foot stays in contact, zero where it
    swings, and where it newly stands the cold start's share of the weight (`initial_guess`)."""
    x = np.asarray(x, dtype=float).ravel()
    if x.shape != (layout.size,):
        raise PlannerConfigError(
            f"retimed_start: {x.size} variables for a layout of {layout.size}")
    if not (period_from_s > 0 and period_to_s > 0):
        raise PlannerConfigError(
            f"retimed_start: periods must be > 0, got {period_from_s}, {period_to_s}")
    was, contact = np.asarray(contact_from, dtype=bool), np.asarray(contact_to, dtype=bool)
    for m in (was, contact):
        if m.shape != (layout.n_knots, layout.n_feet):
            raise PlannerConfigError(f"retimed_start: contact matrix {m.shape}, expected "
                             f"{(layout.n_knots, layout.n_feet)}")
    out = x.copy()
    rate = period_from_s / period_to_s
    f = layout.view(out, "forces").reshape(layout.n_knots, layout.n_feet, 3)
    share = 1.0 / np.maximum(contact.sum(axis=1, keepdims=True), 1)
    f[:, :, 2] = np.where(contact & ~was, np.broadcast_to(share, contact.shape), f[:, :, 2])
    f[~contact] = 0.0
    layout.view(out, "vel")[:] *= rate
    layout.view(out, "acc")[:] *= rate**2
    layout.view(out, "goal_slope")[:] *= rate  # [rad/s]; poses, torques and moments unchanged
    return out

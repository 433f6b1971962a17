"""Cold starts of the spacetime NLP that satisfy its equality rows where they cheaply can.

`planner.nlp.variables.initial_guess` ("stance", `PlannerOptions.cold_start`) stands the robot
still in its nominal stance at every knot with the weight shared evenly by the stance feet and
every lifted variable zero: the lifted torques then violate the inverse-dynamics rows by the
gravity torques (quad12 trot: 0.36 of stall), the stance feet stand still in the treadmill frame
instead of moving with it (no-slip rows, v·T/N) and the swing feet do not lift (swing clearance).
IPOPT's first iterations on that start take steps of α ≈ 1e-4 (issue #16).

The other starts, computed in numpy from the NLP's own functions (no solve):

- "balanced": the same poses; at every knot the stance feet's forces (and flat feet's moments)
  are the least change from the even share that zeroes the whole-body Newton–Euler rows (W&P
  eqs 7-8; linear in the wrench), clipped to f_z ≥ 0 and the friction pyramid; the torques are
  the inverse dynamics at that point (the knot function's "tau"), so the inverse-dynamics rows
  hold; the servo-goal slopes solve the goal spline's cyclic tridiagonal equations
  (`planner.nlp.servo_loop`).
- "stride": as "balanced", on poses that walk: the base stays at its nominal height and level,
  every foot follows the treadmill (−(vx, vy)·T/N per knot interval on which the NLP holds it
  still, "stance no-slip" with `vertical_contact_transitions`), comes forward over its swing
  knots on a half-sine speed profile and lifts 1.25× the swing profile H
  (`planner.nlp.variables.swing_height_profile`); the joints follow by damped least-squares IK
  on the feet (and, for flat feet, the sole normal kept vertical), base fixed, held joints
  fixed; the lifted rates are the cyclic finite differences of those poses (the NLP's own rows)
  and the wrench and torques are solved with the resulting accelerations.
  The command's yaw rate is not followed by the feet (the rates are still the NLP's own).

Measured (docs/results/planner_speed_init.md, session 31): neither saves iterations — quad12's
templates cold at N = 30 took 333 ("stance"), 346 ("balanced") and 475 ("stride") — so "stance"
stays the default. The small first steps come from the swing feet's zero-width force box
(`planner.nlp.swing_wrench`), not from the rows these starts satisfy.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca
import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.command import VelocityCommand
from planner.nlp.config import COLD_STARTS, PlannerOptions
from planner.nlp.constraints import fill_servo_goals
from planner.nlp.model import RobotModel
from planner.nlp.variables import Layout, initial_guess, swing_height_profile
from robots import ContactSchedule

#: damped least squares: iterations per knot and damping λ in leg lengths (ΔQ = Jᵀ(JJᵀ+λ²I)⁻¹e)
IK_ITERATIONS = 12
IK_DAMPING_LEG_LENGTHS = 0.05
#: the swing foot's target height over the swing profile H (the rows ask for ≥ H)
SWING_LIFT_FACTOR = 1.25
#: regularisation of the wrench balance: weight of the change from the even share against the
#: Newton–Euler residual (in body weights; small, so the rows hold wherever they can)
BALANCE_REGULARISATION = 1e-6
#: joints stay this far [rad] inside their planned range (limits minus the option's margin)
JOINT_INSIDE_RAD = 0.01


@dataclass(frozen=True)
class StartCommand:
    """What a cold start depends on besides the schedule: the velocity command and the swing
    clearance [m]."""

    velocity: VelocityCommand
    swing_clearance_m: float


class ColdStarter:
    """Cold starts for one planner (`PlannerOptions.cold_start`); functions built once.

    `knot`: the NLP's `planner.nlp.constraints.knot_function` (dense inputs b, q, bd, qd, bdd,
    qdd, f, v, vy, yaw_rate[, m]); `fd_residual(x, p)`: the "finite differences" rows of the
    NLP at x (physical units), vel − FD(poses) stacked over acc − FD²(poses)."""

    def __init__(
        self,
        layout: Layout,
        model: RobotModel,
        options: PlannerOptions,
        knot: ca.Function,
        fd_residual: Callable[[np.ndarray, np.ndarray], np.ndarray],
    ) -> None:
        self.layout, self.model, self.options = layout, model, options
        self._fd_residual = fd_residual
        n = layout.n_knots
        nj, nf, nflat = model.n_joints, model.n_feet, len(model.flat_feet)
        self._weight_n = model.total_mass_kg * float(np.linalg.norm(model.gravity_m_s2))
        # the knot's base rows and torques, and their (constant) derivative in the wrench
        sx = knot.sx_in()
        wrench = ca.vertcat(sx[6], sx[10]) if nflat else sx[6]
        base_rows, tau = knot.call(sx)[:2]
        self._knot = ca.Function(
            "cold_knot", sx, [base_rows, tau, ca.jacobian(base_rows, wrench)]
        ).map(n)
        # IK task: foot positions (3F) and, for flat feet, the sole normal's x and y (2 each)
        q = ca.SX.sym("q", nj)
        pos = ca.DM([0.0, 0.0, model.robot.stance_base_height_m])
        feet = model.fk(pos, ca.DM.zeros(3), q)[0]
        task = [ca.vec(feet)]
        if nflat:
            rot = model.soles(pos, ca.DM.zeros(3), q)
            task += [rot[0:2, 3 * k + 2] for k in range(nflat)]
        t = ca.vertcat(*task)
        self._task = ca.Function("cold_ik", [q], [t, ca.jacobian(t, q)]).map(n)
        self._n_task = int(t.shape[0])
        lo, hi = model.joint_limits_rad()
        margin = options.joint_limit_margins_rad(lo, hi)
        inside = np.minimum(JOINT_INSIDE_RAD, 0.25 * (hi - lo - 2 * margin))
        self._q_lo, self._q_hi = lo + margin + inside, hi - margin - inside
        self._held = np.array([j.held for j in model.robot.joints], dtype=bool)
        from planner.nlp.servo_loop import loop_arrays, servo_loops

        self._kp, self._damping = loop_arrays(servo_loops(model.robot, options.servo_settings))
        self._nf, self._nflat = nf, nflat

    def start(
        self, kind: str, schedule: ContactSchedule, command: StartCommand, p: np.ndarray
    ) -> np.ndarray:
        """The cold start `kind` (`COLD_STARTS`) for `schedule` and `command`; `p`: the NLP's
        parameter vector for them (`planner.nlp.variables.parameter_vector`)."""
        if kind not in COLD_STARTS:
            raise PlannerConfigError(
                f"cold start {kind!r} is not one of {', '.join(COLD_STARTS)}")
        layout = self.layout
        x = initial_guess(layout, self.model, schedule)
        if kind == "stance":
            return fill_servo_goals(layout, self.model, self.options, x)
        base, q, f = layout.unpack(x)
        if kind == "stride":
            q = self._stride_joints(schedule, command, q)
        return self.consistent(layout.pack(base, q, f), schedule, command, p)

    def consistent(self, x: np.ndarray, schedule: ContactSchedule, command: StartCommand,
                   p: np.ndarray) -> np.ndarray:
        """`x`'s poses with the rest made to meet the equality rows as "balanced" does (module
        docstring): the rates the cyclic differences of the poses, the stance feet's wrench the
        least change from `x`'s forces (zero moments) that zeroes the Newton–Euler rows, the
        torques the inverse dynamics, the goal slopes the spline's. The "balanced" and
        "stride" cold starts end here; benchmarks/warm_start_screen.py's ``fix`` variant applied
        it to re-timed warm starts (it lost; `planner.nlp.warm_start` does not call it)."""
        layout = self.layout
        n = layout.n_knots
        base, q, f = (np.array(v) for v in layout.unpack(x))
        x = layout.pack(base, q, f)
        # rates: the NLP's own cyclic differences of these poses, the "finite differences" rows
        # (vel − D₁·pose, then acc − D₂·pose, knot-major as the blocks) at zero rates negated
        rates = -np.asarray(self._fd_residual(x, p)).ravel()
        vel, acc = (r.reshape(n, layout.width("vel")).T for r in np.split(rates, 2))
        contact = schedule.contact_matrix(n).astype(bool)  # N × F
        wrench, tau = self._balanced_wrench(base, q, f, vel, acc, contact, command)
        f = wrench[:, : 3 * self._nf].reshape(n, self._nf, 3)
        moments = wrench[:, 3 * self._nf :] if self._nflat else None
        slopes = self._goal_slopes(q, vel[6:, :].T, tau, schedule)
        if not self.options.servo_goals:
            slopes = np.zeros_like(slopes)  # fixed at 0 by their bounds
        # the lifted servo goals (`PlannerOptions.servo_goal_form`) from these q, τ and q̇
        return fill_servo_goals(layout, self.model, self.options, layout.pack(
            base, q, f, vel=vel.T, acc=acc.T, tau=tau, goal_slope=slopes, moments=moments))

    # -- pieces ------------------------------------------------------------------------------

    def _stride_joints(
        self, schedule: ContactSchedule, command: StartCommand, q0: np.ndarray
    ) -> np.ndarray:
        """N × J joint angles whose feet walk the treadmill (module docstring), by damped
        least squares from the stance angles `q0`, base fixed."""
        n = self.layout.n_knots
        task0 = np.asarray(self._task(q0.T)[0])[:, 0]  # the stance task (every knot alike)
        feet0 = task0[: 3 * self._nf].reshape(self._nf, 3)
        contact = schedule.contact_matrix(n).astype(bool)  # N × F
        height = swing_height_profile(schedule, n, command.swing_clearance_m)  # N × F
        h = schedule.period_s / n
        target = np.tile(task0, (n, 1))  # N × task
        for foot in range(self._nf):
            c = contact[:, foot]
            stuck = c | np.roll(c, -1) if self.options.vertical_contact_transitions else (
                c & np.roll(c, -1))  # interval k → k+1 held still in the world
            for axis, v in ((0, command.velocity.vx_m_s), (1, command.velocity.vy_m_s)):
                track = _cyclic_track(stuck, -v * h)
                target[:, 3 * foot + axis] = feet0[foot, axis] + track
            target[:, 3 * foot + 2] = feet0[foot, 2] + SWING_LIFT_FACTOR * height[:, foot]
        q = q0.T.copy()  # J × N
        free = ~self._held
        lam2 = (IK_DAMPING_LEG_LENGTHS * self.model.robot.leg_length_m) ** 2
        for _ in range(IK_ITERATIONS):
            t, jac = (np.asarray(v) for v in self._task(q))
            err = target.T - t  # task × N
            for k in range(n):
                j = jac[:, k * q.shape[0] : (k + 1) * q.shape[0]][:, free]
                step = j.T @ np.linalg.solve(j @ j.T + lam2 * np.eye(j.shape[0]), err[:, k])
                q[free, k] += step
            q = np.where(free[:, None], np.clip(q, self._q_lo[:, None], self._q_hi[:, None]), q)
        return q.T

    def _balanced_wrench(
        self,
        base: np.ndarray,
        q: np.ndarray,
        f: np.ndarray,
        vel: np.ndarray,
        acc: np.ndarray,
        contact: np.ndarray,
        command: StartCommand,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(N × (3F + 3F_flat) wrench in the NLP's units, N × J torques [N·m]): per knot the
        least change from the even share `f` (zero moments) that zeroes the base rows."""
        n, nf, nflat = self.layout.n_knots, self._nf, self._nflat
        b = base.T.copy()
        b[0:2, :] = 0.0  # the knot is evaluated at x = y = 0 (translation invariance)
        w0 = np.concatenate([f.reshape(n, 3 * nf), np.zeros((n, 3 * nflat))], axis=1)
        args = [b, q.T, vel[:6], vel[6:], acc[:6], acc[6:], w0[:, : 3 * nf].T,
                command.velocity.vx_m_s, command.velocity.vy_m_s, command.velocity.yaw_rate_rad_s]
        if nflat:
            args.append(w0[:, 3 * nf :].T)
        rows, _, jac = (np.asarray(v) for v in self._knot(*args))
        width = 3 * nf + 3 * nflat
        flat_of = {foot: k for k, foot in enumerate(self.model.flat_feet)}
        mu = self.options.mu / np.sqrt(2.0)
        w = w0.copy()
        for k in range(n):
            active = np.zeros(width, dtype=bool)
            for foot in (int(i) for i in np.flatnonzero(contact[k])):
                active[3 * foot : 3 * foot + 3] = True
                if foot in flat_of:
                    active[3 * nf + 3 * flat_of[foot] : 3 * nf + 3 * flat_of[foot] + 3] = True
            if not active.any():
                continue  # flight: nothing can balance it
            a = jac[:, k * width : (k + 1) * width][:, active]
            # min |Δ|² s.t. a·Δ = −rows (regularised): Δ = aᵀ(aaᵀ + εI)⁻¹(−rows)
            delta = a.T @ np.linalg.solve(a @ a.T + BALANCE_REGULARISATION * np.eye(6),
                                          -rows[:, k])
            w[k, active] += delta
            fk = w[k, : 3 * nf].reshape(nf, 3)
            fk[:, 2] = np.clip(fk[:, 2], 0.0, self.options.max_force_body_weights)
            fk[:, :2] = np.clip(fk[:, :2], -mu * fk[:, 2:3], mu * fk[:, 2:3])
            fk[~contact[k]] = 0.0
            w[k, : 3 * nf] = fk.ravel()
        args[6] = w[:, : 3 * nf].T
        if nflat:
            args[10] = w[:, 3 * nf :].T
        _, tau, _ = (np.asarray(v) for v in self._knot(*args))
        return w, tau.T

    def _goal_slopes(
        self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray, schedule: ContactSchedule
    ) -> np.ndarray:
        """N × J knot slopes of the periodic cubic spline through the servo goals
        (`planner.nlp.constraints._servo_goal_groups`: s_{k−1} + 4 s_k + s_{k+1} =
        3 (g_{k+1} − g_{k−1}) N/T)."""
        n = self.layout.n_knots
        goal = q + (tau + self._damping * qd) / self._kp
        rhs = 3.0 * (np.roll(goal, -1, axis=0) - np.roll(goal, 1, axis=0)) * n / schedule.period_s
        m = 4.0 * np.eye(n) + np.roll(np.eye(n), 1, axis=1) + np.roll(np.eye(n), -1, axis=1)
        return np.linalg.solve(m, rhs)


def _cyclic_track(stuck: np.ndarray, step_m: float) -> np.ndarray:
    """N positions (cycle mean 0) that move by `step_m` over every interval k → k+1 marked
    `stuck` and make up the difference over the others on a half-sine speed profile per run,
    so the cycle closes; all zero when no interval is free."""
    n = stuck.size
    free = ~stuck
    if not free.any() or step_m == 0.0:
        return np.zeros(n)
    weight = np.zeros(n)
    # runs of free intervals (cyclic): a half-sine speed profile over each
    start = int(np.flatnonzero(stuck)[0]) if stuck.any() else 0
    order = [(start + i) % n for i in range(n)]
    run: list[int] = []
    for idx in [*order, order[0]]:
        if free[idx] and idx not in run:
            run.append(idx)
            continue
        for i, r in enumerate(run):
            weight[r] = np.sin(np.pi * (i + 0.5) / len(run))
        run = []
    d = np.where(stuck, step_m, 0.0)
    d[free] = -step_m * stuck.sum() * weight[free] / weight[free].sum()
    x = np.concatenate([[0.0], np.cumsum(d)[:-1]])  # x_k, k = 0 … N−1 (x_N = x_0)
    return x - x.mean()

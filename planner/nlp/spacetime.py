"""The spacetime gait planner: a parametric NLP built once per (robot, N), solved by IPOPT.

Usage (also what basin-CMA calls in its inner loop)::

    planner = GaitPlanner(robot, n_knots=30)                 # builds the NLP once (~seconds)
    result = planner.solve(schedule, speed_m_s=0.25)         # warm-starts from the last solve
    gait = planner.to_gait(result, "trot")                   # raises InfeasibleGaitError

The schedule (contact activity per knot, swing clearance profile), speed and period are NLP
parameters, so changing them never rebuilds anything. Warm starts reuse the previous primal
point (the multipliers restart, `WARM_START_DUALS`), pushed inside its bounds as
`ipopt_options` says for `PlannerOptions.ipopt_tuning`; `PlannerOptions.warm_retime` can map it
onto the new schedule first (`planner.nlp.warm_start`), and a symmetric warm solve takes the
half-cycle NLP (`PlannerOptions.warm_half_cycle`).

IPOPT's derivatives (`PlannerOptions.derivatives`): "knot" (default) keeps the NLP un-expanded and
hands CasADi one knot's Jacobian and Hessian, cached on disk per robot (`planner.nlp.solver_cache`);
"expanded" expands the whole NLP to SX (slow build); "compiled" is "knot" with J and H compiled
to C once per robot (`planner.nlp.compiled_knot`; "knot" picks a compiled entry up, and
starts its compile in the background if there is none: `planner.nlp.background_compile`). Same
optimum; see docs/results/planner_speed.md and planner_speed_compiled.md. With "knot" and
"compiled" IPOPT's constraint Jacobian is assembled from one knot Jacobian per knot
(`PlannerOptions.nlp_jacobian`, `planner.nlp.assembled_jacobian`; planner_speed_lifted.md).
"""

from __future__ import annotations

import dataclasses
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import InfeasibleGaitError, PlannerConfigError
from planner.nlp import diagnostics
from planner.nlp.assembled_hessian import KnotTerm, assembled_hessian
from planner.nlp.assembled_jacobian import assembled_jacobian
from planner.nlp.cold_start import ColdStarter, StartCommand
from planner.nlp.command import VelocityCommand, check_command
from planner.nlp.config import FREED_GROUPS, SWING_WRENCHES, WARM_ONLY_PREFIX, PlannerOptions
from planner.nlp.constraints import (
    build_groups,
    fill_servo_goals,
    group_labels,
    knot_function,
    knot_quantities,
    row_scales,
    stacked_knot,
)
from planner.nlp.costs import cost_terms, weighted_objective
from planner.nlp.half_cycle import HalfCycleNLP, MirrorDefect
from planner.nlp.hessian_shift import shifted_hessian
from planner.nlp.inactive_rows import RowActivity, free_inactive_rows
from planner.nlp.iteration_abort import AbortCallback, StallAbort
from planner.nlp.mirror import check_mirror, schedule_symmetric
from planner.nlp.model import RobotModel
from planner.nlp.solver_cache import (
    ALL_DIRECTIONS,
    CacheOutcome,
    DerivedFunctions,
    KnotDerivatives,
    directions_path,
    knot_jacobian_and_hessian,
    load_directions,
    same_function,
    save_directions,
    used_directions,
    with_knot_derivatives,
)
from planner.nlp.stance_clearance import free_stance_clearance
from planner.nlp.swing_wrench import swing_wrench_bounds
from planner.nlp.variables import (
    Layout,
    force_indices,
    initial_guess,
    make_symbols,
    parameter_vector,
    retimed_start,
    swing_force_upper_bounds,
    variable_bounds,
    variable_scale,
)
from planner.nlp.warm_start import per_foot_applies, per_foot_retimed
from robots import ContactSchedule, Gait, Robot, Velocity

_USER_STOP = ("User_Requested_Stop",)


@dataclass(frozen=True)
class _FullParts:
    """What `GaitPlanner` builds the full NLP's derivatives and solver from at their first use:
    its symbols, objective and rows (as IPOPT sees them), the knot map's call, the plain knot
    function, the direction counts an earlier build recorded and where to record this one's
    (None: recorded already, or not a "knot" build)."""

    x: Any
    p: Any
    f: Any
    g: Any
    knot_call: Any | None
    plain: ca.Function | None
    known: tuple[tuple[int, ...], tuple[int, ...]] | None
    directions: Path | None


@contextmanager
def _sigint_watch() -> Iterator[Callable[[], bool]]:
    """Record a Ctrl-C that arrives while IPOPT runs (CasADi catches the KeyboardInterrupt and
    ends the solve with a failure status); yields "was there one?". Main thread only."""
    hits: list[int] = []
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield lambda: False  # Ctrl-C ignored (SIG_IGN) or not ours to watch
        return
    handler = previous

    def on_sigint(signum: int, frame: FrameType | None) -> None:
        hits.append(signum)
        handler(signum, frame)  # the default handler raises KeyboardInterrupt: IPOPT stops

    signal.signal(signal.SIGINT, on_sigint)
    try:
        yield lambda: bool(hits)
    finally:
        signal.signal(signal.SIGINT, previous)

#: Warm-start policy for "same robot, new schedule/speed/period" (basin-CMA's inner loop):
#: reuse the last primal point only and restart the multipliers from zero. Measured on quad12
#: trot N=30 with 10 perturbed schedules (benchmarks/planner_bench.py): primal-only needs a
#: median 32 IPOPT iterations vs 61 with the previous multipliers (a contact switch makes the old
#: duals wrong and IPOPT spends iterations unwinding them); starting from the template's solution
#: instead of the last one, or μ_init 1e-5 with monotone μ, were worse (78 and 130 iterations).
WARM_START_DUALS = False
#: IPOPT's ``mumps_mem_percent`` (MUMPS' ICNTL(14): the percentage by which the factorisation's
#: workspace exceeds MUMPS' own estimate; IPOPT's default 1000 makes it 11× the estimate, 48–50 MB
#: on quad12 N = 12, which glibc maps and unmaps around every factorisation; IPOPT enlarges it
#: itself should MUMPS report it too small). Measured: docs/results/planner_speed.md, session 29.
MUMPS_MEM_PERCENT = 100
#: IPOPT's ``min_refinement_steps`` (its default 1): iterative-refinement steps on every linear
#: solve even when the residual is already small. 0 refines only when IPOPT's residual test asks
#: for it: the same iterations and optima on every converged schedule of the bar (quad12 and hex18
#: templates + 20 random schedules at N = 30, costs within 3.7e-9 / 3.4e-7 relative), 0.91× /
#: 0.94× the CPU per iteration on the compiled path (docs/results/planner_speed_rows.md, s44 lead).
MIN_REFINEMENT_STEPS = 0
#: IPOPT's ``fast_step_computation`` (its default "no"): "yes" skips the residual of every
#: linear solve (so no refinement either; IPOPT's inertia test and line search still judge the
#: step). The same optima on every converged schedule of the bar (quad12 and hex18 templates +
#: 20 random schedules at N = 30, costs within 1.0e-7 / 3.9e-7 relative; 3 of 36 converged
#: schedules ±1–2 iterations), 0.97× the CPU per iteration on the compiled path
#: (docs/results/planner_speed_rows.md, session 45 lead).
FAST_STEP_COMPUTATION = "yes"
#: `ipopt_tuning="tuned"`, warm solves: how far IPOPT pushes the start off its bounds (relative
#: to max(1, |bound|)) and the bound multipliers' lower limit, instead of 1e-6; and μ₀
TUNED_WARM_BOUND_PUSH = 1e-3
TUNED_WARM_MU_INIT = 1e-3


def _half_cycle_broken(result: PlanResult) -> bool:
    """A half-cycle solve whose reduced NLP converged (`Solve_Succeeded` or acceptable) to a
    point that the full NLP's rows reject (worst violation past `diagnostics.FEASIBILITY_TOL`).
    On a body whose rows are mirror images of each other the expanded point meets the second
    half's rows as the reduced NLP met the first half's (`planner.nlp.half_cycle`), so this says
    the body is not: joints and feet mirror (`robot_variable_mirror`), its dynamics do not
    (seen on a retargeting hybrid of quad12 and spotmicro: dynamics rows violated by 1.5e-2)."""
    status = str(result.stats.get("return_status", ""))
    converged = status in (*diagnostics.OPTIMAL_STATUSES, "Solved_To_Acceptable_Level")
    return (converged and not result.feasible
            and result.max_violation > diagnostics.FEASIBILITY_TOL)


def ipopt_options(options: PlannerOptions, warm: bool) -> dict[str, Any]:
    """IPOPT's options for a cold or a warm solve under `PlannerOptions.ipopt_tuning`.

    Every solve passes its initial multipliers (``warm_start_init_point``): zeros for a cold
    start and, with `WARM_START_DUALS` off, for a warm one too; IPOPT then lifts the bound
    multipliers to ``warm_start_mult_bound_push`` and moves the point that far (relative) inside
    its bounds. "session21" uses 1e-6 for both: a warm start from the last optimum then sits on
    its active bounds with multipliers 1e-6, far off the central path, and took more iterations
    than cold starts of the same schedules (quad12 trot N=30, perturbed chain: 124 vs 104).
    "tuned" warm-starts with `TUNED_WARM_BOUND_PUSH` (same chain: 100) and keeps the cold
    options: pushing cold starts too saved iterations on most templates but reached a 3.4 %
    costlier optimum on quad12's wave (docs/results/planner_speed_ipopt.md).
    """
    ipopt: dict[str, Any] = {
        "tol": options.tol,
        "acceptable_tol": 1e-4,
        "constr_viol_tol": 1e-5,
        "max_iter": options.max_iter,
        "print_level": options.print_level,
        "linear_solver": options.linear_solver,
        "mu_strategy": "adaptive",
        "min_refinement_steps": MIN_REFINEMENT_STEPS,
        "fast_step_computation": FAST_STEP_COMPUTATION,
        "sb": "yes",
        "print_timing_statistics": "yes" if options.print_level >= 5 else "no",
    }
    if options.linear_solver == "mumps":
        # METIS fill-reducing ordering: the KKT factorisation dominates an iteration, and
        # MUMPS' automatic choice is 2.4x slower here (quad12 N=30 cold: 4.8 s -> 2.0 s, same
        # 22 iterations); scaling and memory options made no further difference.
        ipopt["mumps_pivot_order"] = 5
        ipopt["mumps_mem_percent"] = MUMPS_MEM_PERCENT
    if options.inactive_rows == "regularised":
        # the Jacobian is rank-deficient (`planner.nlp.inactive_rows`): δ_c > 0 from the start
        ipopt["perturb_always_cd"] = "yes"
    tuned_warm = warm and options.ipopt_tuning == "tuned"
    if not tuned_warm and options.cold_mu_centrality != "none":
        ipopt["quality_function_centrality"] = options.cold_mu_centrality
    push = TUNED_WARM_BOUND_PUSH if tuned_warm else 1e-6
    ipopt.update(
        {
            "warm_start_init_point": "yes",
            "warm_start_bound_push": push,
            "warm_start_slack_bound_push": push,
            "warm_start_mult_bound_push": push,
            # with mu_strategy adaptive μ₀ matters little: warm, 1e-3 and 1e-4 gave the same
            # iterates (planner_speed_ipopt.md)
            "mu_init": TUNED_WARM_MU_INIT if tuned_warm else 1e-2,
        }
    )
    for name, value in options.ipopt_extra:  # `PlannerOptions.ipopt_extra`: () adds nothing
        if name.startswith(WARM_ONLY_PREFIX):
            if warm:  # "warm:NAME": warm solves only
                ipopt[name.removeprefix(WARM_ONLY_PREFIX)] = value
        else:
            ipopt[name] = value
    return ipopt


@dataclass(frozen=True, eq=False)
class SolveBounds:
    """The bounds one solve handed its solver, in physical units (`GaitPlanner._solve_bounds`);
    the result's reports judge the point against these."""

    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray


@dataclass(frozen=True)
class WarmStart:
    """A primal/dual point to start IPOPT from; `schedule`: the schedule it solves, if known
    (`PlannerOptions.warm_retime` maps it onto another one)."""

    x: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray
    schedule: ContactSchedule | None = None


@dataclass(frozen=True, eq=False)
class PlanResult:
    """One local solve: gait-ready arrays over the N knots plus cost and solver facts."""

    schedule: ContactSchedule
    speed_m_s: float
    base_pose: np.ndarray  # N × 6 (x, y, z, roll, pitch, yaw), treadmill frame
    joint_angles_rad: np.ndarray  # N × J
    joint_speeds_rad_s: np.ndarray  # N × J (central differences)
    contact_forces_n: np.ndarray  # N × F × 3, world frame
    joint_torques_nm: np.ndarray  # N × J, inverse dynamics
    cost: float
    cost_terms: dict[str, float]
    feasible: bool
    status: str
    iterations: int
    solve_time_s: float
    max_violation: float
    binding: tuple[tuple[str, float], ...]
    message: str
    warm_start: WarmStart
    stats: dict[str, Any] = field(default_factory=dict)
    #: IPOPT proved the point locally optimal (`Solve_Succeeded`); a feasible result with
    #: optimal=False is the point IPOPT stopped at (`diagnostics.ACCEPT_IF_FEASIBLE`)
    optimal: bool = True
    #: the rest of the velocity command (`planner.nlp.command`); base_pose is then relative to the
    #: command frame (the treadmill frame when both are 0)
    vy_m_s: float = 0.0
    yaw_rate_rad_s: float = 0.0


class GaitPlanner:
    """Spacetime gait optimisation for one robot at a fixed number of knots."""

    def __init__(
        self, robot: Robot, n_knots: int = 30, options: PlannerOptions | None = None,
        *, background_compile: bool = True,
    ) -> None:
        """`background_compile`: whether a "knot" build that finds no compiled derivatives for
        this body may start their compile in the background (`planner.nlp.background_compile`);
        off for bodies no later command will plan (a design search's samples, a retargeting
        series' hybrids)."""
        if not 8 <= n_knots <= 200:
            raise PlannerConfigError(f"n_knots must be in [8, 200], got {n_knots}")
        t0 = time.perf_counter()
        self.robot = robot
        self.n_knots = n_knots
        self.model = RobotModel(robot)
        options = options or PlannerOptions()
        self.layout = Layout.of(self.model, n_knots, options.lifted_goals)
        # the iteration cap of this NLP's size (`planner.nlp.config.iteration_cap`) unless set;
        # the lifted servo goals (`PlannerOptions.servo_goal_form`) do not count: the same cap
        n_capped = self.layout.size - self.layout.width("goal") * n_knots
        self.options = dataclasses.replace(options, max_iter=options.max_iter_for(n_capped))
        # nondimensional NLP: the solver sees x / x_scale and g / g_scale (see variable_scale)
        nondim = self.options.nondimensional
        self._x_scale = (
            variable_scale(self.layout, self.model) if nondim else np.ones(self.layout.size)
        )
        sym = make_symbols(self.layout, self._x_scale if nondim else None)
        #: with `derivatives="knot"`: the knot function carrying its own derivatives (kept alive
        #: here: CasADi's derivative cache holds weak references) and what the disk cache did
        self.knot_derivatives: KnotDerivatives | None = None
        self.derivative_cache: CacheOutcome | None = None
        #: with "knot"/"compiled": an earlier build with this knot, N and options recorded the
        #: derivative directions its solver used, so only those were created ("second command")
        self.directions_cached: bool | None = None
        knot, plain = None, None
        directions: Path | None = None
        known: tuple[tuple[int, ...], tuple[int, ...]] | None = None
        self._cold_starter: ColdStarter | None = None  # `_cold_start`, built at first use
        if self.options.derivatives in ("knot", "compiled"):
            plain = knot_function(self.model)
            jac, hess, self.derivative_cache = knot_jacobian_and_hessian(
                plain, self.options.derivatives, label=robot.name,
                start_compile=background_compile,
            )
            directions = directions_path(plain, n_knots, self.options)
            known = load_directions(directions)
            self.directions_cached = known is not None
            # the assembled constraint Jacobian calls J itself, never the knot's forward
            # derivatives (CasADi would generate any it asked for: exact, only slower)
            assembled = self.options.nlp_jacobian == "assembled"
            assembled_h = self.options.nlp_hessian == "assembled"
            forward, second = known or (
                () if assembled else ALL_DIRECTIONS, () if assembled_h else ALL_DIRECTIONS
            )
            # J and H, the cache keys and the derivative names are the plain knot's; the NLP
            # calls its stacked form (`stacked_knot`: the same u and y, a faster build)
            self.knot_derivatives = with_knot_derivatives(
                stacked_knot(plain), jac, hess, forward, second
            )
            knot = self.knot_derivatives.knot
        kq = knot_quantities(self.model, sym, n_knots, knot, self.options.knot_threads)
        #: with "knot"/"compiled": the flat feet's and soles' per-knot functions get the knot's
        #: derivative treatment too (`DerivedFunctions`; kept alive here with the solver)
        self.derived: DerivedFunctions | None = (
            None if self.knot_derivatives is None else DerivedFunctions(n_knots, self.options))
        groups = build_groups(self.model, sym, kq, n_knots, self.options,
                              same_function if self.derived is None else self.derived)
        terms = cost_terms(self.model, sym, kq, n_knots)
        objective = weighted_objective(terms, self.options.weights)
        g = ca.vertcat(*[grp.expr for grp in groups])
        self._lbg = np.concatenate([grp.lb for grp in groups])
        self._ubg = np.concatenate([grp.ub for grp in groups])
        self._g_scale = row_scales(groups) if nondim else np.ones(self._lbg.shape)
        g_solver = g / ca.DM(self._g_scale) if nondim else g
        slices, start = [], 0
        for grp in groups:
            size = int(grp.expr.shape[0])
            slices.append((grp.name, slice(start, start + size)))
            start += size
        self._slices = slices
        #: `PlannerOptions.inactive_rows` "free": which rows the schedule switches off
        self._row_activity = _row_activity(
            groups, slices, sym.p, self.layout, FREED_GROUPS[self.options.inactive_rows]) if (
            self.options.inactive_rows in FREED_GROUPS) else None
        self._labels = group_labels(self.model, n_knots, self.options.compact_rows)
        self._x_labels = self.layout.labels(self.robot.joint_names, self.model.flat_feet)
        self._lbx, self._ubx = variable_bounds(self.layout, self.model, self.options)
        #: rows given to IPOPT as variable bounds (`PlannerOptions.compact_rows`), reported
        #: as their groups' rows
        self._bound_rows = bound_rows(self.layout, self.model, self.options)
        self._term_names = list(terms)
        self._evaluate = ca.Function(
            "evaluate", [sym.x, sym.p], [g, kq.tau_nm, kq.qd, *terms.values()]
        )
        self._nlp = {"x": sym.x, "p": sym.p, "f": objective, "g": g_solver}
        #: what the full NLP's derivatives and IPOPT instance are built from, at their first use
        #: (`_jac_g`, `_hess_l`, `_solver`): a command that solves on the half-cycle path alone
        #: (`planner.nlp.half_cycle`) never builds them (docs/results/planner_speed_startup.md,
        #: session 44)
        self._full_parts = _FullParts(sym.x, sym.p, objective, g_solver, kq.knot_call,
                                      plain, known, directions)
        #: `_jac_g`, `_hess_l` once built (a 1-tuple: the function or None), else None
        self._jac_g_fn: tuple[ca.Function | None] | None = None
        self._hess_l_fn: tuple[ca.Function | None] | None = None
        #: the NLP's per-knot calls with their J and H, the knot's first (`assembled_hessian`;
        #: the half-cycle solve evaluates them at the knots its rows read, `_build_half_cycle`)
        self._knot_terms: list[KnotTerm] = []
        if self.knot_derivatives is not None and kq.knot_call is not None:
            knot_term = (
                kq.knot_call, self.knot_derivatives.jacobian, self.knot_derivatives.hessian
            )
            self._knot_terms = [knot_term, *([] if self.derived is None else self.derived.calls)]
        if self.options.hessian_shift_acc > 0 and not self._assembles_hess_l():
            raise PlannerConfigError(
                "hessian_shift_acc needs the assembled Lagrangian Hessian (nlp_hessian="
                "'assembled' with derivatives 'knot' or 'compiled')")
        self._solver_instance: Any | None = None  # `_solver`
        self._warm_solver: Any | None = None  # `_solver_for`
        self.build_time_s = 0.0  # set at the end; a lazy build (`_solver`) adds its time
        if not self.lazy_full_solver:
            self._build_full_solver()
        self._last: WarmStart | None = None
        self._plain_knot = plain
        #: `PlannerOptions.half_cycle_solve`: the reduced NLP, built at the first solve it fits
        #: (False: this body or NLP has none)
        self._half_cycle: HalfCycleNLP | bool | None = None
        #: why this planner solves in full though its joints and feet mirror: its NLP is not its
        #: own mirror image (`planner.nlp.half_cycle.nlp_mirror_defect`, found at the first solve
        #: that would have taken the half-cycle path), else None
        self.half_cycle_asymmetry: MirrorDefect | None = None
        self._used_abort: AbortCallback | None = None
        self.build_time_s = time.perf_counter() - t0

    #: build the full NLP's derivatives and IPOPT instance at their first use (`_solver`); a
    #: subclass whose `_make_solver` sets up more than the solver builds them in `__init__`
    lazy_full_solver = True

    def _assembles_jac_g(self) -> bool:
        """Does IPOPT get the assembled constraint Jacobian (`_jac_g`)?"""
        return (self.options.nlp_jacobian == "assembled" and self.knot_derivatives is not None
                and self._full_parts.knot_call is not None)

    def _assembles_hess_l(self) -> bool:
        """Does IPOPT get the assembled Lagrangian Hessian (`_hess_l`)?"""
        return self.options.nlp_hessian == "assembled" and bool(self._knot_terms)

    def _built_once(self, slot: str, build: Callable[[], ca.Function | None]
                    ) -> ca.Function | None:
        """The function kept in the attribute `slot` (a 1-tuple once built, else None), built
        by `build` at its first use; the build's time is added to `build_time_s`."""
        kept: tuple[ca.Function | None] | None = getattr(self, slot)
        if kept is None:
            t0 = time.perf_counter()
            kept = (build(),)
            setattr(self, slot, kept)
            self.build_time_s += time.perf_counter() - t0
        return kept[0]

    @property
    def _jac_g(self) -> ca.Function | None:
        """`PlannerOptions.nlp_jacobian` "assembled": IPOPT's jac_g of the full NLP
        (`_make_solver`), built at its first use; else None."""

        def build() -> ca.Function | None:
            parts = self._full_parts
            if not self._assembles_jac_g():
                return None
            assert self.knot_derivatives is not None and parts.knot_call is not None
            return assembled_jacobian(parts.x, parts.p, parts.g, parts.knot_call,
                                      self.knot_derivatives.jacobian, self.n_knots)

        return self._built_once("_jac_g_fn", build)

    @property
    def _hess_l(self) -> ca.Function | None:
        """`PlannerOptions.nlp_hessian` "assembled": IPOPT's hess_lag of the full NLP
        (`_make_solver`), built at its first use; else None."""

        def build() -> ca.Function | None:
            parts = self._full_parts
            if not self._assembles_hess_l():
                return None
            hess_l = assembled_hessian(parts.x, parts.p, parts.f, parts.g, self._knot_terms,
                                       self.n_knots)
            if self.options.hessian_shift_acc > 0:  # `planner.nlp.hessian_shift`
                hess_l = shifted_hessian(hess_l, self._acc_mask(),
                                         self.options.hessian_shift_acc)
            return hess_l

        return self._built_once("_hess_l_fn", build)

    @property
    def _solver(self) -> Any:
        """The full NLP's IPOPT instance for cold solves (`_make_solver`), built at its first
        use (its time is added to `build_time_s`)."""
        if self._solver_instance is None:
            self._build_full_solver()
        return self._solver_instance

    @_solver.setter
    def _solver(self, solver: Any) -> None:
        """Replace the full NLP's IPOPT instance (None: build it again at its next use)."""
        self._solver_instance = solver

    def _build_full_solver(self) -> None:
        """`_solver`'s build; the first one also records the knot derivatives' directions the
        solver uses, for the next build with this knot, N and options (`used_directions`)."""
        jac_g, hess_l = self._jac_g, self._hess_l  # their builds count themselves
        t0 = time.perf_counter()
        self._solver_instance = self._make_solver()
        parts = self._full_parts
        if parts.directions is not None and parts.plain is not None:
            # the next build with this knot, N and options creates only the derivatives used
            used = used_directions(self._solver_instance, parts.plain.name())
            # none found: a map CasADi named otherwise (the assembled Jacobian uses no
            # forward directions of the knot, only the Hessian's)
            if used != parts.known and (
                used[0] or (jac_g is not None and (used[1] or hess_l is not None))
            ):
                save_directions(parts.directions, *used)
            self._full_parts = dataclasses.replace(parts, directions=None)  # recorded once
            if self.derived is not None:
                self.derived.save_used(self._solver_instance)
        self.build_time_s += time.perf_counter() - t0

    def _acc_mask(self) -> np.ndarray:
        """The lifted accelerations' entries of x (`PlannerOptions.hessian_shift_acc`)."""
        mask = np.zeros(self.layout.size, dtype=bool)
        mask[self.layout.block("acc")] = True
        return mask

    @property
    def swing_clearance_m(self) -> float:
        """The swing clearance this planner uses (option or scaling law, `planner.nlp.config`)."""
        return self.options.swing_clearance_for(self.robot.leg_length_m)

    @property
    def body_clearance_m(self) -> float:
        return self.options.body_clearance_for(self.robot.leg_length_m)

    def _make_solver(self, warm: bool = False) -> Any:
        """An IPOPT instance for cold (`warm`=False) or warm solves (`ipopt_options`); the
        derivatives it calls are built once per planner, so a second instance costs ≈ 1 s."""
        opts: dict[str, Any] = {
            "ipopt": ipopt_options(self.options, warm),
            "print_time": False,
            # "knot": the MX NLP calls the knot's own derivatives (planner.nlp.solver_cache);
            # expanding it to SX would differentiate N copies of the knot instead
            "expand": self.options.derivatives == "expanded",
            "error_on_fail": False,
        }
        if self._jac_g is not None:
            opts["jac_g"] = self._jac_g
        if self._hess_l is not None:
            opts["hess_lag"] = self._hess_l
        abort = getattr(self, "_abort", None)
        if abort is not None:
            opts["iteration_callback"] = abort
        return ca.nlpsol("spacetime", "ipopt", self._nlp, opts)

    def set_iteration_abort(self, rule: StallAbort | None) -> None:
        """Stop solves whose constraint violation stalls (`planner.nlp.iteration_abort`; the
        gait search's coarse solves) or, with None, never; rebuilds the IPOPT instances."""
        self._abort = None if rule is None else AbortCallback(
            rule, int(self._nlp["x"].numel()), int(self._nlp["g"].numel()),
            int(self._nlp["p"].numel()))
        self._solver_instance = None  # rebuilt with the callback at its next use (`_solver`)
        self._warm_solver = None
        if self._half_cycle is not False:
            self._half_cycle = None  # rebuilt with its own callback at its next solve

    @property
    def last_solve_aborted(self) -> bool:
        """The iteration abort (`set_iteration_abort`) stopped the last solve."""
        abort = getattr(self, "_used_abort", None)
        return abort is not None and abort.fired

    def primal_start(self, x: np.ndarray, clip_to_bounds: bool = False) -> WarmStart:
        """A start at the primal point `x` (physical units, `layout` order) with zero multipliers:
        the warm-start policy for another schedule (`WARM_START_DUALS`); `clip_to_bounds` moves
        `x` into the variable bounds first."""
        x = np.asarray(x, dtype=float).ravel()
        if x.shape != self._lbx.shape:
            raise PlannerConfigError(
                f"a start of {x.size} variables for an NLP of {self._lbx.size}")
        if clip_to_bounds:
            x = np.clip(x, self._lbx, self._ubx)
        return WarmStart(x, np.zeros_like(x), np.zeros(self._lbg.shape))

    def _warm_options_differ(self) -> bool:
        """Do warm solves take other IPOPT options than cold ones (`ipopt_options`)? Then they
        need their own IPOPT instance (`_solver_for`, `_half_solver`)."""
        return ipopt_options(self.options, True) != ipopt_options(self.options, False)

    def _solver_for(self, warm: bool) -> Any:
        """The IPOPT instance for a cold or a warm solve: one instance when the tuning uses the
        same options for both, else the warm one is created at the first warm solve."""
        if not warm or not self._warm_options_differ():
            return self._solver
        if self._warm_solver is None:
            self._warm_solver = self._make_solver(warm=True)
        return self._warm_solver

    # -- solving -----------------------------------------------------------------------------

    def _check(
        self,
        schedule: ContactSchedule,
        speed_m_s: float,
        vy_m_s: float = 0.0,
        yaw_rate_rad_s: float = 0.0,
    ) -> None:
        if tuple(schedule.feet) != self.robot.foot_names:
            raise PlannerConfigError(
                f"schedule feet {list(schedule.feet)} do not match the robot's legs "
                f"{list(self.robot.foot_names)}"
            )
        if not (np.isfinite(speed_m_s) and -10.0 <= speed_m_s <= 10.0):
            raise PlannerConfigError(f"speed must be in [-10, 10] m/s, got {speed_m_s!r}")
        check_command(vy_m_s, yaw_rate_rad_s, schedule.period_s, self.n_knots)
        if self.options.half_cycle_mirror:
            check_mirror(self.robot, schedule, self.n_knots, vy_m_s, yaw_rate_rad_s)
        contact = schedule.contact_matrix(self.n_knots)
        if speed_m_s != 0 or vy_m_s != 0 or yaw_rate_rad_s != 0:
            for foot, duty in zip(schedule.feet, schedule.duty_factor, strict=True):
                if duty >= 1.0 - 1e-9 or contact[:, schedule.feet.index(foot)].all():
                    raise PlannerConfigError(
                        f"foot {foot} never lifts off (duty factor {duty:g} at {self.n_knots} "
                        "knots): a foot that never swings cannot keep up with a moving command; "
                        "use speed 0 (stand) or a shorter duty factor"
                    )
        if not contact.any(axis=0).all():
            raise PlannerConfigError(
                f"with {self.n_knots} knots some foot never touches down; "
                "use more knots or longer duty factors"
            )

    def solve(
        self,
        schedule: ContactSchedule,
        speed_m_s: float,
        warm_start: WarmStart | bool | None = None,
        *,
        vy_m_s: float = 0.0,
        yaw_rate_rad_s: float = 0.0,
        half_cycle: bool | None = None,
        swing_wrench: str | None = None,
    ) -> PlanResult:
        """Plan one gait cycle at the command (vx = `speed_m_s`, `vy_m_s`, `yaw_rate_rad_s`;
        `planner.nlp.command`). `warm_start`: None → the last solution if any, False → cold.
        `half_cycle`: solve on the first half of the knots where it fits (`_half_cycle_for`);
        None → `PlannerOptions.half_cycle_solve`. `swing_wrench`: how this solve holds a swing
        foot's wrench at 0 (`SWING_WRENCHES`, per-solve bounds only: the NLP is the same);
        None → `PlannerOptions.swing_wrench`."""
        if swing_wrench is not None and swing_wrench not in SWING_WRENCHES:
            raise PlannerConfigError(f"swing_wrench must be one of {', '.join(SWING_WRENCHES)} "
                                     f"(or None: the options' own), got {swing_wrench!r}")
        self._check(schedule, speed_m_s, vy_m_s, yaw_rate_rad_s)
        p = parameter_vector(
            schedule, self.n_knots, speed_m_s, self.swing_clearance_m, vy_m_s, yaw_rate_rad_s
        )
        asked = (warm_start, swing_wrench)  # for a full-cycle fallback (`_half_cycle_broken`)
        start = self._last if warm_start is None or warm_start is True else warm_start or None
        t0 = time.perf_counter()
        warm = start is not None
        if swing_wrench is None and warm and self.options.warm_swing_wrench != "same":
            swing_wrench = self.options.warm_swing_wrench
        if start is not None:
            start = self._retimed(start, schedule)
        if start is None:
            x0 = self._cold_start(schedule, p, StartCommand(
                VelocityCommand(float(speed_m_s), float(vy_m_s), float(yaw_rate_rad_s)),
                self.swing_clearance_m))
            start = WarmStart(x0, np.zeros_like(x0), np.zeros_like(self._lbg))
        elif not WARM_START_DUALS:
            # this NLP's row count (a warm start may come from a planner with other rows)
            start = WarmStart(start.x, np.zeros_like(self._lbx), np.zeros_like(self._lbg))
        if self.layout.lifted_goals:  # the start on the "servo goal" rows, whatever its source
            start = dataclasses.replace(
                start, x=fill_servo_goals(self.layout, self.model, self.options, start.x))
        xs, gs = self._x_scale, self._g_scale
        bounds = self._solve_bounds(schedule, swing_wrench or self.options.swing_wrench)
        lbg, ubg = bounds.lbg / gs, bounds.ubg / gs
        half = self._half_cycle_for(schedule, p, start, bounds, vy_m_s, yaw_rate_rad_s, warm,
                                    self.options.half_cycle_solve if half_cycle is None
                                    else half_cycle)
        abort = getattr(self, "_abort", None) if half is None else half.abort
        self._used_abort = abort
        with _sigint_watch() as interrupted:
            if half is not None:
                sol, stats = self._solve_half_cycle(half, start, p, bounds, warm)
            else:
                # the full NLP's IPOPT instance, built at its first use: a one-off build, not
                # this solve's time (a half-cycle solve never builds it)
                t_build = time.perf_counter()
                solver = self._solver_for(warm=warm)
                t0 += time.perf_counter() - t_build
                if abort is not None:
                    abort.arm(lbg, ubg)
                # scaled problem: x̃ = x/xs, g̃ = g/gs, λ̃_x = λ_x·xs, λ̃_g = λ_g·gs
                raw = solver(
                    x0=start.x / xs,
                    lam_x0=start.lam_x * xs,
                    lam_g0=start.lam_g * gs,
                    p=p,
                    lbx=bounds.lbx / xs,
                    ubx=bounds.ubx / xs,
                    lbg=lbg,
                    ubg=ubg,
                )
                sol = {
                    "x": np.asarray(raw["x"]).ravel() * xs,
                    "lam_x": np.asarray(raw["lam_x"]).ravel() / xs,
                    "lam_g": np.asarray(raw["lam_g"]).ravel() / gs,
                    "f": float(raw["f"]),
                }
                stats = solver.stats()
        aborted = abort is not None and abort.fired
        if interrupted() or (stats.get("return_status") in _USER_STOP and not aborted):
            # CasADi swallows Ctrl-C (NonIpopt_Exception_Thrown), IPOPT's own handler returns
            # User_Requested_Stop: either way the user stopped it, the gait is not infeasible
            raise KeyboardInterrupt(f"IPOPT stopped ({stats.get('return_status')})")
        elapsed = time.perf_counter() - t0
        result = self._result(schedule, speed_m_s, p, sol, stats, elapsed, bounds)
        result = dataclasses.replace(result, vy_m_s=float(vy_m_s),
                                     yaw_rate_rad_s=float(yaw_rate_rad_s))
        result.stats["half_cycle"] = half is not None  # solved on the first half's knots
        if self.half_cycle_asymmetry is not None:  # why a mirrored body solves in full
            result.stats["half_cycle_asymmetry"] = dataclasses.asdict(self.half_cycle_asymmetry)
        # how this solve held the swing feet's wrench at 0 (the gait file's, whatever the options)
        result.stats["swing_wrench"] = swing_wrench or self.options.swing_wrench
        if half is not None and not aborted and _half_cycle_broken(result):
            # the reduced NLP converged to a point the full NLP rejects: this body's rows are not
            # mirror images of each other (its masses or inertias, say, are not left–right
            # symmetric, though its joints are), so no half-cycle solve of it can be trusted
            self._half_cycle = False
            full = self.solve(schedule, speed_m_s, asked[0], vy_m_s=vy_m_s,
                              yaw_rate_rad_s=yaw_rate_rad_s, half_cycle=False,
                              swing_wrench=asked[1])
            full.stats["half_cycle_fallback"] = {
                "iterations": result.iterations, "solve_time_s": result.solve_time_s,
                "max_violation": result.max_violation}
            return dataclasses.replace(full, solve_time_s=elapsed + full.solve_time_s)
        if result.feasible:
            self._last = result.warm_start
        return result

    def _retimed(self, start: WarmStart, schedule: ContactSchedule) -> WarmStart:
        """`start` mapped onto `schedule` as `PlannerOptions.warm_retime` says (unchanged when
        "none", when its schedule is unknown or the same, or when it is another NLP's)."""
        retime = self.options.warm_retime
        source = start.schedule
        if (retime == "none" or source is None or source == schedule
                or start.x.shape != self._lbx.shape or source.feet != schedule.feet):
            return start
        if retime == "whole" or not per_foot_applies(source, schedule):
            n = self.n_knots
            x = retimed_start(self.layout, start.x, source.period_s, schedule.period_s,
                              source.contact_matrix(n), schedule.contact_matrix(n))
        else:
            x = per_foot_retimed(self.layout, self.robot, start.x, source, schedule)
        return WarmStart(x, start.lam_x, start.lam_g, schedule)

    def _half_cycle_for(self, schedule: ContactSchedule, p: np.ndarray, start: WarmStart,
                        bounds: SolveBounds, vy_m_s: float, yaw_rate_rad_s: float, warm: bool,
                        wanted: bool) -> HalfCycleNLP | None:
        """The reduced NLP (`planner.nlp.half_cycle`) if `wanted` (`solve(half_cycle=)`) and this
        solve fits it: a straight command, a schedule that is half-cycle mirror symmetric at the
        knots, a start and variable bounds on the mirror subspace; None: solve the full NLP."""
        from planner.templates import mirror_permutation

        if not wanted or self._half_cycle is False:
            return None
        if vy_m_s != 0.0 or yaw_rate_rad_s != 0.0 or self.options.nondimensional:
            return None
        if (warm and not self.options.warm_half_cycle
                and self._warm_options_differ()):
            return None  # the reduced instance uses the cold options
        feet = mirror_permutation(self.robot)
        if feet is None or not schedule_symmetric(schedule, feet, self.n_knots):
            return None
        if self._half_cycle is None:
            self._half_cycle = self._build_half_cycle(p, start.x) or False
            if self._half_cycle is False:
                return None
        half = self._half_cycle
        assert isinstance(half, HalfCycleNLP)
        if not (half.mirror.on_subspace(start.x)
                and half.mirror.bounds_mirrored(bounds.lbx, bounds.ubx)):
            return None
        return half

    def _build_half_cycle(self, p: np.ndarray, x0: np.ndarray) -> HalfCycleNLP | None:
        """The reduced NLP of this planner (`planner.nlp.half_cycle`); its rows over the whole
        cycle are classified at a random point of the subspace near `x0` with parameters `p`
        (a symmetric schedule's). None if the body has no mirror map, or if the full NLP is not
        its own mirror image at a probe point near `x0` (`half_cycle_asymmetry` says where)."""
        from planner.nlp import half_cycle as hc

        mirror = hc.robot_variable_mirror(self.robot, self.layout, self.model.flat_feet)
        if mirror is None:
            return None
        f_and_g = ca.Function("mirror_probe", [self._nlp["x"], self._nlp["p"]],
                              [self._nlp["f"], self._nlp["g"]])
        defect = hc.nlp_mirror_defect(f_and_g, mirror, hc.probe_point(x0, self._lbx, self._ubx),
                                      p, self._slices)
        if not defect.symmetric:
            self.half_cycle_asymmetry = defect
            return None
        keep, cycle_rows = hc.first_half_rows(self._slices, self._labels, self.n_knots)
        weight = [1.0] * len(keep)
        if cycle_rows:
            rng = np.random.default_rng(0)
            x_half = x0[mirror.half] + 0.01 * rng.standard_normal(mirror.n_reduced)
            x_sym = mirror.expand(x_half)
            cycle = np.asarray(cycle_rows)
            x_s, p_s, g_s = self._nlp["x"], self._nlp["p"], self._nlp["g"][cycle_rows]
            if self._knot_terms:
                # these rows' own assembled Jacobian (a few rows: the full NLP's jac_g is not
                # built for a half-cycle solve, `_jac_g`), the knots they read only
                call, jacobian, _ = self._knot_terms[0]
                jac_f = assembled_jacobian(x_s, p_s, g_s, call, jacobian, self.n_knots,
                                           knots_read_only=True)
            else:
                jac_f = ca.Function("cycle_jac_g", [x_s, p_s], [g_s, ca.jacobian(g_s, x_s)])
            g_val, jac = jac_f(x_sym, p)
            jac_reduced = ca.mtimes(ca.DM(jac), mirror.matrix())
            more, more_w = hc.classify_cycle_rows(
                np.asarray(g_val).ravel(), jac_reduced, np.arange(cycle.size), self._lbg[cycle],
                self._ubg[cycle])
            keep += cycle[more].tolist()
            weight += more_w
        order = np.argsort(keep, kind="stable")
        rows = hc.RowSelection(np.asarray(keep, dtype=int)[order],
                               np.asarray(weight, dtype=float)[order])
        # the reduced NLP assembles its own J and ∇²L from the knot's terms: the full NLP's are
        # not built for it (`_jac_g`, `_hess_l`; without knot terms there are none to assemble),
        # only whether it has them matters
        nlp, derivatives = hc.reduced_nlp(mirror, rows, self._nlp["x"], self._nlp["p"],
                                          self._nlp["f"], self._nlp["g"], None, None,
                                          self._knot_terms, self.n_knots,
                                          assembled=(self._assembles_jac_g(),
                                                     self._assembles_hess_l()))
        if self.options.hessian_shift_acc > 0 and "hess_lag" in derivatives:
            # the reduced NLP's own assembled ∇²L, shifted on its accelerations
            # (`planner.nlp.hessian_shift`)
            derivatives["hess_lag"] = shifted_hessian(
                derivatives["hess_lag"], self._acc_mask()[mirror.half],
                self.options.hessian_shift_acc)
        opts: dict[str, Any] = {
            "ipopt": ipopt_options(self.options, False),
            "print_time": False,
            "expand": self.options.derivatives == "expanded",
            "error_on_fail": False,
            **derivatives,
        }
        rule = getattr(self, "_abort", None)
        abort = None if rule is None else AbortCallback(
            rule.rule, mirror.n_reduced, int(rows.keep.size), int(self._nlp["p"].numel()))
        if abort is not None:
            opts["iteration_callback"] = abort
        solver = ca.nlpsol("spacetime_half", "ipopt", nlp, opts)
        return HalfCycleNLP(mirror, rows, solver, abort, nlp, opts)

    def _half_solver(self, half: HalfCycleNLP, warm: bool) -> Any:
        """The reduced NLP's IPOPT instance for a cold or a warm solve (`_solver_for`)."""
        if not warm or not self._warm_options_differ() or half.nlp is None:
            return half.solver
        if half.warm_solver is None:
            opts = {**(half.solver_options or {}), "ipopt": ipopt_options(self.options, True)}
            half.warm_solver = ca.nlpsol("spacetime_half_warm", "ipopt", half.nlp, opts)
        return half.warm_solver

    def _solve_half_cycle(self, half: HalfCycleNLP, start: WarmStart, p: np.ndarray,
                          bounds: SolveBounds, warm: bool = False
                          ) -> tuple[dict[str, Any], dict[str, Any]]:
        """One solve of the reduced NLP, returned as the full NLP's solution (physical units;
        the dropped rows' multipliers 0, the cost f = 2·f̃) and IPOPT's statistics (the
        iteration log's objective doubled too: the full NLP's)."""
        m, r = half.mirror, half.rows
        lbg, ubg = r.weight * bounds.lbg[r.keep], r.weight * bounds.ubg[r.keep]
        if half.abort is not None:
            half.abort.arm(lbg, ubg)
        solver = self._half_solver(half, warm)
        raw = solver(x0=start.x[m.half], lam_x0=start.lam_x[m.half],
                     lam_g0=start.lam_g[r.keep], p=p, lbx=bounds.lbx[m.half],
                     ubx=bounds.ubx[m.half], lbg=lbg, ubg=ubg)
        sol = {
            "x": m.expand(np.asarray(raw["x"]).ravel()),
            "lam_x": m.expand(np.asarray(raw["lam_x"]).ravel()),
            "lam_g": r.lam_full(np.asarray(raw["lam_g"]).ravel(), self._lbg.size),
            "f": 2.0 * float(raw["f"]),
        }
        stats = dict(solver.stats())
        iterations = stats.get("iterations")
        if isinstance(iterations, dict) and "obj" in iterations:  # the full NLP's objective
            stats["iterations"] = {**iterations, "obj": [2.0 * v for v in iterations["obj"]]}
        return sol, stats

    def _variable_bounds(self, schedule: ContactSchedule, contact: np.ndarray | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
        """The variable bounds for `schedule`: the built ones, with f_z ≤ C·f_max when the
        "swing force" rows are bounds (`PlannerOptions.compact_rows`). `contact`: the
        schedule's contact matrix at this planner's knots, if already computed."""
        if "swing force" not in self.options.compact_rows:
            return self._lbx, self._ubx
        if contact is None:
            contact = schedule.contact_matrix(self.n_knots)
        return self._lbx, swing_force_upper_bounds(
            self.layout, self._ubx, contact, self.options.max_force_body_weights)

    def _cold_start(self, schedule: ContactSchedule, p: np.ndarray,
                    command: StartCommand) -> np.ndarray:
        """The start of a cold solve (`PlannerOptions.cold_start`, `planner.nlp.cold_start`)."""
        if self.options.cold_start == "stance":
            return initial_guess(self.layout, self.model, schedule)
        return self._starter().start(self.options.cold_start, schedule, command, p)

    def _starter(self) -> ColdStarter:
        """The planner's `ColdStarter` (built at first use)."""
        if self._cold_starter is None:
            fd = dict(self._slices)["finite differences"]
            scale = self._x_scale

            def fd_residual(x: np.ndarray, p: np.ndarray) -> np.ndarray:
                return np.asarray(self._evaluate(x / scale, p)[0]).ravel()[fd]

            knot = self._plain_knot if self._plain_knot is not None else knot_function(
                self.model)
            self._cold_starter = ColdStarter(
                self.layout, self.model, self.options, knot, fd_residual)
        return self._cold_starter

    def _solve_bounds(self, schedule: ContactSchedule, swing_wrench: str | None = None
                      ) -> SolveBounds:
        """The bounds of a solve of `schedule` (physical units): the built ones, the rows not in
        force freed (`_row_lower_bounds`), with `PlannerOptions.stance_clearance` "free" the stance
        feet's clearance rows freed (`planner.nlp.stance_clearance`) and with `swing_wrench`
        (None: `PlannerOptions.swing_wrench`) "bounds" the swing feet's wrench fixed
        (`planner.nlp.swing_wrench`). The schedule's contact matrix, which each of them needs
        when its option is on, is computed once."""
        swing_wrench = swing_wrench or self.options.swing_wrench
        uses = ("line capture" in dict(self._slices), "swing force" in self.options.compact_rows,
                swing_wrench == "bounds", self._row_activity is not None,
                self.options.stance_clearance == "free")
        contact = schedule.contact_matrix(self.n_knots) if any(uses) else None
        lbg = self._row_lower_bounds(schedule, contact)
        if self.options.stance_clearance == "free":
            assert contact is not None
            lbg = free_stance_clearance(dict(self._slices), contact, lbg)
        lbx, ubx = self._variable_bounds(schedule, contact)
        ubg = self._ubg
        if swing_wrench == "bounds":
            assert contact is not None
            lbx, ubx, lbg = swing_wrench_bounds(
                self.layout, self.model, contact, dict(self._slices), lbx, ubx, lbg)
        if self._row_activity is not None:
            assert contact is not None
            lbg, ubg = free_inactive_rows(self._row_activity.inactive(contact), lbg, ubg)
        return SolveBounds(lbx, ubx, lbg, ubg)

    def _row_lower_bounds(self, schedule: ContactSchedule, contact: np.ndarray | None = None
                          ) -> np.ndarray:
        """The rows' lower bounds for `schedule`: the built ones, with the line-capture rows
        that are not in force for it freed (`planner.nlp.line_capture.rows_in_force`).
        `contact`: the schedule's contact matrix at this planner's knots, if already computed."""
        rows = dict(self._slices).get("line capture")
        if rows is None:
            return self._lbg
        from planner.nlp.line_capture import rows_in_force
        from planner.templates import stance_foot_positions_m

        lbg = self._lbg.copy()
        if contact is None:
            contact = schedule.contact_matrix(self.n_knots)
        free = ~rows_in_force(np.asarray(contact, dtype=float).T,
                              stance_foot_positions_m(self.robot)[:, :2])
        lbg[rows][free] = -np.inf
        return lbg

    def _solver_parameters(self, schedule: ContactSchedule, speed_m_s: float) -> np.ndarray:
        return parameter_vector(schedule, self.n_knots, speed_m_s, self.swing_clearance_m)

    def _result(
        self,
        schedule: ContactSchedule,
        speed_m_s: float,
        p: np.ndarray,
        sol: dict[str, Any],
        stats: dict[str, Any],
        elapsed: float,
        bounds: SolveBounds,
    ) -> PlanResult:
        """The result of a solve that ended at `sol` (physical units), judged against the
        `bounds` it was handed."""
        x = np.asarray(sol["x"]).ravel()
        lam_g, lam_x = np.asarray(sol["lam_g"]).ravel(), np.asarray(sol["lam_x"]).ravel()
        g, tau, qd, *terms = (np.asarray(v) for v in self._evaluate(x / self._x_scale, p))
        g = g.ravel()
        lbx, ubx = bounds.lbx, bounds.ubx
        reports = diagnostics.group_reports(
            *diagnostics.with_bound_rows(
                self._slices, g, bounds.lbg, bounds.ubg, lam_g, self._bound_rows, x, lbx, ubx,
                lam_x),
            self._labels,
        )
        joints = self.layout.block("q")
        names = [f"{n}@{k}" for k in range(self.n_knots) for n in self.robot.joint_names]
        reports.append(
            diagnostics.bound_report(
                "joint limits", x[joints], lbx[joints], ubx[joints], lam_x[joints], names
            )
        )
        tilt = self.layout.indices("base")[:, 3:].ravel()  # roll, pitch, yaw
        reports.append(
            diagnostics.bound_report(
                "tilt",
                x[tilt],
                lbx[tilt],
                ubx[tilt],
                lam_x[tilt],
                [f"roll/pitch/yaw@{k}" for k in range(self.n_knots) for _ in range(3)],
            )
        )
        # every other variable bound (base height, f_z ≥ 0, …): IPOPT keeps them to within its
        # bound relaxation, but the verdict below must not take that on trust
        reports.append(
            diagnostics.bound_report(
                "variable bounds", x, lbx, ubx, np.zeros_like(x), self._x_labels
            )
        )
        max_violation = max(r.max_violation for r in reports)
        status = str(stats.get("return_status", "unknown"))
        feasible, optimal = diagnostics.judge(status, max_violation)
        binding = diagnostics.binding_limits(reports, feasible)
        if not feasible:
            message = diagnostics.explain(reports, binding, status)
        elif optimal:
            message = "ok"
        else:
            message = (
                f"ok: IPOPT stopped with {status} at a point that meets every constraint within "
                f"{diagnostics.FEASIBILITY_TOL:g} (worst {max_violation:.1e}); feasible, not "
                "proven locally optimal"
            )
        base, q, f = self.layout.unpack(x)
        weight_n = self.model.total_mass_kg * float(np.linalg.norm(self.model.gravity_m_s2))
        term_values = {
            n: float(np.asarray(v).item()) for n, v in zip(self._term_names, terms, strict=True)
        }
        return PlanResult(
            schedule=schedule,
            speed_m_s=float(speed_m_s),
            base_pose=base.copy(),
            joint_angles_rad=q.copy(),
            joint_speeds_rad_s=qd.T.copy(),
            contact_forces_n=f * weight_n,
            joint_torques_nm=tau.T.copy(),
            cost=float(sol["f"]),
            cost_terms=term_values,
            feasible=feasible,
            status=status,
            iterations=int(stats.get("iter_count", -1)),
            solve_time_s=elapsed,
            max_violation=max_violation,
            binding=binding,
            message=message,
            warm_start=WarmStart(x, lam_x, lam_g, schedule),
            optimal=optimal,
            stats={
                "return_status": status,
                "optimal": optimal,
                "iter_count": int(stats.get("iter_count", -1)),
                "t_wall_total_s": elapsed,
                "iterations": _iteration_log(stats),
            },
        )

    # -- output ------------------------------------------------------------------------------

    def to_gait(
        self, result: PlanResult, label: str, extra_metadata: dict[str, Any] | None = None
    ) -> Gait:
        """The gait file object for a feasible result; raises InfeasibleGaitError otherwise.

        The cycle is re-indexed to start at its most static-like knot (`planner.nlp.cycle_start`).
        With `PlannerOptions.servo_goals` (default) the joint samples are the servo goals that
        achieve the planned motion; the planned angles are the file's
        ``expected_joint_angles_rad`` and ``planner["joint_angles"]`` says which.
        """
        if not result.feasible:
            raise InfeasibleGaitError(result.message, result.binding)
        from planner.nlp.cycle_start import start_from_rest_like_knot
        from planner.nlp.metadata import planner_metadata

        # phase 0 is where the player ramps in from rest: start at the most evenly loaded knot
        result = start_from_rest_like_knot(result)

        meta = planner_metadata(self, result)
        meta.update(extra_metadata or {})
        knots = result.joint_angles_rad
        if self.options.servo_goals:  # the file streams servo goals (see planner.nlp.servo_loop)
            from planner.nlp.servo_loop import advance_by_latency, servo_goals_rad, servo_loops

            loops = servo_loops(self.robot, self.options.servo_settings)
            knots = servo_goals_rad(
                knots, result.joint_speeds_rad_s, result.joint_torques_nm, loops
            )
            knots = advance_by_latency(knots, result.schedule.period_s, loops)
        return Gait.create(
            robot=self.robot,
            knots_rad=knots,
            schedule=result.schedule,
            velocity=Velocity(result.speed_m_s, result.vy_m_s, result.yaw_rate_rad_s),
            gait_label=label,
            base_pose=result.base_pose,
            contact_forces_n=result.contact_forces_n,
            joint_torques_nm=result.joint_torques_nm,
            planner=meta,
            expected_knots_rad=result.joint_angles_rad if self.options.servo_goals else None,
        )


def _row_activity(groups: list[Any], slices: list[tuple[str, slice]], p: Any,
                  layout: Layout, names: tuple[str, ...] | None = None) -> RowActivity | None:
    """The activity factors of the groups that have them (`planner.nlp.inactive_rows`), only
    those of the groups named in `names` if given, or None if none has."""
    rows, factors = [], []
    for grp, (_, sl) in zip(groups, slices, strict=True):
        if grp.activity is not None and (names is None or grp.name in names):
            rows.append(np.arange(sl.start, sl.stop))
            factors.append(grp.activity)
    if not rows:
        return None
    return RowActivity(p, np.concatenate(rows), ca.vertcat(*factors),
                       layout.n_knots * layout.n_feet)


def bound_rows(
    layout: Layout, model: RobotModel, options: PlannerOptions
) -> tuple[diagnostics.BoundRows, ...]:
    """The constraint rows `options.compact_rows` turns into variable bounds, as
    `diagnostics.BoundRows` in their groups' units and label order
    (`planner.nlp.constraints.group_labels`)."""
    n = layout.n_knots
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in model.robot.joints], dtype=float)
    out = []
    if "joint speed" in options.compact_rows:  # rows q̇/ω₀, labels knot-major
        index = layout.indices("vel")[:, 6:].ravel()  # the joint rates
        out.append(diagnostics.BoundRows("joint speed", index, np.tile(omega0, n)))
    if "goal slope" in options.compact_rows and options.servo_goals:  # servo goal speed, u = 0
        out.append(diagnostics.BoundRows(
            "servo goal speed", layout.indices("goal_slope").ravel(), np.tile(omega0, n)))
    if "swing force" in options.compact_rows:  # rows C·f_max − f_z ≥ 0, labels knot-major
        index = force_indices(layout, 2)
        out.append(diagnostics.BoundRows("swing force", index, np.ones(index.size), True))
    return tuple(out)


def _iteration_log(stats: dict[str, Any]) -> dict[str, list[float]]:
    it = stats.get("iterations") or {}
    return {k: [float(v) for v in it.get(k, [])] for k in ("obj", "inf_pr", "inf_du")}

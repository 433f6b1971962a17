"""Search contact timings with basin-CMA and let the gait emerge from the speed (W&P 2009 §4-5).

The outer search runs over the timing variables only — period, per-foot touchdown phase and duty
factor — which W&P §4.1.2 mark "CMA only": the spacetime NLP (`GaitPlanner`) cannot change
them, so its projection leaves them where they are (``x_projected = x``) and optimises every
other variable (poses, forces) for that timing. Basin-CMA then searches f∘g over the timings.

Encoding (`TimingSpace`): the touchdown phase of the first foot is pinned to 0 (a cycle has no
preferred start, so a global phase shift is not a degree of freedom). With ``symmetric=True``
(the default) each foot with a mirror image under y → −y (detected from the stance foot
positions, `planner.templates.mirror_permutation`; no left/right roles or leg names) runs half
a period after it with the same duty factor — the half-period symmetry of walk, trot and pace,
which halves the search; feet on the midline are searched freely, and a robot with no mirror
pairs (any leg count and layout) gets the asymmetric space. Bound, gallop and pronk need
``symmetric=False``. Phases are searched on an unwrapped interval and wrapped modulo 1.

The search starts from the hand templates: every template that fits the encoding is solved
first, and the best becomes the initial CMA mean — so the search result is never worse than the
best template and, where timing matters, better.

Fitness = spacetime cost + the support term (`planner.search.support.TippingCost`): the open-loop
tipping of the timing's line-support phases, which the NLP (exact dynamics, knife-edge balance
allowed) does not see. Without it the W&P objective picked a trot at every quad12 speed from
0.05 to 0.4 m/s, including slow trots whose long two-foot phases lose speed in MuJoCo.

Acceptance (optional, `acceptance=`): a picklable factory of a check `Gait → verdict` (with
`.passed`, `.badness`), built once per worker. Every feasible projected sample is written as a
gait and checked; one that does not walk is ranked as infeasible (W&P rank infeasible samples
last). The command line passes `sim.acceptance.SimAcceptance` (MuJoCo, the servo model, ramp-in
from rest, each gait with the IMU attitude feedback it will be played with: closed loop for a
walk of a biped with an IMU, open loop otherwise, `robots.attitude.gait_attitude_gain`), so the
search optimises over gaits that walk as played, not only over plans that satisfy the NLP:
optimised timings exploit the model (feet that barely touch, knife-edge balance) in ways the
templates do not. `planner` never imports `sim`; the CLI wires them.

Resolution: the search projects each sample with a coarse NLP (`search_knots`, default 12, and
IPOPT capped at `search_max_iter`; a sample stopped by the cap counts as feasible only if the
point it stopped at meets every constraint — `planner.nlp.diagnostics.judge` — and its cost is then
an upper bound of its local optimum), then re-solves up to `FINAL_CANDIDATES` of the best
timings (`FINAL_CANDIDATES_NONE_ACCEPTED` when the coarse check accepted no sample:
`planner.search.budget`) at the full `n_knots` for the gait file, judged by
`final_acceptance`; by default the cheaper (at full resolution) of the first two that are feasible
and accepted wins, else the first accepted after them (`final_choice`). If none is accepted, the
templates the search was seeded with are re-solved at `n_knots` and judged the same way
(cheapest first), so the search never returns a gait that fails where its own starting
template passes: the coarse acceptance can reject a timing that walks at full resolution
(humanoid20's biped_walk template is rejected at 12 knots and passes at 30;
docs/results/zoo_gaits.md, "Session 25").
With a process pool or Ray the final phase runs on the search's workers, speculatively and
read in rank order (`planner.search.final_phase`), while this process builds the final planner.
The 12-knot NLP builds in 2.8 s instead of 8.5 s and solves in about half the time of the
30-knot one; it ranked quad12's four symmetric templates in the same order as the 30-knot NLP at
0.15 and at 0.3 m/s, though its costs are lower (the final cost is reported next to the search
cost so the difference stays visible).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.config import INACTIVE_ROWS, SWING_WRENCHES, PlannerOptions
from planner.nlp.iteration_abort import StallAbort
from planner.nlp.spacetime import GaitPlanner, PlanResult, WarmStart
from planner.nlp.variables import retimed_start
from planner.search import defaults
from planner.search.basin_cma import BasinCmaResult, GenerationReport, LocalResult, basin_cma
from planner.search.budget import (
    FINAL_CANDIDATES,
    FINAL_CANDIDATES_NONE_ACCEPTED,
    final_candidate_count,
    final_candidates_reason,
)
from planner.search.executors import Executor, ProcessExecutor, make_executor
from planner.search.final_phase import (
    FINAL_CHOICES,
    FinalOutcome,
    FinalPlannerSpec,
    FinalTask,
    choose_final,
    compared_candidates,
    compete_order,
    evaluate_task,
    prepare_final,
    worker_final_solve,
)
from planner.search.support import TippingCost
from planner.templates import (
    identical_schedules,
    label_gait,
    make_schedule,
    mirror_permutation,
    stance_foot_positions_m,
    templates_for,
)
from robots import ContactSchedule, Gait, Robot
from robots import load as load_robot

#: Period bounds in units of √(L/g) (dynamic similarity, Murphy et al. 2008 / Alexander).
PERIOD_BOUNDS_SQRT_L_G = (2.0, 9.0)
DUTY_BOUNDS = (0.35, 0.9)
#: a seed schedule's period outside the box grows the box to this factor beyond it, so CMA can
#: move both ways from the user's start
SEED_PERIOD_ROOM = 1.25
#: the support term's weight and the coarse NLP's knots (`planner.search.defaults`)
DEFAULT_TIPPING_WEIGHT = defaults.DEFAULT_TIPPING_WEIGHT
DEFAULT_SEARCH_KNOTS = defaults.DEFAULT_SEARCH_KNOTS
DEFAULT_SEARCH_MAX_ITER = 60
#: Initial CMA spread as a fraction of each box width: W&P §5 cover the box (⅓). A narrower start
#: around the best template (⅙) was tried on quad12 with MuJoCo acceptance: with 4 generations it
#: beat ⅓ at 0.15 and 0.25 m/s (search cost 0.249 vs 0.284, 0.423 vs 0.562) and tied at 0.35; with
#: 6 generations over 0.05-0.4 m/s it lost at 4 speeds (e.g. 0.15 m/s: 0.249 vs 0.151), won at 2
#: and its 0.35 m/s gait failed the final 12-cycle validation. ⅓ stays.
DEFAULT_SIGMA_FRACTION = 1.0 / 3.0
#: Violation reported for a sample whose plan is feasible but fails acceptance, per unit of the
#: check's badness: ranks it after the feasible samples and ahead of NLP-infeasible ones.
REJECTED_VIOLATION = 1e-9
#: How each coarse sample's NLP solve starts (`search_gait(warm_start=...)`): "cold" (the
#: planner's template-shaped initial guess), or from the primal solution of an earlier sample
#: chosen in the main process from the batches already finished (the seeding batch, earlier
#: generations; never a sample of the same batch, so the search does not depend on the executor
#: or its scheduling): "nearest" (the plan-feasible sample closest in box-normalised timing) or
#: "incumbent" (the cheapest one, accepted samples first). "-retimed" maps the start onto the
#: sample's schedule first (`planner.nlp.variables.retimed_start`: rates rescaled to its period,
#: forces to its contact pattern); without it the solution is used knot for knot as solved.
#: Measured in docs/results/planner_speed_search.md, "Session 30 (branch warm)".
SEARCH_WARM_STARTS = ("cold", "nearest", "nearest-retimed", "incumbent", "incumbent-retimed")
#: `TimingResult.status` of a coarse solve stopped by `TimingSolverFactory.coarse_abort`
ABORTED_STATUS = "stopped: constraint violation stalled"


class AcceptanceVerdict(Protocol):
    @property
    def passed(self) -> bool: ...

    @property
    def badness(self) -> float: ...


GaitAcceptance = Callable[[Gait], AcceptanceVerdict]


@dataclass(frozen=True)
class TimingSpace:
    """Maps a vector of timing variables ↔ a `ContactSchedule` for one robot."""

    feet: tuple[str, ...]
    mirror: tuple[int, ...]  # symmetric: right foot index for each searched (left) foot
    searched: tuple[int, ...]  # feet whose phase/duty are variables
    symmetric: bool
    period_bounds_s: tuple[float, float]

    @staticmethod
    def for_robot(robot: Robot, symmetric: bool = True) -> TimingSpace:
        """The timing space of `robot`. `symmetric` pairs each foot with its mirror image
        under y → −y (`planner.templates.mirror_permutation`: detected from the stance foot
        positions, never from leg names) and runs the +y foot half a period before it; feet on
        the midline are searched freely. A robot without mirror-image feet (e.g. a 5-leg star
        turned so no leg points forward) gets the asymmetric space whatever `symmetric` says."""
        unit = math.sqrt(robot.leg_length_m / 9.81)
        bounds = (PERIOD_BOUNDS_SQRT_L_G[0] * unit, PERIOD_BOUNDS_SQRT_L_G[1] * unit)
        n = len(robot.legs)
        perm = mirror_permutation(robot) if symmetric else None
        pos = stance_foot_positions_m(robot)
        left = [f for f in range(n) if perm is not None and perm[f] != f and pos[f, 1] > 0]
        if not left or perm is None:
            return TimingSpace(robot.foot_names, (), tuple(range(n)), False, bounds)
        middle = [f for f in range(n) if perm[f] == f]
        searched = tuple(left + middle)
        mirror = tuple(perm[f] for f in left)
        return TimingSpace(robot.foot_names, mirror, searched, True, bounds)

    @property
    def dim(self) -> int:
        return 1 + (len(self.searched) - 1) + len(self.searched)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        k = len(self.searched)
        lo = np.r_[self.period_bounds_s[0], np.full(k - 1, -0.5), np.full(k, DUTY_BOUNDS[0])]
        hi = np.r_[self.period_bounds_s[1], np.full(k - 1, 1.5), np.full(k, DUTY_BOUNDS[1])]
        return lo, hi

    def sigma0(self, fraction: float = 1.0 / 3.0) -> np.ndarray:
        """Initial standard deviations: `fraction` of each box width (W&P §5 cover the box: ⅓)."""
        lo, hi = self.bounds()
        return (hi - lo) * fraction

    def decode(self, x: np.ndarray) -> ContactSchedule:
        x = np.asarray(x, dtype=float)
        k = len(self.searched)
        period = float(np.clip(x[0], *self.period_bounds_s))
        rel = np.r_[0.0, x[1:k]]
        duty = np.clip(x[k:2 * k], *DUTY_BOUNDS)
        phases = [0.0] * len(self.feet)
        duties = [0.0] * len(self.feet)
        for i, foot in enumerate(self.searched):
            phases[foot], duties[foot] = float(rel[i] % 1.0), float(duty[i])
        for i, foot in enumerate(self.mirror):
            phases[foot], duties[foot] = float((rel[i] + 0.5) % 1.0), float(duty[i])
        return ContactSchedule(period, self.feet, tuple(phases), tuple(duties))

    def encode(self, schedule: ContactSchedule) -> np.ndarray | None:
        """The vector for `schedule`, or None if it breaks this space's symmetry."""
        ph = np.asarray(schedule.touchdown_phase)
        du = np.asarray(schedule.duty_factor)
        ref = ph[self.searched[0]]
        rel = (ph - ref) % 1.0
        if self.symmetric:
            for left, right in zip(self.searched[: len(self.mirror)], self.mirror, strict=True):
                if abs(((rel[right] - rel[left] - 0.5 + 0.5) % 1.0) - 0.5) > 1e-9 \
                        or abs(du[right] - du[left]) > 1e-9:
                    return None
        s = list(self.searched)
        return np.r_[schedule.period_s, rel[s[1:]], du[s]].astype(float)


def _encoded_seeds(space: TimingSpace,
                   schedules: Mapping[str, ContactSchedule]) -> dict[str, np.ndarray]:
    """The seed schedules as timing vectors; refuses one the search cannot represent."""
    out: dict[str, np.ndarray] = {}
    for name, schedule in schedules.items():
        if tuple(schedule.feet) != tuple(space.feet):
            raise PlannerConfigError(f"seed schedule {name!r}: feet {schedule.feet} are not the "
                                     f"robot's {space.feet}")
        duties = schedule.duty_factor
        if not all(DUTY_BOUNDS[0] <= d <= DUTY_BOUNDS[1] for d in duties):
            raise PlannerConfigError(
                f"seed schedule {name!r}: the search's duty factors lie in "
                f"[{DUTY_BOUNDS[0]}, {DUTY_BOUNDS[1]}], got {', '.join(f'{d:g}' for d in duties)}")
        x = space.encode(schedule)
        if x is None:
            raise PlannerConfigError(
                f"seed schedule {name!r}: its mirror-image legs do not run half a period apart "
                "with equal duty factors, as the symmetric search needs; use --no-symmetric")
        out[name] = x
    return out


def searchable_templates(robot: Robot) -> list[str]:
    """The templates that seed the search: those whose duty factors lie in `DUTY_BOUNDS`
    (`stand` never lifts a foot and cannot move at a speed > 0)."""
    return [name for name in templates_for(robot)
            if max(make_schedule(robot, name).duty_factor) <= DUTY_BOUNDS[1]]


def cost_of_transport(result: PlanResult, robot: Robot) -> float:
    """Mechanical cost of transport Σ|τ·q̇| / (m g v), averaged over the cycle (∞ at v = 0)."""
    power = np.abs(result.joint_torques_nm * result.joint_speeds_rad_s)
    power_w = float(np.mean(np.sum(power, axis=1)))
    if result.speed_m_s <= 0:
        return math.inf
    return power_w / (robot.mass_kg * 9.81 * result.speed_m_s)


@dataclass(frozen=True)
class TimingResult(LocalResult):
    """A local solve of the search; `plan_feasible`: the NLP solved, whatever acceptance said.

    For measurement (`benchmarks/gait_search_bench.py`, `benchmarks/readme_split.py`):
    `solve_s` the NLP solve's wall time, `accept_s` the acceptance check's, `build_s` the
    worker's planner build (on the first result a worker returns, 0 on the others); `cpu_s`
    and `accept_cpu_s` the worker process's CPU seconds (`time.process_time`) of the solve and
    of the check, which other jobs on a shared machine move far less than wall time."""

    plan_feasible: bool = False
    solve_s: float = 0.0
    accept_s: float = 0.0
    build_s: float = 0.0
    #: IPOPT's return status of the solve ("" if it did not run)
    status: str = ""
    cpu_s: float = 0.0
    accept_cpu_s: float = 0.0
    #: IPOPT's iterates, iteration 0 first: (objective, inf_pr, inf_du) as IPOPT reports them
    #: (`PlanResult.stats["iterations"]`), for replaying iteration rules on recorded searches
    iteration_log: tuple[tuple[float, float, float], ...] = ()
    #: the coarse NLP's primal solution of a plan-feasible sample, kept only when the search
    #: warm-starts later samples from earlier ones (`SEARCH_WARM_STARTS`; None otherwise)
    solution: np.ndarray | None = field(default=None, repr=False)
    #: whether this sample's solve started from an earlier sample's solution
    warm: bool = False


@dataclass(frozen=True)
class SampleStart:
    """A sample's timing with the start point of its solve: what the main process sends a
    worker under a warm `SEARCH_WARM_STARTS` policy (one coarse primal vector, ≈ 10 kB).

    `primal`: an earlier sample's solution (physical units, the coarse NLP's layout);
    `source_x`: that sample's timing; `retime`: map the solution onto this sample's schedule
    (`planner.nlp.variables.retimed_start`) before starting from it."""

    x: np.ndarray
    primal: np.ndarray
    source_x: np.ndarray
    retime: bool


@dataclass
class TimingSolver:
    """The local solve g(x) of basin-CMA: one spacetime solve for the decoded timing.

    The returned cost is the NLP's cost plus the support term of the timing (if any). A
    `SampleStart` instead of a timing vector starts the solve from its point (W&P §4.1.1's
    projection is unchanged: the timing stays fixed, the solve ends at a constrained local
    minimum for it; which one may depend on the start).
    """

    planner: GaitPlanner
    space: TimingSpace
    speed_m_s: float
    tipping: TippingCost | None = None
    acceptance: GaitAcceptance | None = None
    #: wall time of building `planner` (and the check), reported once with the first result
    build_s: float = 0.0
    #: `SEARCH_WARM_STARTS`: anything but "cold" returns each plan-feasible solution
    #: (`TimingResult.solution`) for the main process to start later samples from
    warm_start: str = "cold"

    def start_for(self, sample: np.ndarray | SampleStart, schedule: ContactSchedule
                  ) -> WarmStart | None:
        """The point the solve of `schedule` starts from (None: cold)."""
        if not isinstance(sample, SampleStart):
            return None
        primal = np.asarray(sample.primal, dtype=float)
        if primal.shape != (self.planner.layout.size,):
            raise PlannerConfigError(
                f"warm start: a start of {primal.size} variables for a coarse NLP of "
                f"{self.planner.layout.size}; starts must come from the same search")
        if sample.retime:
            n = self.planner.n_knots
            source = self.space.decode(np.clip(sample.source_x, *self.space.bounds()))
            primal = retimed_start(self.planner.layout, primal, source.period_s,
                                   schedule.period_s, source.contact_matrix(n),
                                   schedule.contact_matrix(n))
        # primal only (session 22: an earlier schedule's multipliers cost iterations)
        return self.planner.primal_start(primal)

    def __call__(self, sample: np.ndarray | SampleStart) -> TimingResult:
        build_s, self.build_s = self.build_s, 0.0
        x = sample.x if isinstance(sample, SampleStart) else sample
        x = np.clip(np.asarray(x, dtype=float), *self.space.bounds())
        schedule = self.space.decode(x)
        t0, c0 = time.perf_counter(), time.process_time()
        start = self.start_for(sample, schedule)
        warm = start is not None
        try:
            result = self.planner.solve(
                schedule, self.speed_m_s, warm_start=start if start is not None else False
            )
        except PlannerConfigError:  # e.g. a foot never lands on any knot
            return TimingResult(x, math.inf, False, 0, math.inf,
                                solve_s=time.perf_counter() - t0, build_s=build_s,
                                cpu_s=time.process_time() - c0, warm=warm)
        solve_s, cpu_s = time.perf_counter() - t0, time.process_time() - c0
        evals = int(result.iterations) + 1
        log = result.stats.get("iterations", {})
        iteration_log = tuple(zip(log.get("obj", ()), log.get("inf_pr", ()), log.get("inf_du", ()),
                                  strict=True))
        if self.planner.last_solve_aborted:
            # stopped as hopeless (`TimingSolverFactory.coarse_abort`): ranked after every
            # solved sample, whatever violation the point it stopped at has
            return TimingResult(x, math.inf, False, evals, math.inf, False, solve_s, 0.0,
                                build_s, ABORTED_STATUS, cpu_s, 0.0, iteration_log, warm=warm)
        cost = result.cost + (self.tipping(schedule) if self.tipping is not None else 0.0)
        solution = result.warm_start.x if result.feasible and self.warm_start != "cold" else None
        if result.feasible and self.acceptance is not None:
            t1, c1 = time.perf_counter(), time.process_time()
            verdict = self.acceptance(self.planner.to_gait(result, "search sample"))
            accept_s, accept_cpu_s = time.perf_counter() - t1, time.process_time() - c1
            if not verdict.passed:
                return TimingResult(x, cost, False, evals,
                                    REJECTED_VIOLATION * (1.0 + verdict.badness), True,
                                    solve_s, accept_s, build_s, result.status, cpu_s,
                                    accept_cpu_s, iteration_log, solution, warm)
            return TimingResult(x, cost, True, evals, result.max_violation, True,
                                solve_s, accept_s, build_s, result.status, cpu_s, accept_cpu_s,
                                iteration_log, solution, warm)
        return TimingResult(x, cost, result.feasible, evals, result.max_violation, result.feasible,
                            solve_s, 0.0, build_s, result.status, cpu_s, 0.0, iteration_log,
                            solution, warm)


#: the most plan-feasible solutions a `WarmStartExecutor` keeps (≈ 10 kB each for quad12's
#: coarse NLP); the worst-ranked is dropped beyond it
WARM_STARTS_KEPT = 256


class WarmStartExecutor:
    """Sends each sample with the start point its policy picks (`SEARCH_WARM_STARTS`) from the
    plan-feasible solutions of the batches this executor finished before (main process).

    Starts come only from earlier batches, so a sample's start is the same whatever the
    executor, its worker count or its scheduling."""

    def __init__(self, inner: Executor, space: TimingSpace, policy: str) -> None:
        if policy not in SEARCH_WARM_STARTS or policy == "cold":
            raise PlannerConfigError(f"WarmStartExecutor needs a warm policy of "
                                     f"{', '.join(SEARCH_WARM_STARTS[1:])}, got {policy!r}")
        self.inner, self.space, self.policy = inner, space, policy
        self.retime = policy.endswith("-retimed")
        lo, hi = space.bounds()
        self._lo, self._width = lo, hi - lo
        #: (normalised timing, rank (accepted first, cost), primal solution, timing)
        self.solved: list[tuple[np.ndarray, tuple[int, float], np.ndarray, np.ndarray]] = []

    def _normalised(self, x: np.ndarray) -> np.ndarray:
        return (np.clip(x, self._lo, self._lo + self._width) - self._lo) / self._width

    def start(self, x: np.ndarray) -> np.ndarray | SampleStart:
        """The item sent for sample `x`: itself (cold) while nothing is solved, else a
        `SampleStart` from the policy's earlier solution."""
        if not self.solved:
            return x
        if self.policy.startswith("incumbent"):
            _, _, primal, source = min(self.solved, key=lambda s: s[1])
        else:
            u = self._normalised(x)
            _, _, primal, source = min(self.solved, key=lambda s: float(np.sum((s[0] - u) ** 2)))
        return SampleStart(x, primal, source, self.retime)

    def map(self, fn: Callable[[np.ndarray | SampleStart], LocalResult],
            xs: Iterable[np.ndarray]) -> list[LocalResult]:
        items = [np.asarray(x, dtype=float) for x in xs]
        out = self.inner.map(fn, [self.start(x) for x in items])
        for x, r in zip(items, out, strict=True):
            self.remember(x, r)
        return out

    def remember(self, x: np.ndarray, result: LocalResult) -> None:
        """Keep `result`'s solution (if it returned one: plan-feasible) to start later samples."""
        solution = getattr(result, "solution", None)
        if solution is not None:
            rank = (0 if result.feasible else 1, float(result.cost))
            self.solved.append((self._normalised(x), rank, solution, np.asarray(x, dtype=float)))
            if len(self.solved) > WARM_STARTS_KEPT:
                # memory stays bounded on long searches: the worst-ranked solution goes
                worst = max(range(len(self.solved)), key=lambda i: self.solved[i][1])
                del self.solved[worst]


@dataclass(frozen=True)
class TimingSolverFactory:
    """Picklable factory: each executor worker builds its GaitPlanner once (W&P §5)."""

    robot_dir: str
    n_knots: int
    speed_m_s: float
    symmetric: bool
    options: PlannerOptions = field(default_factory=PlannerOptions)
    tipping_weight: float = 0.0
    acceptance: Callable[[], GaitAcceptance] | None = None
    warm_start: str = "cold"
    #: the search's period box when a seed schedule widened it (None: the robot's default box)
    period_bounds_s: tuple[float, float] | None = None
    #: stop coarse solves whose constraint violation stalls (`planner.nlp.iteration_abort`;
    #: None: every solve runs to IPOPT's own stop)
    coarse_abort: StallAbort | None = None

    def __call__(self) -> TimingSolver:
        t0 = time.perf_counter()
        robot = load_robot(self.robot_dir)
        planner = GaitPlanner(robot, self.n_knots, self.options)
        if self.coarse_abort is not None:
            planner.set_iteration_abort(self.coarse_abort)
        tipping = TippingCost.for_robot(robot, self.tipping_weight) if self.tipping_weight else None
        check = self.acceptance() if self.acceptance is not None else None
        space = TimingSpace.for_robot(robot, self.symmetric)
        if self.period_bounds_s is not None:
            space = replace(space, period_bounds_s=self.period_bounds_s)
        return TimingSolver(planner, space, self.speed_m_s, tipping, check,
                            time.perf_counter() - t0, self.warm_start)


class RecordingExecutor:
    """Delegates to an executor and keeps every (sample, local result) pair it evaluated."""

    def __init__(self, inner: Executor) -> None:
        self.inner = inner
        self.records: list[tuple[np.ndarray, LocalResult]] = []

    def map(self, fn: Callable[[np.ndarray], LocalResult], xs: Iterable[np.ndarray]
            ) -> list[LocalResult]:
        items = [np.asarray(x, dtype=float) for x in xs]
        out = self.inner.map(fn, items)
        self.records.extend(zip(items, out, strict=True))
        return out

    def best_feasible(self, k: int) -> list[tuple[np.ndarray, LocalResult]]:
        """`final_candidates_of` the samples evaluated so far."""
        return final_candidates_of(self.records, k)


def final_rank(result: LocalResult) -> tuple[int, float]:
    """The final phase's order of search results, best first: accepted (feasible) samples by
    cost, then those whose plan solved but whose gait failed the coarse acceptance check (they
    may pass at full resolution) by cost, then the rest (no plan), tied (a sort keeps their
    order)."""
    if not math.isfinite(result.cost):
        return (2, math.inf)
    if result.feasible:
        return (0, result.cost)
    return (1, result.cost) if getattr(result, "plan_feasible", False) else (2, math.inf)


def coarse_plan_solved(result: LocalResult) -> bool:
    """Whether a coarse solve gave a plan the final phase may re-solve (`final_rank` < 2)."""
    return final_rank(result)[0] < 2


def final_candidates_of(records: Iterable[tuple[np.ndarray, LocalResult]], k: int
                        ) -> list[tuple[np.ndarray, LocalResult]]:
    """Up to k distinct samples to re-solve at full resolution, best first: the feasible ones
    by cost, then those whose plan solved but whose gait failed acceptance (at the coarse
    resolution of the search; they may pass at the final one), by cost."""

    usable = sorted((r for r in records if coarse_plan_solved(r[1])),
                    key=lambda record: final_rank(record[1]))
    picked: list[tuple[np.ndarray, LocalResult]] = []
    for x, res in usable:
        if all(not np.allclose(x, y) for y, _ in picked):
            picked.append((x, res))
        if len(picked) == k:
            break
    return picked


@dataclass(frozen=True)
class SearchLogRow:
    generation: int
    best_cost: float
    generation_best_cost: float
    n_feasible: int
    n_local_solves: int
    elapsed_s: float
    period_s: float
    touchdown_phase: tuple[float, ...]
    duty_factor: tuple[float, ...]
    gait_label: str


@dataclass(frozen=True, eq=False)
class GaitSearchResult:
    """The searched gait: `best` is the final solve at `n_knots` (the gait file's resolution).

    Costs named `search_*` and `template_costs` come from the coarse search NLP and include the
    support term, so they compare with each other; `best.cost` is the final NLP's objective
    without it and `support_cost` the support term of the winning timing.
    """

    robot: Robot
    speed_m_s: float
    best: PlanResult
    label: str
    template_costs: dict[str, float]  # template → search cost (inf if infeasible)
    best_template: str
    search_cost: float  # search cost of the timing that won (template or CMA sample)
    search_feasible: bool  # it was feasible and accepted at the search resolution too
    support_cost: float  # support term of that timing
    tipping_amplification: float
    log: tuple[SearchLogRow, ...]
    cma: BasinCmaResult
    elapsed_s: float
    cost_of_transport: float
    search_knots: int
    accepted: bool | None  # the final gait passed the acceptance check (None: no check)
    planner: GaitPlanner  # the final planner (builds the gait file from `best`)
    symmetric: bool = True  # the search used the mirror half-period symmetry (TimingSpace)
    #: every local solve of the search, template seeds first, as (sample, result)
    samples: tuple[tuple[np.ndarray, LocalResult], ...] = ()
    #: the full-resolution candidates re-solved: (plan, acceptance wall time [s], verdict)
    final_solves: tuple[tuple[PlanResult, float, bool | None], ...] = ()
    #: wall time [s] of the search's phases: "final_build" (the final planner, 0 if passed in),
    #: "seed" (executor start, worker builds, template solves), "cma", "final" (re-solves + checks)
    phase_s: dict[str, float] = field(default_factory=dict)
    #: this process's CPU seconds (`time.process_time`) in the same phases
    phase_cpu_s: dict[str, float] = field(default_factory=dict)
    #: the template that won: after no searched timing passed the final acceptance, or (with
    #: ``final_templates="compete"``) as cheaper than the searched winner (None: a searched
    #: timing, or the normal ranking, won)
    fallback_template: str | None = None
    #: the final phase's outcomes as read, in order (`final_solves` with the CPU seconds of
    #: the process that ran each: this one, or a worker with `final_on_workers`)
    final_outcomes: tuple[FinalOutcome, ...] = ()
    #: the final phase ran on the executor's workers (`planner.search.final_phase`); the final
    #: planner's build ("final_build") then overlapped it and is part of "final"'s wall time
    final_on_workers: bool = False
    #: the timings the final phase could re-solve and why (`planner.search.budget`)
    final_candidates: int = FINAL_CANDIDATES
    final_candidates_reason: str = ""
    #: how the final phase chose among them (`final_phase.choose_final`, `FINAL_CHOICES`)
    final_choice: str = defaults.DEFAULT_FINAL_CHOICE
    #: the coarse solves ran on the first half of a symmetric sample's knots (`half_cycle`)
    search_half_cycle: bool = defaults.SEARCH_HALF_CYCLE
    #: `PlannerOptions.half_cycle_solve` of the final re-solves (`search_gait(final_half_cycle=)`)
    final_half_cycle: bool = defaults.FINAL_HALF_CYCLE
    #: which candidates whose half-cycle re-solve failed were re-solved on the full NLP
    #: (`search_gait(final_retry_full=)`, `defaults.FINAL_RETRIES`, `FinalTask.retry_full`)
    final_retry_full: str = defaults.FINAL_RETRY_FULL
    #: the written plan is such a full-cycle retry (`final_phase.FinalOutcome.half_tried`)
    final_retried: bool = False
    #: why it was retried: how its half-cycle plan failed (`final_phase.describe_failure`,
    #: e.g. "narrow: heading +0.4 %"; "" if the written plan is not a retry)
    final_retry_reason: str = ""
    #: the templates only as the fallback, or competing with the searched winner
    #: (`defaults.FINAL_TEMPLATES`, `final_phase.choose_final(rival=)`)
    final_templates: str = defaults.DEFAULT_FINAL_TEMPLATES
    #: with "compete": the searched winner's full-resolution cost + support term when the
    #: template `fallback_template` was cheaper and won over it (None: it did not)
    beaten_search_total: float | None = None

    @property
    def froude(self) -> float:
        return self.speed_m_s**2 / (9.81 * self.robot.leg_length_m)

    @property
    def best_template_cost(self) -> float:
        return self.template_costs[self.best_template]

    @property
    def total_cost(self) -> float:
        """Final NLP cost + support term: the quantity the search minimised, at full resolution."""
        return self.best.cost + self.support_cost


def _check_one_of(name: str, value: str, choices: Sequence[str]) -> None:
    """`search_gait`'s argument `name` must be one of `choices` (`PlannerConfigError`)."""
    if value not in choices:
        raise PlannerConfigError(f"{name} must be one of {', '.join(choices)}, got {value!r}")


def search_gait(
    robot: Robot,
    speed_m_s: float,
    *,
    n_knots: int = 30,
    options: PlannerOptions | None = None,
    symmetric: bool = True,
    max_generations: int = defaults.DEFAULT_GENERATIONS,
    popsize: int | None = None,
    restarts: int = 0,
    max_local_solves: int | None = None,
    seed: int = 0,
    executor: str = "serial",
    workers: int | None = None,
    address: str | None = None,
    planner: GaitPlanner | None = None,
    search_knots: int = DEFAULT_SEARCH_KNOTS,
    search_max_iter: int = DEFAULT_SEARCH_MAX_ITER,
    tipping_weight: float = DEFAULT_TIPPING_WEIGHT,
    acceptance: Callable[[], GaitAcceptance] | None = None,
    final_acceptance: Callable[[], GaitAcceptance] | None = None,
    sigma_fraction: float = DEFAULT_SIGMA_FRACTION,
    progress: Callable[[SearchLogRow], None] | None = None,
    final_candidates: int | None = None,
    warm_start: str = "cold",
    seed_schedules: Mapping[str, ContactSchedule] | None = None,
    coarse_abort: StallAbort | None = None,
    search_swing_wrench: str | None = defaults.SEARCH_SWING_WRENCH,
    search_tol: float | None = None,
    search_inactive_rows: str = defaults.SEARCH_INACTIVE_ROWS,
    final_choice: str = defaults.DEFAULT_FINAL_CHOICE,
    search_half_cycle: bool = defaults.SEARCH_HALF_CYCLE,
    final_templates: str = defaults.DEFAULT_FINAL_TEMPLATES,
    final_half_cycle: bool = defaults.FINAL_HALF_CYCLE,
    final_retry_full: str = defaults.FINAL_RETRY_FULL,
    final_swing_wrench: str | None = defaults.FINAL_SWING_WRENCH,
) -> GaitSearchResult:
    """The best contact timing for `robot` at `speed_m_s`: basin-CMA seeded by the templates.

    `planner` is the final planner (n_knots, options); pass one to reuse its NLP across speeds.
    The executor's workers each build the coarse search NLP once (`search_knots`).
    `acceptance` judges every feasible sample, `final_acceptance` (default: `acceptance`) the
    full-resolution candidates — the final judge may be stricter than the coarse one;
    `final_candidates` of the cheapest timings are re-solved for it, the first accepted wins
    (None, the default: `FINAL_CANDIDATES`, or `FINAL_CANDIDATES_NONE_ACCEPTED` if no sample
    was accepted; `planner.search.budget`).
    `warm_start`: where each coarse sample's solve starts (`SEARCH_WARM_STARTS`; "cold").
    `seed_schedules`: more named seeds beside the templates (e.g. the user's own schedule,
    `gaitsmith plan --search --period/--duty/--phases/--schedule`): CMA starts from the first of
    them instead of the cheapest template, they join the templates in the fallback, and the
    period box grows to hold their periods with `SEED_PERIOD_ROOM` to spare.
    `coarse_abort`: stop coarse solves whose constraint violation stalls and rank them last
    (`planner.nlp.iteration_abort`; None, the default: every solve runs to IPOPT's stop).
    `search_swing_wrench`: `PlannerOptions.swing_wrench` of the coarse solves only ("rows" or
    "bounds"; default `planner.search.defaults.SEARCH_SWING_WRENCH`; None: `options.swing_wrench`);
    the final re-solves take
    `final_swing_wrench` (docs/results/planner_speed_search.md, sessions 32 and 40).
    `final_swing_wrench`: `PlannerOptions.swing_wrench` of the final re-solves of searched
    candidates (default `planner.search.defaults.FINAL_SWING_WRENCH`; None: `options`' own);
    a `planner` passed in must have it (`final_options`). The templates the final phase
    re-solves keep `options.swing_wrench`, as the template path plans them.
    `search_tol`: IPOPT's `tol` of the coarse solves only (None, the default: `options.tol`);
    the final re-solves keep `options.tol` (planner_speed_search.md, session 33).
    `search_inactive_rows`: `PlannerOptions.inactive_rows` of the coarse solves only (default
    `planner.search.defaults.SEARCH_INACTIVE_ROWS`, "rows", whatever `options` has); the final
    re-solves keep `options.inactive_rows` (planner_speed_ipopt.md, session 34). The coarse
    solves' `PlannerOptions.stance_clearance` and `cold_mu_centrality` are
    `defaults.SEARCH_STANCE_CLEARANCE` and `defaults.SEARCH_COLD_MU_CENTRALITY` whatever
    `options` has; the final re-solves keep the options' own.
    `final_choice` (`FINAL_CHOICES`, `final_phase.choose_final`): "first" — the first candidate in
    coarse rank order that is feasible and accepted wins; "cheapest-of-2" (the default) — the one
    of the first two with the lower full-resolution cost plus support term, else the first
    accepted after them; "cheapest" — every candidate is re-solved, the cheapest accepted wins.
    `search_half_cycle`: `PlannerOptions.half_cycle_solve` of the coarse solves only (default
    `planner.search.defaults.SEARCH_HALF_CYCLE`): a symmetric sample is solved on the first half
    of its knots (`planner.nlp.half_cycle`); the final re-solves take `final_half_cycle`.
    `final_half_cycle`: `PlannerOptions.half_cycle_solve` of the final re-solves of searched
    candidates, whatever `options` says (default `planner.search.defaults.FINAL_HALF_CYCLE`,
    on since session 40, with `final_retry_full` "narrow"; `PlannerOptions`' own default is the
    template path's); a
    `planner` passed in must have it (`final_options`). The templates the final phase re-solves
    are planned as the template path plans them, with `options`' own `half_cycle_solve`.
    `final_retry_full` (`defaults.FINAL_RETRIES`, default `defaults.FINAL_RETRY_FULL`): which
    candidates whose final re-solve ran on half the knots and did not pass are re-solved cold on
    the full NLP, that plan judged instead — "all" (infeasible or failing), "narrow" (feasible
    and failing the final check by at most `defaults.FINAL_RETRY_MARGIN` of every failed
    criterion's limit), "off" (one task: the rule and its order are unchanged;
    `final_phase.evaluate_final`); no effect with `final_half_cycle` off.
    `final_templates` (`defaults.FINAL_TEMPLATES`): "fallback" — the templates are re-solved
    only if no searched timing passes; "compete" — every template whose coarse plan solved is
    re-solved too, and the cheapest accepted one is written if it beats the searched winner
    (or if none passes)
    (`final_phase.choose_final(rival=)`; needs a final check, else the same as "fallback").
    """
    t0, c0 = time.perf_counter(), time.process_time()
    options = options or PlannerOptions()
    if planner is not None and planner.n_knots != n_knots:
        raise PlannerConfigError(f"planner has {planner.n_knots} knots, search asked for {n_knots}")
    if planner is not None and planner.options.half_cycle_solve != final_half_cycle:
        raise PlannerConfigError(
            f"planner has half_cycle_solve={planner.options.half_cycle_solve}, the search's final "
            f"re-solves final_half_cycle={final_half_cycle}: build it with final_options()")
    for name, value in (("search_swing_wrench", search_swing_wrench),
                        ("final_swing_wrench", final_swing_wrench)):
        if value is not None and value not in SWING_WRENCHES:
            raise PlannerConfigError(f"{name} must be one of {', '.join(SWING_WRENCHES)} (or "
                                     f"None: the options' own), got {value!r}")
    if planner is not None and planner.options.swing_wrench != (final_swing_wrench
                                                                 or options.swing_wrench):
        raise PlannerConfigError(
            f"planner has swing_wrench={planner.options.swing_wrench!r}, the search's final "
            f"re-solves {final_swing_wrench or options.swing_wrench!r}: build it with "
            "final_options()")
    if search_max_iter < 1:
        raise PlannerConfigError(f"search_max_iter must be ≥ 1, got {search_max_iter}")
    if final_candidates is not None and final_candidates < 1:
        raise PlannerConfigError(f"final_candidates must be ≥ 1, got {final_candidates}")
    _check_one_of("warm_start", warm_start, SEARCH_WARM_STARTS)
    if not 0 < sigma_fraction <= 1:
        raise PlannerConfigError(f"sigma_fraction must be in (0, 1], got {sigma_fraction}")
    _check_one_of("search_inactive_rows", search_inactive_rows, INACTIVE_ROWS)
    _check_one_of("final_choice", final_choice, FINAL_CHOICES)
    _check_one_of("final_templates", final_templates, defaults.FINAL_TEMPLATES)
    _check_one_of("final_retry_full", final_retry_full, defaults.FINAL_RETRIES)
    if search_tol is not None and not 0 < search_tol < 1:
        raise PlannerConfigError(f"search_tol must be in (0, 1) (or None: the options' own), "
                                 f"got {search_tol!r}")
    space = TimingSpace.for_robot(robot, symmetric)
    # each template as `gaitsmith plan` would plan it: the seeds, and the fallback's schedules
    # (a template's encoding starts the first foot at phase 0, a phase-rotated copy whose knots
    # fall elsewhere in the cycle, so IPOPT can end on another local optimum — bittle8's walk
    # at 0.13 m/s: the template passes MuJoCo, its rotated copy turns −7.4°)
    own = {name: make_schedule(robot, name) for name in searchable_templates(robot)}
    if space.symmetric and all(space.encode(schedule) is None for schedule in own.values()):
        # mirror pairs exist but no template runs them half a period apart (e.g. the azimuth
        # wave/ripple of a 5-leg star): search every foot's timing instead
        space = TimingSpace.for_robot(robot, False)
    symmetric = space.symmetric
    seeds = _encoded_seeds(space, seed_schedules or {})
    if seeds:
        periods = [float(x[0]) for x in seeds.values()]
        lo_s, hi_s = space.period_bounds_s
        space = replace(space, period_bounds_s=(min(lo_s, min(periods) / SEED_PERIOD_ROOM),
                                                max(hi_s, max(periods) * SEED_PERIOD_ROOM)))
    tipping = TippingCost.for_robot(robot, tipping_weight)
    search_options = replace(options, max_iter=search_max_iter if options.max_iter is None
                             else min(options.max_iter, search_max_iter),
                             swing_wrench=search_swing_wrench or options.swing_wrench,
                             tol=options.tol if search_tol is None else search_tol,
                             inactive_rows=search_inactive_rows,
                             stance_clearance=defaults.SEARCH_STANCE_CLEARANCE,
                             cold_mu_centrality=defaults.SEARCH_COLD_MU_CENTRALITY,
                             half_cycle_solve=search_half_cycle)
    factory = TimingSolverFactory(str(robot.root_dir), search_knots, speed_m_s, symmetric,
                                  search_options, tipping_weight, acceptance, warm_start,
                                  space.period_bounds_s if seeds else None, coarse_abort)
    log: list[SearchLogRow] = []

    def on_generation(rep: GenerationReport) -> None:
        sched = space.decode(rep.mean)
        row = SearchLogRow(rep.generation, rep.best_cost, rep.generation_best_cost, rep.n_feasible,
                           rep.n_local_solves, time.perf_counter() - t0, sched.period_s,
                           sched.touchdown_phase, sched.duty_factor, label_gait(sched, robot))
        log.append(row)
        if progress is not None:
            progress(row)

    lo, hi = space.bounds()
    final_check = final_acceptance or acceptance
    # the final phase runs on the executor's workers unless they are this process (module
    # `planner.search.final_phase`); they build its planner from the same robot and options
    on_workers = executor != "serial"
    spec = FinalPlannerSpec.new(robot if planner is None else planner.robot, n_knots,
                                final_options(options, final_half_cycle, final_swing_wrench)
                                if planner is None
                                else planner.options, speed_m_s, final_check)
    t_seed, c_seed = time.perf_counter(), time.process_time()
    with make_executor(executor, factory, workers=workers, address=address) as ex:  # type: ignore[arg-type]
        if on_workers and isinstance(ex, ProcessExecutor):
            # a worker out of samples at a generation barrier builds the final planner
            ex.idle_task = (prepare_final, spec)
        # a warm policy picks each sample's start in this process (`WarmStartExecutor`)
        pool = RecordingExecutor(ex if warm_start == "cold"
                                 else WarmStartExecutor(ex, space, warm_start))
        # 1. seed with the hand templates that fit the encoding (one parallel batch)
        if progress is not None:
            progress(SearchLogRow(-1, math.inf, math.inf, 0, 0, time.perf_counter() - t0, 0.0,
                                  (), (), "seeding with the templates"))
        named = [(name, space.encode(schedule)) for name, schedule in own.items()]
        named_x = [(name, x) for name, x in named if x is not None] + list(seeds.items())
        if not named_x:
            raise PlannerConfigError(f"no template of {robot.name} fits the search encoding")
        seeded = pool.map(ex.local_solve, [x for _, x in named_x])
        seed_results = {name: r for (name, _), r in zip(named_x, seeded, strict=True)}
        template_costs = {name: (r.cost if r.feasible else math.inf)
                          for name, r in seed_results.items()}
        best_template = min(template_costs, key=lambda n: template_costs[n])
        seed_x = dict(named_x)
        seed_schedule = {name: (seed_schedules or {}).get(name) or own[name]
                         for name, _ in named_x}
        # CMA starts from the user's own schedule when one is given (their intent), else from
        # the cheapest template
        x0 = next(iter(seeds.values())) if seeds else seed_x[best_template]
        t_cma, c_cma = time.perf_counter(), time.process_time()
        # 2. basin-CMA over the timings (projection = coarse spacetime solve)
        cma = basin_cma(ex.local_solve, x0, space.sigma0(sigma_fraction), (lo, hi),
                        popsize=popsize,
                        max_generations=max_generations, restarts=restarts,
                        max_local_solves=max_local_solves, seed=seed, executor=pool,
                        callback=on_generation)
        # 3. the cheapest timings, re-solved at full resolution; the first feasible (and
        #    accepted) one wins, else the templates, else the first feasible one (not accepted)
        t_final, c_final = time.perf_counter(), time.process_time()
        n_final = final_candidate_count(pool.records, final_candidates)
        n_final_reason = final_candidates_reason(pool.records, final_candidates)
        tasks, searched, rival = ordered_final_tasks(
            spec, space, pool.records, n_final, (x0, seed_results[best_template]),
            seed_results, seed_schedule if final_check is not None else None,
            final_choice, final_templates, options.half_cycle_solve,
            final_retry_full if final_half_cycle else defaults.FINAL_RETRY_OFF,
            options.swing_wrench)

        def final_planner() -> tuple[GaitPlanner, float, float]:
            """The final planner (passed in, or built here) and its build's wall and CPU s."""
            if planner is not None:
                return planner, 0.0, 0.0
            built = GaitPlanner(robot, n_knots, spec.options)
            return built, time.perf_counter() - t_final, time.process_time() - c_final

        def score(plan: PlanResult) -> float:
            """What the search minimises, at full resolution: how `final_choice` compares."""
            return plan.cost + tipping(plan.schedule)

        if on_workers:
            with ex.ordered(worker_final_solve, tasks) as outcomes:
                # the workers solve the first candidates meanwhile
                final, final_build_s, final_build_cpu_s = final_planner()
                choice = choose_final(tasks, searched, outcomes, final_choice, score, rival)
        else:
            final, final_build_s, final_build_cpu_s = final_planner()
            check = final_check() if final_check is not None else None
            with ex.ordered(lambda task: evaluate_task(final, check, task), tasks) as outcomes:
                choice = choose_final(tasks, searched, outcomes, final_choice, score, rival)
    # the final phase ends when the pool has shut down (workers still solving are stopped)
    t_end, c_end = time.perf_counter(), time.process_time()
    best, won, accepted, fallback = choice.plan, choice.searched, choice.accepted, \
        choice.fallback_template
    final_solves = [(o.plan, o.check_s, o.ok) for o in choice.read]
    schedule = best.schedule
    return GaitSearchResult(
        robot=robot, speed_m_s=speed_m_s, best=best, label=label_gait(schedule, robot),
        template_costs=template_costs, best_template=best_template, search_cost=won.cost,
        search_feasible=won.feasible,
        support_cost=tipping(schedule), tipping_amplification=tipping.amplification(schedule),
        log=tuple(log), cma=cma, elapsed_s=time.perf_counter() - t0,
        cost_of_transport=cost_of_transport(best, robot), search_knots=search_knots,
        accepted=accepted, planner=final, symmetric=symmetric, samples=tuple(pool.records),
        final_solves=tuple(final_solves), fallback_template=fallback,
        final_outcomes=choice.read, final_on_workers=on_workers,
        final_candidates=n_final, final_candidates_reason=n_final_reason,
        final_choice=final_choice, search_half_cycle=search_half_cycle,
        final_half_cycle=final_half_cycle, final_templates=final_templates,
        final_retry_full=final_retry_full,
        final_retried=choice.retried,
        final_retry_reason=choice.retry_reason,
        beaten_search_total=choice.beaten_score,
        phase_s={"seed": t_cma - t_seed, "cma": t_final - t_cma, "final_build": final_build_s,
                 "final": t_end - t_final - (0.0 if on_workers else final_build_s)},
        phase_cpu_s={"seed": c_cma - c_seed, "cma": c_final - c_cma,
                     "final_build": final_build_cpu_s,
                     "final": c_end - c_final - final_build_cpu_s,
                     "total": time.process_time() - c0},
    )


def final_options(options: PlannerOptions,
                  final_half_cycle: bool = defaults.FINAL_HALF_CYCLE,
                  final_swing_wrench: str | None = defaults.FINAL_SWING_WRENCH
                  ) -> PlannerOptions:
    """The options of the search's final re-solves: `options` with `final_half_cycle` as their
    `PlannerOptions.half_cycle_solve` and `final_swing_wrench` (None: the options' own) as their
    `swing_wrench` (a final planner built outside `search_gait`, e.g.
    `planner.search.speed_sweep`'s, must be built with these)."""
    return replace(options, half_cycle_solve=final_half_cycle,
                   swing_wrench=final_swing_wrench or options.swing_wrench)


def final_tasks(spec: FinalPlannerSpec, space: TimingSpace,
                records: Iterable[tuple[np.ndarray, LocalResult]], final_candidates: int,
                start: tuple[np.ndarray, LocalResult], seed_results: Mapping[str, LocalResult],
                seed_schedules: Mapping[str, ContactSchedule] | None,
                read_first: int | None = None, template_half_cycle: bool | None = None,
                retry_full: str = defaults.FINAL_RETRY_OFF,
                template_swing_wrench: str | None = None,
                ) -> tuple[list[FinalTask], list[LocalResult]]:
    """The final phase's tasks in the order `choose_final` reads them, with the search result of
    each one's timing: the `final_candidates` cheapest usable samples of `records`
    (`final_candidates_of`; `start`, CMA's first mean and its seed's result, if none is usable),
    then, when `seed_schedules` is given (a final check exists), the seeds ranked as the
    candidates are (`final_rank`: until session 34 every seed the coarse check rejected tied
    at an infinite cost and came in template order), as their own schedules, skipping any
    identical to a candidate — to one of the first `read_first` candidates if given (those the
    final choice always reads: `templates_read_first`), each solved with `template_half_cycle`
    and `template_swing_wrench` (`FinalTask.half_cycle`, `.swing_wrench`; `search_gait` passes
    its options' own, so a template is planned as `gaitsmith plan ROBOT --gait NAME` plans it);
    the candidates with `retry_full`
    (`FinalTask.retry_full`, `search_gait(final_retry_full=)`). A search stopped after
    generation k is its recording truncated there (`benchmarks/search_outcomes.py replay`)."""
    candidates = final_candidates_of(records, final_candidates) or [start]
    tasks = [FinalTask(spec, space.decode(x), retry_full=retry_full) for x, _ in candidates]
    searched: list[LocalResult] = [r for _, r in candidates]
    if seed_schedules is not None:
        # nothing searched may pass: the templates the search started from, at full
        # resolution, as the template command plans them (not their phase-rotated encodings)
        # ranked as the candidates are (`final_rank`): a template the coarse check rejected
        # but whose plan solved comes before one with no plan, the cheaper first
        tried = [task.schedule for task in tasks[:read_first]]
        for name in sorted(seed_results, key=lambda n: final_rank(seed_results[n])):
            own_schedule = seed_schedules[name]
            if not any(identical_schedules(own_schedule, t) for t in tried):
                tasks.append(FinalTask(spec, own_schedule, name, template_half_cycle,
                                       swing_wrench=template_swing_wrench))
                searched.append(seed_results[name])
    return tasks, searched


def templates_read_first(final_choice: str, final_templates: str, n_candidates: int
                         ) -> int | None:
    """`final_tasks(read_first=)`: with "compete" a template is skipped only when it is identical
    to a candidate the choice always reads; one identical to a later candidate is a rival like
    the others (`compete_order` drops that candidate instead). Skipping it (session 37) let the
    README search at seed 0 with half-cycle coarse solves write a 0.720 trot over the 0.631
    trot template, its fourth candidate, which was never read. None: any candidate."""
    if final_templates != defaults.FINAL_TEMPLATES_COMPETE:
        return None
    return compared_candidates(final_choice, n_candidates)


#: which templates compete with the searched winner (`final_phase.choose_final(rival=)`)
Rival = Callable[[LocalResult], bool]


def final_order(tasks: list[FinalTask], searched: list[LocalResult], final_choice: str,
                final_templates: str
                ) -> tuple[list[FinalTask], list[LocalResult], Rival | None]:
    """`final_tasks`' tasks in the order `choose_final` reads them under `final_templates`, and
    its `rival` (None: "fallback", the order unchanged). "compete" takes every template with a
    coarse plan: also those the coarse check rejected (spotmicro's trot template fails it at 12
    knots and passes at 30; with only the accepted ones "compete" changed none of 32 replayed
    searches, docs/results/planner_speed_search.md, session 37)."""
    if final_templates != defaults.FINAL_TEMPLATES_COMPETE:
        return tasks, searched, None
    return (*compete_order(tasks, searched, final_choice, coarse_plan_solved), coarse_plan_solved)


def ordered_final_tasks(spec: FinalPlannerSpec, space: TimingSpace,
                        records: Iterable[tuple[np.ndarray, LocalResult]],
                        final_candidates: int, start: tuple[np.ndarray, LocalResult],
                        seed_results: Mapping[str, LocalResult],
                        seed_schedules: Mapping[str, ContactSchedule] | None,
                        final_choice: str, final_templates: str,
                        template_half_cycle: bool | None = None,
                        retry_full: str = defaults.FINAL_RETRY_OFF,
                        template_swing_wrench: str | None = None,
                        ) -> tuple[list[FinalTask], list[LocalResult], Rival | None]:
    """The final phase's tasks, their search results and `rival` as `choose_final` reads them
    under `final_choice` and `final_templates`: `final_tasks` (skipping the templates
    `templates_read_first` says) in `final_order`. The search and its replay
    (`benchmarks/search_outcomes.py`) both build them here, so the two cannot part."""
    tasks, searched = final_tasks(
        spec, space, records, final_candidates, start, seed_results, seed_schedules,
        templates_read_first(final_choice, final_templates, final_candidates),
        template_half_cycle, retry_full, template_swing_wrench)
    return final_order(tasks, searched, final_choice, final_templates)


def write_search_log(result: GaitSearchResult, path: str | Path) -> None:
    """CSV: one row per generation (best cost, mean schedule, its gait label)."""
    from robots.gait import atomic_write_text

    feet = result.robot.foot_names
    head = ["generation", "best_cost", "generation_best_cost", "n_feasible", "n_local_solves",
            "elapsed_s", "period_s", *[f"phase_{f}" for f in feet], *[f"duty_{f}" for f in feet],
            "gait_label"]
    lines = [",".join(head)]
    for r in result.log:
        cells = [r.generation, f"{r.best_cost:.6g}", f"{r.generation_best_cost:.6g}", r.n_feasible,
                 r.n_local_solves, f"{r.elapsed_s:.2f}", f"{r.period_s:.4f}",
                 *[f"{p:.4f}" for p in r.touchdown_phase], *[f"{d:.4f}" for d in r.duty_factor],
                 r.gait_label]
        lines.append(",".join(str(c) for c in cells))
    for name, cost in result.template_costs.items():
        lines.append(f"# template {name}: search cost {cost:.6g}")
    winner = {defaults.FINAL_CHOICE_FIRST: "the first accepted in coarse rank order",
              defaults.FINAL_CHOICE_CHEAPEST_OF_2: "the cheaper accepted of the first two at "
              "full resolution (else the first accepted after them)",
              defaults.FINAL_CHOICE_CHEAPEST: "the accepted one cheapest at full resolution",
              }.get(result.final_choice, result.final_choice)
    rivals = (" against the cheapest accepted template (the cheaper is written)"
              if result.final_templates == defaults.FINAL_TEMPLATES_COMPETE else "")
    lines.append(f"# final phase: up to {result.final_candidates} searched timings re-solved "
                 f"at full resolution ({result.final_candidates_reason}); {winner} wins"
                 f"{rivals}")
    lines.append(f"# search: {result.search_knots} knots"
                 + (" (symmetric samples on the first half of them, `half_cycle`)"
                    if result.search_half_cycle else "") + "; winner search cost "
                 f"{result.search_cost:.6g} (support term {result.support_cost:.6g}, open-loop "
                 f"tipping amplification {result.tipping_amplification:.4g})")
    # how the written plan was solved: a candidate as `final_half_cycle` says, a template as
    # the template path (`final_tasks(template_half_cycle=)`), on half the knots where it fits
    lines.append(f"# final solve: {result.planner.n_knots} knots"
                 + (" (a symmetric timing on the first half of them, `half_cycle`)"
                    if result.best.stats.get("half_cycle") else
                    f" (full cycle, a retry: its half-cycle plan failed, "
                    f"{result.final_retry_reason})" if result.final_retried
                    else " (full cycle)")
                 + f", {result.label}, cost "
                 f"{result.best.cost:.6g} + support {result.support_cost:.6g} = "
                 f"{result.total_cost:.6g}, feasible {result.best.feasible}, accepted "
                 f"{'-' if result.accepted is None else result.accepted}")
    atomic_write_text(path, "\n".join(lines) + "\n")


__all__ = [
    "DEFAULT_SEARCH_KNOTS",
    "DEFAULT_SEARCH_MAX_ITER",
    "DEFAULT_SIGMA_FRACTION",
    "DEFAULT_TIPPING_WEIGHT",
    "FINAL_CANDIDATES",
    "FINAL_CANDIDATES_NONE_ACCEPTED",
    "SEARCH_WARM_STARTS",
    "AcceptanceVerdict",
    "GaitAcceptance",
    "GaitSearchResult",
    "RecordingExecutor",
    "SearchLogRow",
    "TimingResult",
    "TimingSolver",
    "TimingSolverFactory",
    "TimingSpace",
    "coarse_plan_solved",
    "cost_of_transport",
    "final_options",
    "final_order",
    "final_rank",
    "final_tasks",
    "ordered_final_tasks",
    "search_gait",
    "searchable_templates",
    "templates_read_first",
    "write_search_log",
]

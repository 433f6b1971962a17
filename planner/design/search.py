"""Basin-CMA over the body (W&P 2009 §3.6 and §4.1.2: morphology "managed in the outer loop").

W&P note that adding the morphological variables to the spacetime NLP "sometimes causes the
spacetime optimization to fail", and that the fix is to let basin-CMA choose them and hold them
fixed in each sampled spacetime solve. That is what this module does: every CMA sample is a body
(`planner.design.body`: a length scale per link group, a servo model per joint group); its
projection is the spacetime solve of the default gait template for the leg count at the design
speed on that body (`GaitPlanner`, warm-started from the incumbent — the best feasible body so
far — and re-solved cold if the warm start ends infeasible). The NLP cannot move the body, so the
projection leaves the scales where they are and snaps each servo variable to its candidate index
(`DesignSpace.snap`); the CMA update uses those projected points (Lamarckian, W&P eqs 26-27).

Objective (documented weight): ``J = planner cost + w_m · m / m₀``. The planner cost is the
spacetime objective (W&P eqs 13-16) whose effort term is Σ(τ/τ_stall)² of each joint's own
servo, so a weaker servo or a longer lever costs what it really costs; a body's mass enters its
dynamics there too (heavier legs need more torque). The second term charges the mass carried
itself (battery life, parts, the mass the robot must be lifted with), m₀ the original robot's
mass, ``w_m = DEFAULT_MASS_WEIGHT``: a body 10 % heavier pays 0.01·(w_m/0.1), about 2 % of
quad12's trot cost at 0.35 m/s (0.62 at 16 knots). Infeasible samples rank below every feasible
one (by constraint violation, `BasinCma.rank`). Servos that share no supply voltage range cannot
run on one battery: such samples are redrawn before any solve (`supplied_samples`), and a
sample that still has them is infeasible without a solve (violation: the gap in volts).

Acceptance (optional, `acceptance=`, as in `planner.search.gait_search`): a picklable factory of
a check (body, gait) → verdict; a feasible sample it rejects ranks as infeasible. The command line
passes MuJoCo's (the body stands on its servos and the gait walks under the servo model), so
the search can prefer bodies that walk over bodies that only satisfy the NLP; `planner` never
imports `sim`.

Samples run on `planner.search.executors` (serial, process pool, Ray): each worker builds its
`DesignSolver` once, writes each sample's robot folder into a temporary folder of its own and
builds that body's NLP (the NLP is built per robot; it takes most of a sample's time).
"""

from __future__ import annotations

import math
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np

from planner.design.body import BodyDesign, DesignError, DesignSpace, describe, write_design
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, PlanResult, WarmStart
from planner.search.basin_cma import BasinCma, LocalResult
from planner.search.executors import make_executor
from planner.search.gait_search import DEFAULT_SIGMA_FRACTION, REJECTED_VIOLATION
from planner.templates import default_gait_for, make_schedule
from robots import Gait, Robot
from robots import load as load_robot

DEFAULT_MASS_WEIGHT = 0.1
DEFAULT_KNOTS = 16
DEFAULT_GENERATIONS = 3
#: Initial CMA spread (a fraction of each box width, W&P §5) and the violation of a feasible
#: sample that fails acceptance: the gait search's own, so bodies and timings rank alike.
SIGMA_FRACTION = DEFAULT_SIGMA_FRACTION


class BodyVerdict(Protocol):
    @property
    def passed(self) -> bool: ...

    @property
    def badness(self) -> float: ...

    @property
    def reasons(self) -> tuple[str, ...]: ...


#: A check of a designed body and its planned gait (the CLI passes MuJoCo's: stand + walk).
BodyCheck = Callable[[Robot, Gait], BodyVerdict]


@dataclass(frozen=True, eq=False)
class DesignTask:
    """What a worker gets for one sample: the CMA point and the incumbent's solution."""

    x: np.ndarray
    warm_start: WarmStart | None = None


@dataclass(frozen=True, eq=False)
class DesignSample(LocalResult):
    """One projected sample: the body, its objective split, and the solve's facts."""

    design: BodyDesign = field(default_factory=lambda: BodyDesign((), ()))
    planner_cost: float = math.nan
    effort: float = math.nan
    mass_kg: float = math.nan
    leg_length_m: float = math.nan
    peak_torque_ratio: float = math.nan  # max over knots and joints of |τ|/τ_stall
    binding: tuple[tuple[str, float], ...] = ()
    message: str = ""
    iterations: int = 0
    solve_time_s: float = 0.0
    warm_start: WarmStart | None = None


def peak_torque_ratio(result: PlanResult, robot: Robot) -> float:
    stall = np.array([j.servo.stall_torque_nm for j in robot.joints])
    return float(np.max(np.abs(result.joint_torques_nm) / stall))


def plan_body(body: Robot, gait: str, speed_m_s: float, n_knots: int, options: PlannerOptions,
              warm_start: WarmStart | None = None, *, background_compile: bool = True
              ) -> tuple[GaitPlanner, PlanResult]:
    """The default-template gait of `body` at `speed_m_s` (period from the body's leg length,
    `planner.templates.default_period_s`): warm-started from `warm_start`, cold if that ends
    infeasible (or none is given). `background_compile`: `GaitPlanner`'s (off for the search's
    samples: bodies no later command plans)."""
    planner = GaitPlanner(body, n_knots, options, background_compile=background_compile)
    schedule = make_schedule(body, gait)
    result: PlanResult | None = None
    if warm_start is not None and warm_start.x.shape == (planner.layout.size,):
        result = planner.solve(schedule, speed_m_s, warm_start)
    if result is None or not result.feasible:
        cold = planner.solve(schedule, speed_m_s, warm_start=False)
        if result is None or cold.feasible or cold.max_violation < result.max_violation:
            result = cold
    return planner, result


def objective(result: PlanResult, body: Robot, reference_mass_kg: float,
              mass_weight: float) -> float:
    """J = planner cost + w_m · m / m₀ (module docstring)."""
    return float(result.cost) + mass_weight * body.mass_kg / reference_mass_kg


def sample_of(x: np.ndarray, design: BodyDesign, body: Robot, result: PlanResult,
              reference_mass_kg: float, mass_weight: float) -> DesignSample:
    """The sample record of `body`'s solve."""
    return DesignSample(
        x, objective(result, body, reference_mass_kg, mass_weight), result.feasible,
        int(result.iterations) + 1, float(result.max_violation), design=design,
        planner_cost=float(result.cost), effort=float(result.cost_terms.get("effort", math.nan)),
        mass_kg=body.mass_kg, leg_length_m=body.leg_length_m,
        peak_torque_ratio=peak_torque_ratio(result, body), binding=result.binding,
        message=result.message, iterations=int(result.iterations),
        solve_time_s=float(result.solve_time_s),
        warm_start=result.warm_start if result.feasible else None)


@dataclass
class DesignSolver:
    """The local solve of the design search (built once per worker)."""

    robot: Robot
    space: DesignSpace
    gait: str
    speed_m_s: float
    n_knots: int
    options: PlannerOptions
    reference_mass_kg: float
    mass_weight: float
    acceptance: BodyCheck | None = None

    def __call__(self, task: DesignTask) -> DesignSample:
        x = self.space.snap(task.x)
        design = self.space.decode(x)
        lo, hi = self.space.supply_range_v(design)
        if lo > hi:
            return DesignSample(x, math.inf, False, 0, lo - hi, design=design,
                                message=f"no common supply voltage ({describe(self.space, design)}"
                                        f": {lo:g} V minimum above {hi:g} V maximum)",
                                binding=(("supply voltage", lo - hi),))
        with tempfile.TemporaryDirectory(prefix="gaitsmith-design-") as tmp:
            try:
                body = write_design(self.robot, self.space, design, Path(tmp) / "body",
                                    f"{self.robot.name}_sample")
                planner, result = plan_body(body, self.gait, self.speed_m_s, self.n_knots,
                                            self.options, task.warm_start,
                                            background_compile=False)
            except (DesignError, PlannerConfigError) as exc:
                return DesignSample(x, math.inf, False, 0, math.inf, design=design,
                                    message=str(exc), binding=(("body", math.inf),))
            sample = sample_of(x, design, body, result, self.reference_mass_kg, self.mass_weight)
            if not (sample.feasible and self.acceptance is not None):
                return sample
            verdict = self.acceptance(body, planner.to_gait(result, self.gait))
            if verdict.passed:
                return sample
            return replace(sample, feasible=False,
                           violation=REJECTED_VIOLATION * (1.0 + verdict.badness),
                           binding=(("MuJoCo acceptance", verdict.badness),),
                           message="planned, but in MuJoCo: " + "; ".join(verdict.reasons),
                           warm_start=None)


@dataclass(frozen=True)
class DesignSolverFactory:
    """Picklable factory of `DesignSolver` (one per executor worker)."""

    robot_dir: str
    space: DesignSpace
    gait: str
    speed_m_s: float
    n_knots: int
    options: PlannerOptions
    reference_mass_kg: float
    mass_weight: float
    acceptance: Callable[[], BodyCheck] | None = None

    def __call__(self) -> DesignSolver:
        check = self.acceptance() if self.acceptance is not None else None
        return DesignSolver(load_robot(self.robot_dir), self.space, self.gait, self.speed_m_s,
                            self.n_knots, self.options, self.reference_mass_kg, self.mass_weight,
                            check)


@dataclass(frozen=True)
class GenerationRow:
    """Progress after one generation."""

    generation: int
    n_samples: int
    n_feasible: int
    best_cost: float  # best design cost of the samples so far (inf: no feasible body yet)
    best: str  # `describe` of that body
    elapsed_s: float


@dataclass(frozen=True, eq=False)
class DesignResult:
    """A finished search: the original body as solved in the same run, every sample, the best."""

    robot: Robot
    space: DesignSpace
    gait: str
    speed_m_s: float
    n_knots: int
    mass_weight: float
    original: DesignSample
    original_plan: PlanResult
    original_planner: GaitPlanner
    samples: tuple[DesignSample, ...]
    history: tuple[GenerationRow, ...]
    elapsed_s: float

    def ranked(self) -> list[DesignSample]:
        """Samples best first: feasible by cost, then infeasible by violation."""
        def key(s: DesignSample) -> tuple[int, float]:
            return (0, s.cost) if s.feasible else (1, s.violation)
        return sorted(self.samples, key=key)

    def best_feasible(self, k: int) -> list[DesignSample]:
        """Up to k feasible samples of distinct bodies, best first."""
        out: list[DesignSample] = []
        for s in self.ranked():
            if s.feasible and all(s.design != o.design for o in out):
                out.append(s)
            if len(out) == k:
                break
        return out

    def limits(self) -> list[tuple[str, int]]:
        """The most binding limit of each infeasible sample, counted (most frequent first)."""
        counts = Counter(s.binding[0][0] if s.binding else "solver" for s in self.samples
                         if not s.feasible)
        return counts.most_common()


#: Redraws of a generation's samples whose servos share no supply voltage (they cost no solve).
MAX_SUPPLY_REDRAWS = 50


def supplied_samples(cma: BasinCma, space: DesignSpace) -> np.ndarray:
    """λ samples whose servos share a supply voltage, by resampling (Hansen's resampling of
    infeasible points: the supply constraint is known without a solve); after
    `MAX_SUPPLY_REDRAWS` draws the rest are taken as they come (they rank as infeasible)."""
    kept: list[np.ndarray] = []
    for _ in range(MAX_SUPPLY_REDRAWS):
        for x in cma.ask():
            lo, hi = space.supply_range_v(space.decode(x))
            if lo <= hi:
                kept.append(x)
        if len(kept) >= cma.popsize:
            return np.array(kept[: cma.popsize])
    return np.array((kept + list(cma.ask()))[: cma.popsize])


def design_body(
    robot: Robot,
    speed_m_s: float,
    space: DesignSpace,
    *,
    n_knots: int = DEFAULT_KNOTS,
    options: PlannerOptions | None = None,
    mass_weight: float = DEFAULT_MASS_WEIGHT,
    generations: int = DEFAULT_GENERATIONS,
    popsize: int | None = None,
    seed: int = 0,
    executor: str = "serial",
    workers: int | None = None,
    address: str | None = None,
    progress: Callable[[GenerationRow], None] | None = None,
    on_original: Callable[[DesignSample], None] | None = None,
    acceptance: Callable[[], BodyCheck] | None = None,
) -> DesignResult:
    """Basin-CMA over `space` at `speed_m_s` (module docstring); the original robot is solved
    first, in this process, as the baseline and the first incumbent. `acceptance` (a picklable
    factory, built once per worker) judges every feasible sample's body and gait; one it
    rejects ranks as infeasible (after the accepted ones)."""
    if not math.isfinite(mass_weight) or mass_weight < 0:
        raise PlannerConfigError(f"mass weight must be ≥ 0, got {mass_weight!r}")
    if generations < 1:
        raise PlannerConfigError(f"generations must be ≥ 1, got {generations}")
    t0 = time.perf_counter()
    options = options or PlannerOptions()
    gait = default_gait_for(robot)
    planner, plan = plan_body(robot, gait, speed_m_s, n_knots, options)
    x0 = space.encode(space.original())
    original = sample_of(x0, space.original(), robot, plan, robot.mass_kg, mass_weight)
    if on_original is not None:
        on_original(original)
    factory = DesignSolverFactory(str(robot.root_dir), space, gait, speed_m_s, n_knots, options,
                                  robot.mass_kg, mass_weight, acceptance)
    lo, hi = space.bounds()
    cma = BasinCma(x0, (hi - lo) * SIGMA_FRACTION, (lo, hi), popsize=popsize,
                   rng=np.random.default_rng(seed))
    # the incumbent warm-starts the samples (the original until a sample beats it); `best` is
    # what the progress reports: samples only, since the original was not judged by `acceptance`
    incumbent: DesignSample | None = original if original.feasible else None
    best: DesignSample | None = None
    samples: list[DesignSample] = []
    history: list[GenerationRow] = []
    with make_executor(executor, factory, workers=workers, address=address) as ex:  # type: ignore[arg-type]
        for generation in range(generations):
            xs = supplied_samples(cma, space)
            warm = incumbent.warm_start if incumbent is not None else None
            results: list[DesignSample] = ex.map(ex.local_solve,
                                                 [DesignTask(x, warm) for x in xs])
            samples.extend(results)
            cma.tell(np.array([r.x_projected for r in results]), [r.cost for r in results],
                     [r.feasible for r in results], [r.violation for r in results])
            for r in results:
                if r.feasible and (incumbent is None or r.cost < incumbent.cost):
                    incumbent = r
                if r.feasible and (best is None or r.cost < best.cost):
                    best = r
            row = GenerationRow(
                generation, len(results), sum(r.feasible for r in results),
                best.cost if best is not None else math.inf,
                describe(space, best.design) if best is not None else "-",
                time.perf_counter() - t0)
            history.append(row)
            if progress is not None:
                progress(row)
    return DesignResult(robot, space, gait, speed_m_s, n_knots, mass_weight, original, plan,
                        planner, tuple(samples), tuple(history), time.perf_counter() - t0)


def servos_alone(result: DesignResult, sample: DesignSample) -> DesignSample | None:
    """The original link lengths with `sample`'s servos, solved like a sample: splits what the
    servo choice bought from what the lengths bought (None if that body is the sample's or the
    original's)."""
    original = result.space.original()
    body = BodyDesign(original.scales, sample.design.servos)
    if body in (sample.design, original):
        return None
    solver = DesignSolverFactory(str(result.robot.root_dir), result.space, result.gait,
                                 result.speed_m_s, result.n_knots,
                                 result.original_planner.options, result.robot.mass_kg,
                                 result.mass_weight)()
    return solver(DesignTask(result.space.encode(body), result.original.warm_start))


__all__ = [
    "DEFAULT_GENERATIONS",
    "DEFAULT_KNOTS",
    "DEFAULT_MASS_WEIGHT",
    "REJECTED_VIOLATION",
    "BodyCheck",
    "BodyVerdict",
    "DesignResult",
    "DesignSample",
    "DesignSolver",
    "DesignSolverFactory",
    "DesignTask",
    "GenerationRow",
    "design_body",
    "objective",
    "peak_torque_ratio",
    "plan_body",
    "servos_alone",
]

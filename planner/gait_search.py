"""Search contact timings with basin-CMA and let the gait emerge from the speed (W&P 2009 §4-5).

The outer search runs over the timing variables only — period, per-foot touchdown phase and duty
factor — which W&P §4.1.2 mark "CMA only": the spacetime NLP (`GaitPlanner`) cannot change
them, so its projection leaves them where they are (``x_projected = x``) and optimises every
other variable (poses, forces) for that timing. Basin-CMA then searches f∘g over the timings.

Encoding (`TimingSpace`): the touchdown phase of the first foot is pinned to 0 (a cycle has no
preferred start, so a global phase shift is not a degree of freedom). With ``symmetric=True``
(the default) each right leg runs half a period after its left mirror with the same duty factor
— the left/right half-period symmetry of walk, trot and pace, which halves the search; bound,
gallop and pronk need ``symmetric=False``. Phases are searched on an unwrapped interval and
wrapped modulo 1 when decoded.

The search starts from the hand templates: every template that fits the encoding is solved
first, and the best becomes the initial CMA mean — so the search result is never worse than the
best template and, where timing matters, better.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from planner.basin_cma import BasinCmaResult, GenerationReport, LocalResult, basin_cma
from planner.config import PlannerOptions
from planner.errors import PlannerConfigError
from planner.executors import make_executor
from planner.spacetime import GaitPlanner, PlanResult
from planner.templates import label_gait, leg_roles, make_schedule, templates_for
from robots import ContactSchedule, Robot
from robots import load as load_robot

#: Period bounds in units of √(L/g) (dynamic similarity, Murphy et al. 2008 / Alexander).
PERIOD_BOUNDS_SQRT_L_G = (2.0, 9.0)
DUTY_BOUNDS = (0.35, 0.9)


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
        unit = math.sqrt(robot.leg_length_m / 9.81)
        bounds = (PERIOD_BOUNDS_SQRT_L_G[0] * unit, PERIOD_BOUNDS_SQRT_L_G[1] * unit)
        n = len(robot.legs)
        if symmetric:
            roles = leg_roles(robot)
            left = sorted((r for r in roles if r.startswith("L")), key=lambda r: roles[r])
            searched = tuple(roles[r] for r in left)
            mirror = tuple(roles["R" + r[1:]] for r in left)
        else:
            searched, mirror = tuple(range(n)), ()
        return TimingSpace(robot.foot_names, mirror, searched, symmetric, bounds)

    @property
    def dim(self) -> int:
        return 1 + (len(self.searched) - 1) + len(self.searched)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        k = len(self.searched)
        lo = np.r_[self.period_bounds_s[0], np.full(k - 1, -0.5), np.full(k, DUTY_BOUNDS[0])]
        hi = np.r_[self.period_bounds_s[1], np.full(k - 1, 1.5), np.full(k, DUTY_BOUNDS[1])]
        return lo, hi

    def sigma0(self) -> np.ndarray:
        """Initial standard deviations: a third of each box width (W&P §5 cover the box)."""
        lo, hi = self.bounds()
        return (hi - lo) / 3.0

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
            for left, right in zip(self.searched, self.mirror, strict=True):
                if abs(((rel[right] - rel[left] - 0.5 + 0.5) % 1.0) - 0.5) > 1e-9 \
                        or abs(du[right] - du[left]) > 1e-9:
                    return None
        s = list(self.searched)
        return np.r_[schedule.period_s, rel[s[1:]], du[s]].astype(float)


def cost_of_transport(result: PlanResult, robot: Robot) -> float:
    """Mechanical cost of transport Σ|τ·q̇| / (m g v), averaged over the cycle (∞ at v = 0)."""
    power = np.abs(result.joint_torques_nm * result.joint_speeds_rad_s)
    power_w = float(np.mean(np.sum(power, axis=1)))
    if result.speed_m_s <= 0:
        return math.inf
    return power_w / (robot.mass_kg * 9.81 * result.speed_m_s)


@dataclass
class TimingSolver:
    """The local solve g(x) of basin-CMA: one spacetime solve for the decoded timing."""

    planner: GaitPlanner
    space: TimingSpace
    speed_m_s: float

    def __call__(self, x: np.ndarray) -> LocalResult:
        x = np.clip(np.asarray(x, dtype=float), *self.space.bounds())
        schedule = self.space.decode(x)
        try:
            # cold start: on a new contact timing a warm start costs more iterations than it
            # saves (planner_bench: warm/cold 1.49), and cold solves make every sample's cost
            # independent of which samples a worker solved before (executor-invariant search)
            result = self.planner.solve(schedule, self.speed_m_s, warm_start=False)
        except PlannerConfigError:  # e.g. a foot never lands on any knot
            return LocalResult(x, math.inf, False, 0, math.inf)
        evals = int(result.iterations) + 1
        return LocalResult(x, result.cost, result.feasible, evals, result.max_violation)


@dataclass(frozen=True)
class TimingSolverFactory:
    """Picklable factory: each executor worker builds its GaitPlanner once (W&P §5)."""

    robot_dir: str
    n_knots: int
    speed_m_s: float
    symmetric: bool
    options: PlannerOptions = field(default_factory=PlannerOptions)

    def __call__(self) -> TimingSolver:
        robot = load_robot(self.robot_dir)
        planner = GaitPlanner(robot, self.n_knots, self.options)
        return TimingSolver(planner, TimingSpace.for_robot(robot, self.symmetric), self.speed_m_s)


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
    robot: Robot
    speed_m_s: float
    best: PlanResult
    label: str
    template_costs: dict[str, float]  # template → cost (inf if infeasible)
    best_template: str
    log: tuple[SearchLogRow, ...]
    cma: BasinCmaResult
    elapsed_s: float
    cost_of_transport: float
    planner: GaitPlanner  # the main process's planner (builds the gait file from `best`)

    @property
    def froude(self) -> float:
        return self.speed_m_s**2 / (9.81 * self.robot.leg_length_m)


def search_gait(
    robot: Robot,
    speed_m_s: float,
    *,
    n_knots: int = 30,
    options: PlannerOptions | None = None,
    symmetric: bool = True,
    max_generations: int = 6,
    popsize: int | None = None,
    restarts: int = 0,
    max_local_solves: int | None = None,
    seed: int = 0,
    executor: str = "serial",
    workers: int | None = None,
    address: str | None = None,
    planner: GaitPlanner | None = None,
    progress: Callable[[SearchLogRow], None] | None = None,
) -> GaitSearchResult:
    """The best contact timing for `robot` at `speed_m_s`: basin-CMA seeded by the templates."""
    t0 = time.perf_counter()
    options = options or PlannerOptions()
    space = TimingSpace.for_robot(robot, symmetric)
    local = planner or GaitPlanner(robot, n_knots, options)
    solver = TimingSolver(local, space, speed_m_s)

    # 1. seed with the hand templates that fit the encoding
    template_costs: dict[str, float] = {}
    if progress is not None:
        progress(SearchLogRow(-1, math.inf, math.inf, 0, 0, time.perf_counter() - t0, 0.0, (), (),
                              "seeding with the templates"))
    seeds: list[tuple[float, np.ndarray, str]] = []
    for name in templates_for(robot):
        x = space.encode(make_schedule(robot, name))
        if x is None:
            continue
        r = solver(x)
        template_costs[name] = r.cost if r.feasible else math.inf
        seeds.append((template_costs[name], x, name))
    if not seeds:
        raise PlannerConfigError(f"no template of {robot.name} fits the search encoding")
    seeds.sort(key=lambda s: s[0])
    best_template_cost, x0, best_template = seeds[0]

    # 2. basin-CMA over the timings (projection = spacetime solve)
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
    factory = TimingSolverFactory(str(robot.root_dir), n_knots, speed_m_s, symmetric, options)
    if executor == "serial":
        cma = basin_cma(solver, x0, space.sigma0(), (lo, hi), popsize=popsize,
                        max_generations=max_generations, restarts=restarts,
                        max_local_solves=max_local_solves, seed=seed, callback=on_generation)
    else:
        with make_executor(executor, factory, workers=workers, address=address) as ex:  # type: ignore[arg-type]
            cma = basin_cma(ex.local_solve, x0, space.sigma0(), (lo, hi), popsize=popsize,  # type: ignore[attr-defined]
                            max_generations=max_generations, restarts=restarts,
                            max_local_solves=max_local_solves, seed=seed, executor=ex,
                            callback=on_generation)

    # 3. the winner (template or CMA point), re-solved here for its full trajectories
    x_best = cma.x if cma.feasible and cma.cost < best_template_cost else x0
    best = local.solve(space.decode(x_best), speed_m_s, warm_start=False)
    label = label_gait(best.schedule, robot)
    return GaitSearchResult(
        robot=robot, speed_m_s=speed_m_s, best=best, label=label, template_costs=template_costs,
        best_template=best_template, log=tuple(log), cma=cma, elapsed_s=time.perf_counter() - t0,
        cost_of_transport=cost_of_transport(best, robot), planner=local,
    )


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
        lines.append(f"# template {name}: cost {cost:.6g}")
    atomic_write_text(path, "\n".join(lines) + "\n")


__all__ = [
    "GaitSearchResult",
    "SearchLogRow",
    "TimingSolver",
    "TimingSolverFactory",
    "TimingSpace",
    "cost_of_transport",
    "search_gait",
    "write_search_log",
]

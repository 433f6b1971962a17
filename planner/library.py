"""Build a gait library: one schedule family planned over a grid of commands (issue #15 item 2).

A *use* of `planner.nlp` (one `GaitPlanner` per worker, warm-started between neighbouring
commands) and `planner.search.executors` (process pool or Ray). The MuJoCo validation is passed
in by the caller as a picklable factory (`ValidatorFactory`), so the planner never imports
`sim` — the command line wires it (`gaitsmith.library_cmd`), as `gaitsmith/search_options.py`
does for the search's acceptance check.

Default grid (`default_grid`), from the robot's size only:

- forward speeds vx ∈ {−v/2, 0, v/2, v} with v = `default_speed_m_s(L)`, the Froude-law speed
  of the leg length L (`planner.nlp.config`: Fr = 0.035, 0.25 m/s at L = 0.18 m);
- yaw rates W ∈ {−w, 0, w} with w·r = v/2: the stance feet, at radius r about the body centre
  (mean horizontal distance of the nominal-stance feet), sweep at half the top forward speed;
  capped at the command line's yaw bound (0.5·√(g/L)) and a quarter of the planner's turn per
  period (`planner.nlp.command.MAX_TURN_PER_PERIOD_RAD`);
- vy ∈ {0}: side-steps only when asked (`vy_m_s=…`; each vy value triples the grid).

Every entry uses the same schedule family (`default_gait_for` unless given) and one period and
duty factor (the template's, or those chosen with the family: `gaitsmith library` asks
`gaitsmith.gait_choice.grid_gait`, which gives a turning trotter grid the static walk of
`commanded_gait` for every entry; the period law is constant), and is written with the
*template's* phase origin:
`GaitPlanner.to_gait` starts each cycle at its most rest-like knot, which differs between
commands, so the entry is rotated back (`align_phase`) — the library's entries must share one
phase origin to be blended at equal phase (`robots.blend`).

Warm starts: the grid is solved in waves of a breadth-first walk from the command nearest zero;
each entry starts IPOPT from a feasible neighbour of the previous wave (one grid step away), the
first one cold. Entries of one wave run in parallel on the executor. Measured on hex18 (N = 30,
one process): the neighbour's primal point did not save iterations — (0.096, 0, 0) took 33
iterations warm from (0, 0, 0) against 18 cold, (0, 0, 0.386) 27 against 26, same optima — so
`warm_start=False` (one batch, every worker busy) is offered too. An entry whose plan is
infeasible, whose validation fails, or whose worker raised is reported (command, reason) and left
out; the stand (the nominal stance, every foot down) is validated too.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

import numpy as np

from planner.errors import PlannerConfigError, PlannerError
from planner.nlp.command import MAX_TURN_PER_PERIOD_RAD, check_command
from planner.nlp.config import GRAVITY_M_S2, PlannerOptions, default_speed_m_s
from planner.nlp.cycle_start import rotate_schedule
from planner.nlp.spacetime import GaitPlanner, WarmStart
from planner.search.executors import make_executor, worker_local_solve
from planner.templates import default_gait_for, make_schedule, stance_foot_positions_m
from robots import ContactSchedule, Gait, Robot, Velocity
from robots import load as load_robot
from robots.library import GaitLibrary, LibraryEntry, velocity_tuple

#: the command line's yaw bound in √(g/L) (gaitsmith.options.MAX_YAW_RATE_SQRT_G_PER_L)
MAX_YAW_RATE_SQRT_G_PER_L = 0.5
MIN_ENTRIES = 2  # fewer surviving walking entries than this (or than the grid): no library
MAX_GRID_ENTRIES = 1000  # robots.library.MAX_ENTRIES
SCHEDULE_TOL = 1e-9

#: a picklable factory (built once per worker) of a check that validates one gait in MuJoCo and
#: returns the gait file's `validation` block: {"passed": bool, "reasons": [...],
#: "metrics": {"achieved_vx_m_s": …, "achieved_vy_m_s": …, "achieved_yaw_rate_rad_s": …}, …}
ValidatorFactory = Callable[[], Callable[[Gait], dict[str, Any]]]


class LibraryBuildError(PlannerError):
    """The library cannot be built: a bad grid, the stand failed, or too few entries passed."""


@dataclass(frozen=True)
class GridSpec:
    """The commands of a library: the tensor product of the three axes."""

    vx_m_s: tuple[float, ...]
    vy_m_s: tuple[float, ...] = (0.0,)
    yaw_rate_rad_s: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        for name in ("vx_m_s", "vy_m_s", "yaw_rate_rad_s"):
            values = tuple(float(v) for v in getattr(self, name))
            if not values or not all(math.isfinite(v) for v in values):
                raise LibraryBuildError(f"grid {name}: needs at least one finite value")
            if len(set(values)) != len(values):
                raise LibraryBuildError(f"grid {name}: repeats a value {values}")
            object.__setattr__(self, name, tuple(sorted(values)))
        if self.size > MAX_GRID_ENTRIES:
            raise LibraryBuildError(f"grid has {self.size} commands; at most {MAX_GRID_ENTRIES}")

    @property
    def shape(self) -> tuple[int, int, int]:
        return (len(self.vx_m_s), len(self.vy_m_s), len(self.yaw_rate_rad_s))

    @property
    def size(self) -> int:
        a, b, c = self.shape
        return a * b * c

    def command(self, node: tuple[int, int, int]) -> Velocity:
        i, j, k = node
        return Velocity(self.vx_m_s[i], self.vy_m_s[j], self.yaw_rate_rad_s[k])

    def nodes(self) -> list[tuple[int, int, int]]:
        return [tuple(int(x) for x in n) for n in np.ndindex(*self.shape)]  # type: ignore[misc]

    def waves(self) -> list[list[tuple[int, int, int]]]:
        """Breadth-first layers from the node nearest zero (grid steps, |Δi|+|Δj|+|Δk|)."""
        seed = tuple(int(np.argmin(np.abs(np.asarray(axis)))) for axis in
                     (self.vx_m_s, self.vy_m_s, self.yaw_rate_rad_s))
        layers: dict[int, list[tuple[int, int, int]]] = {}
        for n in self.nodes():
            layers.setdefault(sum(abs(a - b) for a, b in zip(n, seed, strict=True)), []).append(n)
        return [layers[d] for d in sorted(layers)]

    def as_dict(self) -> dict[str, list[float]]:
        return {"vx_m_s": list(self.vx_m_s), "vy_m_s": list(self.vy_m_s),
                "yaw_rate_rad_s": list(self.yaw_rate_rad_s)}


def foot_radius_m(robot: Robot) -> float:
    """Mean horizontal distance of the nominal-stance feet from the body centre."""
    feet = stance_foot_positions_m(robot)
    return float(np.mean(np.hypot(feet[:, 0], feet[:, 1])))


def max_yaw_rate_rad_s(robot: Robot, period_s: float) -> float:
    """The largest default yaw rate: the CLI's 0.5·√(g/L), and a quarter of the planner's turn
    per period."""
    return min(MAX_YAW_RATE_SQRT_G_PER_L * math.sqrt(GRAVITY_M_S2 / robot.leg_length_m),
               0.25 * MAX_TURN_PER_PERIOD_RAD / period_s)


def default_grid(robot: Robot, family: str | None = None,
                 period_s: float | None = None) -> GridSpec:
    """The grid of the module docstring for `robot` (and the period of `family`, or
    `period_s`: a longer period lowers the yaw cap of a quarter turn per period)."""
    family = family or default_gait_for(robot)
    period = make_schedule(robot, family, period_s=period_s).period_s
    v = default_speed_m_s(robot.leg_length_m)
    w = min(0.5 * v / foot_radius_m(robot), max_yaw_rate_rad_s(robot, period))
    vx = tuple(round(x, 4) for x in (-0.5 * v, 0.0, 0.5 * v, v))
    return GridSpec(vx, (0.0,), (round(-w, 3), 0.0, round(w, 3)))


def check_grid(robot: Robot, grid: GridSpec, schedule: ContactSchedule, n_knots: int) -> None:
    """Every command plannable (`planner.nlp.command.check_command`), before any solve."""
    for vy in grid.vy_m_s:
        for w in grid.yaw_rate_rad_s:
            try:
                check_command(vy, w, schedule.period_s, n_knots)
            except PlannerConfigError as exc:
                raise LibraryBuildError(f"grid command vy {vy:g}, yaw rate {w:g}: {exc}") from None
    for vx in grid.vx_m_s:
        if abs(vx) > 10.0:
            raise LibraryBuildError(f"grid vx {vx:g} m/s: at most 10 m/s in magnitude")


def align_phase(gait: Gait, template: ContactSchedule, robot: Robot) -> Gait:
    """`gait` re-indexed so that its schedule is `template`'s (with the gait's period): undoes
    `GaitPlanner.to_gait`'s rest-like start (`planner.nlp.cycle_start.rotate`), so entries
    planned from one template share one phase origin."""
    n = gait.n_knots
    ref = template.with_period(gait.period_s)
    for k in range(n):
        rotated = rotate_schedule(ref, k, n)
        if rotated.feet == gait.schedule.feet and all(
            abs(a - b) <= SCHEDULE_TOL
            for a, b in zip(rotated.touchdown_phase + rotated.duty_factor,
                            gait.schedule.touchdown_phase + gait.schedule.duty_factor,
                            strict=True)
        ):
            break
    else:
        raise LibraryBuildError(
            f"gait at {velocity_tuple(gait.velocity)} does not follow the {gait.gait_label} "
            "template's schedule up to a knot shift"
        )
    if k == 0:
        return gait

    def back(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.roll(a, k, axis=0)

    planner_meta = dict(gait.planner)
    planner_meta["phase_origin"] = f"template (rest-like start knot {k} rotated back)"
    return Gait.create(
        robot=robot, knots_rad=back(gait.knots_rad), schedule=ref,  # type: ignore[arg-type]
        velocity=gait.velocity, gait_label=gait.gait_label, base_pose=back(gait.base_pose),
        contact_forces_n=back(gait.contact_forces_n),
        joint_torques_nm=back(gait.joint_torques_nm), planner=planner_meta,
        expected_knots_rad=back(gait.expected_joint_angles_rad),
    )


def stand_gait(robot: Robot, period_s: float, n_knots: int = 8) -> Gait:
    """The library's stand: the nominal stance, every foot down, zero velocity."""
    feet = robot.foot_names
    schedule = ContactSchedule(period_s, feet, (0.0,) * len(feet), (1.0,) * len(feet))
    knots = np.tile(np.asarray(robot.nominal_stance_rad, dtype=float), (n_knots, 1))
    return Gait.create(robot=robot, knots_rad=knots, schedule=schedule, velocity=Velocity(),
                       gait_label="stand", planner={"stand": "nominal stance"})


@dataclass(frozen=True)
class EntryTask:
    command: Velocity
    warm_start: WarmStart | None = None


@dataclass(frozen=True, eq=False)
class EntryOutcome:
    """One command's result: a validated gait, or why it is left out."""

    command: Velocity
    gait: Gait | None  # validation filled (passed or not); None when the plan failed
    passed: bool
    reason: str  # why it failed ("" when it passed)
    achieved: Velocity | None
    plan_s: float
    validate_s: float
    warm_started: bool
    warm_start: WarmStart | None = field(default=None, repr=False)  # its solution, for neighbours


def _achieved(validation: dict[str, Any]) -> Velocity | None:
    m = validation.get("metrics") or {}
    try:
        return Velocity(float(m["achieved_vx_m_s"]), float(m["achieved_vy_m_s"]),
                        float(m["achieved_yaw_rate_rad_s"]))
    except (KeyError, TypeError, ValueError):
        return None


@dataclass(frozen=True)
class EntrySolverFactory:
    """Picklable: builds, once per worker, the planner and validator for one library build."""

    robot_dir: str
    family: str
    n_knots: int
    options: PlannerOptions
    validator: ValidatorFactory | None
    period_s: float | None = None  # None: the template's
    duty_factor: float | None = None  # None: the template's

    def __call__(self) -> Callable[[EntryTask], EntryOutcome]:
        robot = load_robot(self.robot_dir)
        planner = GaitPlanner(robot, self.n_knots, self.options)
        check = self.validator() if self.validator is not None else None
        template = make_schedule(robot, self.family, self.period_s, self.duty_factor)
        return _EntrySolver(robot, planner, check, template, self.family)


@dataclass
class _EntrySolver:
    robot: Robot
    planner: GaitPlanner
    check: Callable[[Gait], dict[str, Any]] | None
    template: ContactSchedule
    family: str

    def __call__(self, task: EntryTask) -> EntryOutcome:
        c = task.command
        t0 = time.perf_counter()
        try:
            result = self.planner.solve(
                self.template, c.vx_m_s, task.warm_start if task.warm_start is not None else False,
                vy_m_s=c.vy_m_s, yaw_rate_rad_s=c.yaw_rate_rad_s)
        except PlannerError as exc:
            return EntryOutcome(c, None, False, f"planner: {exc}", None,
                                time.perf_counter() - t0, 0.0, task.warm_start is not None)
        plan_s = time.perf_counter() - t0
        warm = task.warm_start is not None
        if not result.feasible:
            return EntryOutcome(c, None, False, f"plan infeasible: {result.message}", None,
                                plan_s, 0.0, warm)
        gait = align_phase(self.planner.to_gait(result, self.family), self.template, self.robot)
        if self.check is None:
            return EntryOutcome(c, gait, False, "not validated (no validator)", None, plan_s,
                                0.0, warm, result.warm_start)
        t1 = time.perf_counter()
        try:
            validation = self.check(gait)
        except Exception as exc:  # a sim error is this entry's failure, not the build's
            return EntryOutcome(c, gait, False, f"validation raised: {exc}", None, plan_s,
                                time.perf_counter() - t1, warm, result.warm_start)
        validate_s = time.perf_counter() - t1
        gait = gait.with_validation(validation)
        passed = validation.get("passed") is True
        reasons = "; ".join(str(r) for r in validation.get("reasons", []))
        return EntryOutcome(c, gait, passed, "" if passed else f"MuJoCo: {reasons}",
                            _achieved(validation), plan_s, validate_s, warm, result.warm_start)


def _solve_entry(task: EntryTask) -> EntryOutcome:
    """Module-level (picklable by reference): this worker's `_EntrySolver` on one task."""
    out: EntryOutcome = worker_local_solve(task)
    return out


def _neighbours(node: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    out = []
    for axis in range(3):
        for step in (-1, 1):
            n = list(node)
            n[axis] += step
            out.append((n[0], n[1], n[2]))
    return out


def _versions() -> dict[str, str]:
    out = {}
    for pkg in ("gaitsmith", "numpy", "casadi", "mujoco"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            continue
    return out


def _command_dict(c: Velocity) -> dict[str, float]:
    return dict(zip(("vx_m_s", "vy_m_s", "yaw_rate_rad_s"), velocity_tuple(c), strict=True))


@dataclass(frozen=True, eq=False)
class LibraryBuild:
    library: GaitLibrary
    outcomes: tuple[EntryOutcome, ...]  # every command, in build order
    stand_validation: dict[str, Any]
    time_s: float


def build_library(
    robot: Robot,
    grid: GridSpec | None = None,
    *,
    family: str | None = None,
    period_s: float | None = None,
    duty_factor: float | None = None,
    family_reason: str = "",
    n_knots: int = 30,
    options: PlannerOptions | None = None,
    validator: ValidatorFactory,
    stand_validator: Callable[[Gait], dict[str, Any]] | None = None,
    executor: str = "process",
    workers: int | None = None,
    address: str | None = None,
    on_entry: Callable[[int, int, EntryOutcome], None] | None = None,
    min_entries: int = MIN_ENTRIES,
    warm_start: bool = True,
) -> LibraryBuild:
    """Plan and validate every grid command (module docstring); raises LibraryBuildError if the
    stand fails or fewer than `min_entries` (or the whole grid, if smaller) pass. Without
    `warm_start` every entry starts from the template's initial guess, all in one batch.
    `period_s` / `duty_factor` (None: the template's) set the one schedule every entry shares,
    e.g. the static walk `gaitsmith.gait_choice.grid_gait` chooses for a turning trotter;
    `family_reason` says why, in the file's `built` metadata."""
    t_start = time.perf_counter()
    family = family or default_gait_for(robot)
    # TemplateError names the offered families
    template = make_schedule(robot, family, period_s, duty_factor)
    grid = grid or default_grid(robot, family, template.period_s)
    check_grid(robot, grid, template, n_knots)
    options = options or PlannerOptions()
    stand = stand_gait(robot, template.period_s)
    stand_check = stand_validator or validator()
    t0 = time.perf_counter()
    stand_validation = stand_check(stand)
    stand_s = time.perf_counter() - t0
    if stand_validation.get("passed") is not True:
        reasons = "; ".join(str(r) for r in stand_validation.get("reasons", []))
        raise LibraryBuildError(f"{robot.name}: the stand failed in MuJoCo ({reasons}); "
                                "no library written")
    stand = stand.with_validation(stand_validation)
    factory = EntrySolverFactory(str(robot.root_dir), family, n_knots, options, validator,
                                 period_s, duty_factor)
    done: dict[tuple[int, int, int], EntryOutcome] = {}
    order: list[EntryOutcome] = []
    n_workers = workers
    with make_executor(executor, factory, workers, address) as ex:  # type: ignore[arg-type]
        n_workers = getattr(ex, "workers", 1)
        waves = grid.waves()
        if not warm_start:  # every entry cold: one batch keeps every worker busy
            waves = [[n for wave in waves for n in wave]]
        for wave in waves:
            tasks = []
            for node in wave:
                warm = None
                for nb in _neighbours(node) if warm_start else ():
                    prev = done.get(nb)
                    if prev is not None and prev.warm_start is not None:
                        warm = prev.warm_start
                        if prev.passed:
                            break
                tasks.append(EntryTask(grid.command(node), warm))
            for node, outcome in zip(wave, ex.map(_solve_entry, tasks), strict=True):
                done[node] = outcome
                order.append(outcome)
                if on_entry is not None:
                    on_entry(len(order), grid.size, outcome)
    passed = [o for o in order if o.passed and o.gait is not None and o.achieved is not None]
    need = min(min_entries, grid.size)
    if len(passed) < need:
        failed = "; ".join(f"{velocity_tuple(o.command)}: {o.reason.split('; ')[0]}"
                           for o in order if not o.passed)
        raise LibraryBuildError(
            f"{robot.name}: only {len(passed)} of {grid.size} grid entries passed MuJoCo "
            f"(need {need}); no library written. Failed (first reason each): {failed}"
        )
    entries = tuple(LibraryEntry(o.command, o.gait, o.achieved)  # type: ignore[arg-type]
                    for o in sorted(passed, key=lambda o: velocity_tuple(o.command)))
    total_s = time.perf_counter() - t_start
    built = {
        "grid": grid.as_dict(),
        "family": family,
        "family_choice": family_reason or "as given",
        "duty_factor": float(template.duty_factor[0]),
        "static_margin_leg_lengths": options.static_margin_leg_lengths,
        "mean_footprint_leg_lengths": options.mean_footprint_leg_lengths,
        "n_knots": n_knots,
        "period_s": template.period_s,
        "period_law": ("constant (the template period)" if period_s is None
                       else "constant (chosen with the family)"),
        "executor": executor,
        "warm_start": warm_start,
        "workers": n_workers,
        "time_s": total_s,
        "stand_validate_s": stand_s,
        "entries": [
            {"command": _command_dict(o.command), "passed": o.passed, "plan_s": o.plan_s,
             "validate_s": o.validate_s, "warm_started": o.warm_started}
            for o in order
        ],
        "failures": [{"command": _command_dict(o.command), "reason": o.reason}
                     for o in order if not o.passed],
        "versions": _versions(),
    }
    library = GaitLibrary(robot.name, robot.fingerprint, robot.joint_names, family, stand,
                          entries, built)
    return LibraryBuild(library, tuple(order), stand_validation, total_s)


__all__ = [
    "EntryOutcome",
    "GridSpec",
    "LibraryBuild",
    "LibraryBuildError",
    "align_phase",
    "build_library",
    "default_grid",
    "foot_radius_m",
    "stand_gait",
]


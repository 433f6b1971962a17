"""The gait search's final phase: its cheapest timings re-solved at the gait file's resolution
and judged by the final acceptance; the first accepted in rank order wins ("first"), or the
cheaper accepted of the first two ("cheapest-of-2", the search's default), or the cheapest
accepted of all ("cheapest"); then the seeding templates.

The rule (`choose_final`), unchanged from the serial loop it replaces: the candidates in rank
order (`planner.search.gait_search.final_candidates_of`), each solved cold at `n_knots`; the
first that is feasible and accepted (or feasible, when nothing checks) wins. If none does and a
check exists, the templates the search started from, cheapest first (their own schedules, as
`gaitsmith plan` plans them, skipping any identical to a candidate tried), the first accepted
wins; else the first feasible candidate, reported as not accepted (or the first one, infeasible).
With ``final_templates="compete"`` the templates whose coarse plan solved are read right after
the compared candidates (`compete_order`), and the cheapest accepted one is written if it beats
the candidates' winner (`choose_final(rival=...)`).

Where it runs: with the serial executor, in this process, one task at a time and only as far as
the rule reads (`SerialExecutor.ordered`). With the process pool or Ray, on the search's workers:
each task is evaluated speculatively, up to one per worker ahead of the one the rule waits for
(`planner.search.executors.AheadResults`), and the rule still reads the outcomes in rank order
— a later candidate that finished and passed first does not win over an earlier one that passes.
A worker builds the final planner and check once (`prepare_final`: lazily at its first task, or
ahead in a generation barrier's idle time as the executor's `idle_task`) from a
`FinalPlannerSpec` shipped with every task (the robot object itself, so a robot changed in memory,
e.g. `robots.voltage.robot_at_voltage`, is planned as in this process). A cold solve does not
depend on what the planner solved before (docs/results/planner_determinism.md), so the outcome of
a task is the same bits on any worker and in this process.
"""

from __future__ import annotations

import os
import time
import uuid
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.search.basin_cma import LocalResult
from planner.search.defaults import (
    FINAL_CHOICE_CHEAPEST,
    FINAL_CHOICE_CHEAPEST_OF_2,
    FINAL_CHOICE_FIRST,
    FINAL_CHOICES,
    FINAL_RETRIES,
    FINAL_RETRY_ALL,
    FINAL_RETRY_MARGIN,
    FINAL_RETRY_OFF,
)
from planner.templates import identical_schedules
from robots import ContactSchedule, Gait, Robot

#: the label of the gait the final check judges (as the serial loop wrote it)
CHECK_LABEL = "search"
#: how a half-cycle final plan that did not pass failed (`FinalOutcome.half_failure`): its
#: plan infeasible, failing the check narrowly (`narrow_failure`), or failing it clearly
HALF_INFEASIBLE = "infeasible"
HALF_NARROW = "narrow"
HALF_CLEAR = "clear"


@dataclass(frozen=True)
class FinalPlannerSpec:
    """What a worker needs to build the final planner and check: one per search (`token`)."""

    robot: Robot
    n_knots: int
    options: PlannerOptions
    speed_m_s: float
    #: picklable factory of the final check (`gait_search.GaitAcceptance`); None: no check
    acceptance: Callable[[], Callable[[Gait], object]] | None
    token: str = ""

    @staticmethod
    def new(robot: Robot, n_knots: int, options: PlannerOptions, speed_m_s: float,
            acceptance: Callable[[], Callable[[Gait], object]] | None) -> FinalPlannerSpec:
        return FinalPlannerSpec(robot, n_knots, options, speed_m_s, acceptance, uuid.uuid4().hex)


@dataclass(frozen=True)
class FinalTask:
    """One full-resolution solve of the final phase: a searched candidate (`template` None) or
    the template `template` (the fallback's, or a rival); `half_cycle` and `swing_wrench` the
    solve's `GaitPlanner.solve(half_cycle=, swing_wrench=)` (None: the spec's options; a
    template is planned as the template path plans it); `retry_full`
    (`defaults.FINAL_RETRIES`): which half-cycle plans that did not pass are re-solved cold on
    the full NLP, that plan judged instead (`evaluate_final`; the search's `final_retry_full`,
    for its candidates)."""

    spec: FinalPlannerSpec
    schedule: ContactSchedule
    template: str | None = None
    half_cycle: bool | None = None
    retry_full: str = FINAL_RETRY_OFF
    swing_wrench: str | None = None


@dataclass(frozen=True)
class FinalOutcome:
    """A task's solve and verdict: `ok` None when the plan is infeasible or nothing checks;
    `check_s` the check's wall time; CPU seconds of the process that ran it (`cpu` of the solve
    and of the check); `build_s`, `build_cpu_s` the final planner's build if this task paid it.
    After a full-cycle retry (`FinalTask.retry_full`) `plan` and `ok` are the full solve's,
    `check_s`, `solve_cpu_s` and `check_cpu_s` the sums over both attempts, and `half_tried`
    the half-cycle attempt that failed (its own plan, verdict and CPU). `half_failure` says how
    a half-cycle plan that did not pass failed (`HALF_INFEASIBLE`, `HALF_NARROW`, `HALF_CLEAR`;
    "" if it passed or the solve was not on half the knots): on the retry's outcome, why it was
    retried; on the half plan's own outcome, why it was not."""

    plan: PlanResult
    check_s: float
    ok: bool | None
    solve_cpu_s: float = 0.0
    check_cpu_s: float = 0.0
    build_s: float = 0.0
    build_cpu_s: float = 0.0
    #: the process that ran it and when (`time.time()`, s): for timelines of the final phase
    pid: int = 0
    started_at_s: float = 0.0
    ended_at_s: float = 0.0
    #: the half-cycle attempt a full-cycle retry replaced (None: no retry)
    half_tried: FinalOutcome | None = None
    #: the check's failed criteria and how far past their limits, relative (the verdict's
    #: `excess`, `sim.validate.criterion_excess`; empty if passed, infeasible or not given)
    excess: tuple[tuple[str, float], ...] = ()
    #: how the half-cycle plan failed (see above): why it was, or was not, retried
    half_failure: str = ""

    @property
    def retried(self) -> bool:
        """The plan is a full-cycle retry after a failed half-cycle attempt."""
        return self.half_tried is not None


@dataclass(frozen=True)
class FinalChoice:
    """What the rule chose: the plan, the search result of its timing, its verdict, the
    fallback template (None: a candidate), and every outcome the rule read, in order."""

    plan: PlanResult
    searched: LocalResult
    accepted: bool | None
    fallback_template: str | None
    read: tuple[FinalOutcome, ...]
    #: the score of the candidates' accepted winner when a rival template beat it (None: it
    #: did not, or no candidate was accepted)
    beaten_score: float | None = None

    @property
    def retried(self) -> bool:
        """The chosen plan is a full-cycle retry after a failed half-cycle attempt
        (`FinalOutcome.retried`)."""
        return any(o.plan is self.plan and o.retried for o in self.read)

    @property
    def retry_reason(self) -> str:
        """Why the chosen plan is a full-cycle retry (`describe_failure` of its half-cycle
        attempt; "" if it is not one)."""
        return next((describe_failure(o.half_tried) for o in self.read
                     if o.plan is self.plan and o.half_tried is not None), "")


def describe_failure(outcome: FinalOutcome) -> str:
    """How a half-cycle plan failed, for a log: "infeasible", or "narrow"/"clear" and its failed
    criteria with their relative excess ("narrow: heading +0.4 %")."""
    if not outcome.half_failure or outcome.half_failure == HALF_INFEASIBLE:
        return outcome.half_failure
    parts = ", ".join(f"{name} +{100 * e:.1f} %" for name, e in outcome.excess)
    return f"{outcome.half_failure}: {parts}" if parts else outcome.half_failure


def narrow_failure(excess: Sequence[tuple[str, float]], margin: float = FINAL_RETRY_MARGIN
                   ) -> bool:
    """A failed check is narrow when it names its failed criteria (`FinalOutcome.excess`) and
    every one's metric is at most `margin` past its limit, relative to it (a fall is +inf:
    never narrow; a verdict that gives no excess is not judged narrow)."""
    return bool(excess) and all(e <= margin for _, e in excess)


def half_failure(outcome: FinalOutcome, margin: float = FINAL_RETRY_MARGIN) -> str:
    """How `outcome`'s plan failed (`HALF_INFEASIBLE`, `HALF_NARROW`, `HALF_CLEAR`; "" if it
    is feasible and passed or nothing checks it)."""
    if not outcome.plan.feasible:
        return HALF_INFEASIBLE
    if outcome.ok is not False:
        return ""
    return HALF_NARROW if narrow_failure(outcome.excess, margin) else HALF_CLEAR


def retries(policy: str, failure: str) -> bool:
    """Whether the final-retry `policy` (`defaults.FINAL_RETRIES`) re-solves on the full NLP a
    half-cycle plan that failed as `failure` says (`half_failure`; "" never)."""
    if policy not in FINAL_RETRIES:
        raise ValueError(f"final retry must be one of {', '.join(FINAL_RETRIES)}, got {policy!r}")
    if not failure or policy == FINAL_RETRY_OFF:
        return False
    return policy == FINAL_RETRY_ALL or failure == HALF_NARROW


def evaluate_final(planner: GaitPlanner, check: Callable[[Gait], object] | None,
                   schedule: ContactSchedule, speed_m_s: float,
                   half_cycle: bool | None = None, retry_full: str = FINAL_RETRY_OFF,
                   swing_wrench: str | None = None, margin: float = FINAL_RETRY_MARGIN
                   ) -> FinalOutcome:
    """Solve `schedule` cold at the planner's knots (`half_cycle`, `swing_wrench`:
    `GaitPlanner.solve`'s) and, if feasible, judge its gait. If that solve ran on half the knots
    (`stats["half_cycle"]`) and its plan did not pass (`half_failure`: infeasible, or failing
    the check narrowly — every failed criterion within `margin` of its limit — or clearly),
    `retry_full` (`defaults.FINAL_RETRIES`) says whether to solve it again cold on the full NLP
    (the same `swing_wrench`) and judge that one: "all" every such plan, "narrow" only a narrow
    failure, "off" none (the outcome's `half_tried` holds the first attempt, `half_failure`
    why). A half-cycle optimum can fail a MuJoCo check by a hair that the same point solved on
    all knots passes (docs/results/planner_speed_search.md, 36-lead i, session 39 (lead),
    session 40)."""
    first = _solve_and_judge(planner, check, schedule, speed_m_s, half_cycle, swing_wrench)
    if not first.plan.stats.get("half_cycle"):
        return first
    failure = half_failure(first, margin) if check is not None or not first.plan.feasible else ""
    first = replace(first, half_failure=failure)
    if not retries(retry_full, failure):
        return first
    full = _solve_and_judge(planner, check, schedule, speed_m_s, False, swing_wrench)
    return replace(full, check_s=first.check_s + full.check_s,
                   solve_cpu_s=first.solve_cpu_s + full.solve_cpu_s,
                   check_cpu_s=first.check_cpu_s + full.check_cpu_s,
                   started_at_s=first.started_at_s, half_tried=first, half_failure=failure)


def _solve_and_judge(planner: GaitPlanner, check: Callable[[Gait], object] | None,
                     schedule: ContactSchedule, speed_m_s: float,
                     half_cycle: bool | None, swing_wrench: str | None = None) -> FinalOutcome:
    """One cold solve of `schedule` and, if feasible, its gait's verdict (`evaluate_final`)."""
    c0, started = time.process_time(), time.time()
    solved = planner.solve(schedule, speed_m_s, warm_start=False, half_cycle=half_cycle,
                           swing_wrench=swing_wrench)
    solve_cpu_s = time.process_time() - c0
    if not solved.feasible:
        return FinalOutcome(solved, 0.0, None, solve_cpu_s, pid=os.getpid(),
                            started_at_s=started, ended_at_s=time.time())
    t_check, c_check = time.perf_counter(), time.process_time()
    verdict = None if check is None else check(planner.to_gait(solved, CHECK_LABEL))
    ok = None if verdict is None else bool(verdict.passed)  # type: ignore[attr-defined]
    excess = () if verdict is None or ok else tuple(getattr(verdict, "excess", ()))
    return FinalOutcome(solved, time.perf_counter() - t_check, ok, solve_cpu_s,
                        time.process_time() - c_check, pid=os.getpid(), started_at_s=started,
                        ended_at_s=time.time(), excess=excess)


#: this worker's final planner and check: (spec token, planner, check)
_WORKER_FINAL: tuple[str, GaitPlanner, Callable[[Gait], object] | None] | None = None


def prepare_final(spec: FinalPlannerSpec) -> tuple[float, float]:
    """Build this worker's final planner and check for `spec` unless built (wall and CPU
    seconds spent; 0 if it was). The executor's `idle_task`, and the start of every task."""
    global _WORKER_FINAL
    if _WORKER_FINAL is not None and _WORKER_FINAL[0] == spec.token:
        return 0.0, 0.0
    t0, c0 = time.perf_counter(), time.process_time()
    _WORKER_FINAL = None  # the last search's planner goes before this one is built
    planner = GaitPlanner(spec.robot, spec.n_knots, spec.options)
    check = spec.acceptance() if spec.acceptance is not None else None
    _WORKER_FINAL = (spec.token, planner, check)
    return time.perf_counter() - t0, time.process_time() - c0


def worker_final_solve(task: FinalTask) -> FinalOutcome:
    """A final task on an executor worker (picklable by reference)."""
    build_s, build_cpu_s = prepare_final(task.spec)
    assert _WORKER_FINAL is not None
    _, planner, check = _WORKER_FINAL
    return replace(evaluate_task(planner, check, task), build_s=build_s, build_cpu_s=build_cpu_s)


def evaluate_task(planner: GaitPlanner, check: Callable[[Gait], object] | None,
                  task: FinalTask) -> FinalOutcome:
    """`task` solved and judged with `planner` and `check` (`evaluate_final` with the task's
    `half_cycle`, `retry_full` and `swing_wrench`, the default margin): on a worker, in the
    search's process and in its replay."""
    return evaluate_final(planner, check, task.schedule, task.spec.speed_m_s, task.half_cycle,
                          task.retry_full, task.swing_wrench)


def compared_candidates(choice: str, n_tasks: int) -> int:
    """How many candidates `choice` compares before the cheapest accepted one wins (1: the
    first accepted wins)."""
    if choice not in FINAL_CHOICES:
        raise ValueError(f"choose_final: choice must be one of {', '.join(FINAL_CHOICES)}, "
                         f"got {choice!r}")
    return {FINAL_CHOICE_FIRST: 1, FINAL_CHOICE_CHEAPEST_OF_2: 2,
            FINAL_CHOICE_CHEAPEST: n_tasks}[choice]


def compete_order(tasks: Sequence[FinalTask], searched: Sequence[LocalResult], choice: str,
                  rival: Callable[[LocalResult], bool],
                  ) -> tuple[list[FinalTask], list[LocalResult]]:
    """`tasks` (candidates, then templates) in the order `choose_final(..., rival=rival)` reads
    them: the candidates `choice` compares, the rival templates (those whose search result
    `rival` takes), the other candidates (but one whose timing is a rival's, already read),
    the other templates. The rivals are read right after
    the compared candidates, in one stream: a second stream after the first would wait for the
    first one's speculative solves (a 30-knot candidate can take tens of seconds) instead of
    stopping them."""
    pairs = list(zip(tasks, searched, strict=True))
    candidates = [pr for pr in pairs if pr[0].template is None]
    templates = [pr for pr in pairs if pr[0].template is not None]
    n = compared_candidates(choice, len(tasks))
    rivals = [pr for pr in templates if rival(pr[1])]
    others = [pr for pr in templates if not rival(pr[1])]
    # a later candidate with a rival's timing is that rival's solve, read before it
    later = [pr for pr in candidates[n:]
             if not any(identical_schedules(pr[0].schedule, r[0].schedule) for r in rivals)]
    order = candidates[:n] + rivals + later + others
    return [t for t, _ in order], [r for _, r in order]


def choose_final(tasks: Sequence[FinalTask], searched: Sequence[LocalResult],
                 outcomes: Iterable[FinalOutcome], choice: str = FINAL_CHOICE_FIRST,
                 score: Callable[[PlanResult], float] | None = None,
                 rival: Callable[[LocalResult], bool] | None = None) -> FinalChoice:
    """The module's rule over `outcomes`, read lazily in the order of `tasks` (candidates
    first, then fallback templates, each with the search result of its timing in `searched`);
    stops reading at the first winner. `tasks` must hold at least one candidate.

    `choice` "cheapest": every candidate is read, and of those that are feasible and accepted
    (or feasible, when nothing checks) the one with the lowest `score` of its full-resolution
    plan wins (default score: the plan's cost); the templates are read only if none is.
    "cheapest-of-2": the same over the first two candidates; if neither is accepted, the first
    accepted after them wins, as with "first". The coarse cost ranks the candidates, but the
    search's later samples can be coarse-cheaper and costlier at full resolution
    (docs/results/planner_speed_search.md, session 35).

    `rival` (``final_templates="compete"``; `tasks` in `compete_order`): the templates it takes
    (the search: those whose coarse plan solved) are read too, and the cheapest accepted one
    wins if its `score` is lower than the candidates' winner's — or if no candidate is accepted
    (then before the other templates). So the search never writes a gait costlier than a
    template that `gaitsmith plan ROBOT --gait NAME` would plan and the same check would pass:
    a search can otherwise write a candidate several times costlier than a template
    (docs/results/planner_speed_search.md, session 36, spotmicro seed 1: 6.3×; session 37)."""
    compared = compared_candidates(choice, len(tasks))
    rank = score or (lambda plan: plan.cost)
    chosen: tuple[PlanResult, LocalResult, bool | None] | None = None
    winners: list[tuple[float, int, PlanResult, LocalResult, bool | None]] = []
    rivals: list[tuple[float, int, PlanResult, LocalResult, str]] = []
    fallback: str | None = None
    read: list[FinalOutcome] = []
    n_candidates = 0
    pending = iter(outcomes)
    for task, result in zip(tasks, searched, strict=False):
        is_rival = task.template is not None and rival is not None and rival(result)
        if task.template is None:
            if winners and n_candidates >= compared:
                break  # a candidate won; the rest are not read (nor solved)
        elif not is_rival and (winners or rivals):
            break  # the fallback's other templates: only when nothing was accepted
        out = next(pending, None)
        if out is None:
            break
        read.append(out)
        plan = out.plan
        if task.template is None:
            n_candidates += 1
            if not plan.feasible:
                chosen = chosen or (plan, result, None)
                continue
            if out.ok is not False:
                winners.append((rank(plan), len(winners), plan, result, out.ok))
                continue
            if chosen is None or not chosen[0].feasible:
                chosen = (plan, result, False)
        elif plan.feasible and out.ok:
            if is_rival:
                rivals.append((rank(plan), len(rivals), plan, result, task.template))
                continue
            chosen, fallback = (plan, result, True), task.template
            break
    if winners:
        _, _, plan, result, ok = min(winners, key=lambda w: (w[0], w[1]))
        chosen = (plan, result, ok)
    beaten: float | None = None
    if rivals:
        cost, _, plan, result, name = min(rivals, key=lambda w: (w[0], w[1]))
        if not winners or cost < rank(chosen[0]):  # type: ignore[index]
            beaten = rank(chosen[0]) if winners else None  # type: ignore[index]
            chosen, fallback = (plan, result, True), name
    if chosen is None:
        raise ValueError("choose_final: no candidate was read (the tasks start with one)")
    return FinalChoice(*chosen, fallback, tuple(read), beaten)


__all__ = [
    "CHECK_LABEL",
    "FINAL_CHOICES",
    "FINAL_CHOICE_CHEAPEST",
    "FINAL_CHOICE_CHEAPEST_OF_2",
    "FINAL_CHOICE_FIRST",
    "HALF_CLEAR",
    "HALF_INFEASIBLE",
    "HALF_NARROW",
    "FinalChoice",
    "FinalOutcome",
    "FinalPlannerSpec",
    "FinalTask",
    "choose_final",
    "compared_candidates",
    "compete_order",
    "describe_failure",
    "evaluate_final",
    "evaluate_task",
    "half_failure",
    "narrow_failure",
    "prepare_final",
    "retries",
    "worker_final_solve",
]

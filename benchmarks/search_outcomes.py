"""A search setting judged by its outcomes over many searches, at its CPU cost.

    python benchmarks/search_outcomes.py run --searches quad12@0.25:0-4,hex18@0.15:0-2 \\
        --settings base,coarse-bounds,coarse-bounds+nearest-retimed --out RUNS.jsonl
    python benchmarks/search_outcomes.py table RUNS.jsonl [--baseline base]

Basin-CMA is a stochastic optimiser: whether one seed's winner survives a change of its
settings says little; the distribution of the written gaits over searches (robot, speed, seed)
does. `run` runs every setting of one search back to back (so their CPU ratios share the
machine's load), search after search, each as `gaitsmith plan ROBOT --speed V --search --seed S`
runs it (`gait_search_bench.run`: the command line's options, process executor, MuJoCo
acceptance on), and appends one JSON line per run to `--out` (a run already there is skipped, so
an interrupted study resumes). `table` prints every run and, per setting against the baseline:
total and median CPU ratio, iterations ratio, the final cost ratio's median and mean over
searches, how many searches ended better / the same (within 1e-4 relative) / worse, a two-sided
sign test on better vs worse, and how many searches did not write a MuJoCo-passing gait.

A setting is "+"-joined tokens: "base" (today's defaults), a `PlannerOptions.swing_wrench`
value (the options', so the templates' re-solves; the coarse and the candidates' final solves
take `SEARCH_SWING_WRENCH` and `FINAL_SWING_WRENCH`, "bounds" since session 40, unless a token
sets theirs), "coarse-rows" / "coarse-bounds" (the coarse solves' swing wrench,
`search_gait(search_swing_wrench=...)`; the defaults before session 40 are
"coarse-rows+finalrows"), a `SEARCH_WARM_STARTS` policy, "abortK/V" (the
coarse stall abort `StallAbort(K, V)`), "capN" (the coarse solves' IPOPT iteration cap,
`search_gait(search_max_iter=N)`, default 60), "tolX" (the coarse solves' IPOPT `tol`,
`search_gait(search_tol=X)`; the final re-solves keep 1e-6), "genK" (K basin-CMA generations
instead of `--generations`), "knotsN" (the coarse NLP's knots, `search_gait(search_knots=N)`,
`gaitsmith plan --search --search-knots N`, default 12; the final re-solves keep `--knots`, so
final costs compare; the compiled knot J/H are one knot's, so every N uses the same compiled
entry), "speedX" (the coarse MuJoCo check's relative speed tolerance,
`PassCriteria.speed_rel_tol`, X instead of 0.10; the final check keeps the default), "half" /
"full" (the coarse solves on the first half of a symmetric sample's knots or on all of them,
`search_gait(search_half_cycle=...)`, `planner.nlp.half_cycle`), "halffinal" (the final
re-solves of the candidates on the first half too, as solved: `search_gait(
final_half_cycle=True, final_retry_full="off")`), "halfretry" (on the first half, a candidate
infeasible or failing the check there re-solved on the full NLP: `final_half_cycle=True,
final_retry_full="all"`), "halfnarrow" (on the first half, only a candidate failing the check
there narrowly re-solved on the full NLP: `final_retry_full="narrow"`,
`defaults.FINAL_RETRY_MARGIN`), "fullfinal" (on the full NLP: `final_half_cycle=False`),
"fallback" / "compete" (the templates re-solved only when nothing searched passes, or also held
against the searched winner: `search_gait(final_templates=...)`), "finalrows" / "finalbounds"
(the candidates' final re-solves with the swing wrench by rows or bounds, the templates keep the
options' own: `search_gait(final_swing_wrench=...)`), "none" / "reciprocal" (the options'
`cold_mu_centrality`: the templates' and the candidates' final re-solves; the coarse solves keep
`SEARCH_COLD_MU_CENTRALITY`), "sepunitX" (`PlannerOptions.separation_unit_leg_lengths` X, every
NLP). Measured in docs/results/planner_speed_search.md, sessions 32-40, and
planner_speed_coldstart.md, session 42.

    python benchmarks/search_outcomes.py run ... --save DIR
    python benchmarks/search_outcomes.py replay DIR/*.pkl --generations 2,3,4,5,6 --out RUNS.jsonl

`--save` pickles each run's recording (every local solve, template seeds first) into DIR.
`replay` evaluates "the same search with --generations k" exactly on a recording: basin-CMA
draws each generation from its seeded generator and nothing in it depends on the total count
(`max_generations` only bounds the loop; the stall stop needs 10 generations, restarts are off),
so that search is the recording truncated after generation k; its final phase — the k-truncated
record's candidates (`gait_search.final_tasks`) re-solved cold at 30 knots and checked in MuJoCo,
then the template fallback — is really run here (in this process, serially; a cold solve is the
same bits in any process, `planner.search.final_phase`; identical schedules are solved once).
`--final-candidates C[,C2...]` re-solves up to C timings instead of `FINAL_CANDIDATES` (rows
"SETTING+genK+finalC"); `--final-templates compete` holds the winner against the cheapest accepted
template (rows "...+compete", `final_phase.choose_final(rival=)`). Each k appends a row
"SETTING+genK" whose iterations are the truncated record's, and whose CPU is an estimate: the
recorded run's CPU minus the dropped samples' worker CPU (solve + check) minus the recorded final
phase's solve + check CPU plus the replayed one's.

    python benchmarks/search_outcomes.py rule DIR/*.pkl --runs RUNS.jsonl --out RULE.jsonl \
        [--generations K]

`rule` writes, per recording, the row of the search under today's final-candidate rule
(`planner.search.budget`: 8 final candidates when the record, truncated after K generations,
default the recorded ones, accepted no sample, else 4), named "SETTING+rule" (K given:
"SETTING+genK+rule"): it is the replayed row "SETTING+genK" or "SETTING+genK+final8" the rule
picks (a replay is exact, so the rule's search is that row), read from `--runs`; a missing row
is named with the `replay` command that makes it. It prints each search's timing-space
dimension, λ, the samples accepted and the rule's choice.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pickle
import statistics
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from scipy.stats import binomtest
from scipy.stats import t as student_t

sys.path.insert(0, str(Path(__file__).resolve().parent))

from gait_search_bench import (
    COARSE_BOUNDS,
    FINAL_SOLVE_TOKENS,
    SearchRun,
    _abort_rule,
    cli_search_options,
    final_solve_token,
    run,
)

import robots
from gaitsmith.options import KNOTS_RANGE
from planner.nlp.config import (
    COLD_MU_CENTRALITIES,
    DEFAULT_COLD_MU_CENTRALITY,
    DEFAULT_SEPARATION_UNIT_LEG_LENGTHS,
    DEFAULT_SWING_WRENCH,
    SWING_WRENCHES,
)
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.search.basin_cma import LocalResult
from planner.search.budget import final_candidate_count, final_candidates_reason
from planner.search.defaults import (
    DEFAULT_FINAL_CHOICE,
    DEFAULT_FINAL_TEMPLATES,
    DEFAULT_TIPPING_WEIGHT,
    FINAL_HALF_CYCLE,
    FINAL_RETRY_ALL,
    FINAL_RETRY_FULL,
    FINAL_RETRY_OFF,
    FINAL_SWING_WRENCH,
    FINAL_TEMPLATES,
    SEARCH_HALF_CYCLE,
    SEARCH_SWING_WRENCH,
)
from planner.search.final_phase import (
    FINAL_CHOICE_FIRST,
    FINAL_CHOICES,
    FinalOutcome,
    FinalPlannerSpec,
    FinalTask,
    choose_final,
    evaluate_task,
)
from planner.search.gait_search import (
    DEFAULT_SEARCH_KNOTS,
    DEFAULT_SEARCH_MAX_ITER,
    FINAL_CANDIDATES,
    SEARCH_WARM_STARTS,
    TimingSpace,
    final_options,
    ordered_final_tasks,
)
from planner.search.support import TippingCost
from planner.templates import label_gait, make_schedule

#: relative final-cost change below which two searches' gaits count as the same
SAME_REL = 1e-4


@dataclass(frozen=True)
class Setting:
    """Search options of one setting (see the module docstring for the tokens)."""

    name: str
    swing_wrench: str = DEFAULT_SWING_WRENCH
    search_swing_wrench: str | None = SEARCH_SWING_WRENCH
    warm_start: str = "cold"
    abort: str = "off"
    search_max_iter: int = DEFAULT_SEARCH_MAX_ITER
    search_tol: float | None = None
    generations: int | None = None
    search_knots: int = DEFAULT_SEARCH_KNOTS
    coarse_speed_tol: float | None = None
    search_half_cycle: bool = SEARCH_HALF_CYCLE
    final_half_cycle: bool = FINAL_HALF_CYCLE
    final_templates: str = DEFAULT_FINAL_TEMPLATES
    final_retry_full: str = FINAL_RETRY_FULL
    final_swing_wrench: str | None = FINAL_SWING_WRENCH
    #: `PlannerOptions.cold_mu_centrality` of the options (the templates' and the candidates'
    #: final re-solves; the coarse solves keep `SEARCH_COLD_MU_CENTRALITY`)
    cold_mu_centrality: str = DEFAULT_COLD_MU_CENTRALITY
    #: `PlannerOptions.separation_unit_leg_lengths` of every NLP
    separation_unit_leg_lengths: float | None = DEFAULT_SEPARATION_UNIT_LEG_LENGTHS

    def __post_init__(self) -> None:
        # recordings before session 40 hold the retry as a bool: True was "all", False "off"
        if isinstance(self.final_retry_full, bool):
            object.__setattr__(self, "final_retry_full", retry_policy(self.final_retry_full))


def option_fields(setting: Setting) -> tuple[tuple[str, object], ...]:
    """The `PlannerOptions` fields a setting sets beyond the command line's defaults."""
    out: list[tuple[str, object]] = []
    if setting.cold_mu_centrality != DEFAULT_COLD_MU_CENTRALITY:
        out.append(("cold_mu_centrality", setting.cold_mu_centrality))
    if setting.separation_unit_leg_lengths != DEFAULT_SEPARATION_UNIT_LEG_LENGTHS:
        out.append(("separation_unit_leg_lengths", setting.separation_unit_leg_lengths))
    return tuple(out)


def retry_policy(value: bool | str) -> str:
    """`search_gait(final_retry_full=)` of a setting: a bool of a recording made before
    session 40 read as that day's meaning (True: every failed candidate, "all"; False: "off")."""
    if isinstance(value, bool):
        return FINAL_RETRY_ALL if value else FINAL_RETRY_OFF
    return value


#: the coarse solves' swing wrench tokens: `search_gait(search_swing_wrench=)`
COARSE_SWING_TOKENS = {"coarse-rows": "rows", COARSE_BOUNDS: "bounds"}
#: the candidates' final re-solves' swing wrench tokens: `search_gait(final_swing_wrench=)`
FINAL_SWING_TOKENS = {"finalrows": "rows", "finalbounds": "bounds"}
#: `replay --final-half-cycle` values: the final re-solve token each stands for
REPLAY_FINAL_SOLVES = {"on": "halffinal", "off": "fullfinal", "retry": "halfretry",
                       "narrow": "halfnarrow"}


def _number(token: str, prefix: str, kind: type[int] | type[float], text: str,
            low: int = 1, high: int | None = None, example: int = 40) -> int | float:
    """The number after `prefix` in `token` (an integer in [low, high] for capN, genK and
    knotsN, 0 < tolX < 1); one-line `SystemExit` otherwise."""
    try:
        value = kind(token.removeprefix(prefix))
    except ValueError:
        value = math.nan
    ok = 0 < value < 1 if kind is float else low <= value <= (high or math.inf)
    if not ok:
        want = ("a number in (0, 1)" if kind is float else f"an integer ≥ {low}" if high is None
                else f"an integer in [{low}, {high}]")
        raise SystemExit(f"--settings: {token!r} in {text!r} needs {want} after {prefix!r} "
                         f"(e.g. {prefix}{'1e-4' if kind is float else example})")
    return value


def parse_setting(text: str) -> Setting:
    """A "+"-joined setting; one-line `SystemExit` naming the bad token."""
    fields: dict[str, str | int | float | None] = {}
    for token in text.split("+"):
        value: str | int | float | None
        if token == "base":
            continue
        if token in SWING_WRENCHES:
            key, value = "swing_wrench", token
        elif token in COARSE_SWING_TOKENS:
            key, value = "search_swing_wrench", COARSE_SWING_TOKENS[token]
        elif token in SEARCH_WARM_STARTS:
            key, value = "warm_start", token
        elif token.startswith("abort"):
            key, value = "abort", token.removeprefix("abort")
            _abort_rule(value)
        elif token.startswith("cap"):
            key, value = "search_max_iter", _number(token, "cap", int, text)
        elif token.startswith("tol"):
            key, value = "search_tol", _number(token, "tol", float, text)
        elif token.startswith("gen"):
            key, value = "generations", _number(token, "gen", int, text)
        elif token.startswith("knots"):
            key, value = "search_knots", _number(token, "knots", int, text, *KNOTS_RANGE, 10)
        elif token.startswith("speed"):
            key, value = "coarse_speed_tol", _number(token, "speed", float, text)
        elif token in ("half", "full"):
            key, value = "search_half_cycle", token == "half"
        elif token in FINAL_SOLVE_TOKENS:
            if "final_half_cycle" in fields:
                raise SystemExit(f"--settings: {text!r} sets final_half_cycle twice")
            fields["final_half_cycle"], fields["final_retry_full"] = FINAL_SOLVE_TOKENS[token]
            continue
        elif token in FINAL_TEMPLATES:
            key, value = "final_templates", token
        elif token in FINAL_SWING_TOKENS:
            key, value = "final_swing_wrench", FINAL_SWING_TOKENS[token]
        elif token in COLD_MU_CENTRALITIES:
            key, value = "cold_mu_centrality", token
        elif token.startswith("sepunit"):
            key, value = "separation_unit_leg_lengths", _number(token, "sepunit", float, text)
        else:
            raise SystemExit(
                f"--settings: unknown token {token!r} in {text!r}; use base, "
                f"{', '.join(SWING_WRENCHES)}, {', '.join(COARSE_SWING_TOKENS)}, "
                f"{', '.join(SEARCH_WARM_STARTS)}, "
                "abortK/V, capN, tolX, genK, knotsN, speedX, half, full, "
                f"{', '.join(COLD_MU_CENTRALITIES)}, sepunitX, "
                f"{', '.join(FINAL_SOLVE_TOKENS)}, {', '.join(FINAL_SWING_TOKENS)}, "
                f"{' or '.join(FINAL_TEMPLATES)}, joined by +")
        if key in fields:
            raise SystemExit(f"--settings: {text!r} sets {key} twice")
        fields[key] = value
    return Setting(text, **fields)  # type: ignore[arg-type]


@dataclass(frozen=True)
class Search:
    robot: str
    speed_m_s: float
    seed: int

    @property
    def key(self) -> str:
        return f"{self.robot}@{self.speed_m_s:g}:{self.seed}"


def parse_searches(text: str) -> list[Search]:
    """"ROBOT@SPEED:SEEDS,..." with SEEDS "3" or "0-4"; one-line `SystemExit` on a bad item."""
    out: list[Search] = []
    for item in (t.strip() for t in text.split(",") if t.strip()):
        try:
            robot, rest = item.split("@")
            speed, seeds = rest.split(":")
            lo, _, hi = seeds.partition("-")
            first, last = int(lo), int(hi or lo)
            v = float(speed)
        except ValueError:
            raise SystemExit(f"--searches: expected ROBOT@SPEED:SEEDS (e.g. quad12@0.25:0-4), "
                             f"got {item!r}") from None
        if not robot or not (v > 0 and math.isfinite(v)) or first < 0 or last < first:
            raise SystemExit(f"--searches: {item!r} needs a robot, a speed > 0 and seeds "
                             "FIRST-LAST with 0 ≤ FIRST ≤ LAST")
        out.extend(Search(robot, v, s) for s in range(first, last + 1))
    if not out:
        raise SystemExit("--searches: no search given")
    return out


def record(search: Search, setting: Setting, r: SearchRun, load_start: float) -> dict[str, object]:
    """One run as a JSON-able row."""
    res = r.result
    return {
        "search": search.key, "setting": setting.name, **asdict(setting),
        "utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
        "load_start": load_start, "load_end": os.getloadavg()[0],
        "wall_s": r.wall_s, "cpu_s": r.cpu_s + r.worker_cpu_s, "main_cpu_s": r.cpu_s,
        "worker_cpu_s": r.worker_cpu_s, "phase_cpu_s": res.phase_cpu_s,
        "worker_solve_s": r.worker_s("solve_s"), "worker_accept_s": r.worker_s("accept_s"),
        "solves": r.solves,
        "iterations": r.iterations, "accepted": r.count("accepted"),
        "rejected": r.count("rejected"), "infeasible": r.count("infeasible"),
        "stopped": r.stopped(), "winner": res.label, "search_cost": res.search_cost,
        "best_template": res.best_template, "fallback_template": res.fallback_template,
        "final_cost": res.best.cost if res.best.feasible else None,
        "final_total": res.total_cost if res.best.feasible else None,
        "beaten_search_total": res.beaten_search_total,
        "final_solves": len(res.final_solves), "final_choice": res.final_choice,
        "verdict": r.verdict(), **retry_fields(res.final_outcomes), "final_retried":
        res.final_retried,
    }


def retry_fields(outcomes: Sequence[FinalOutcome]) -> dict[str, object]:
    """How often the final phase's full-cycle retry fired among the outcomes read and what it
    cost (`FinalOutcome.half_tried`): "retries", the half-cycle attempts' CPU ("retry_half_cpu_s",
    solve + check) and the full re-solves' ("retry_full_cpu_s")."""
    tried = [o for o in outcomes if o.half_tried is not None]
    half = sum(t.solve_cpu_s + t.check_cpu_s for t in (o.half_tried for o in tried) if t)
    return {"retries": len(tried), "retry_half_cpu_s": half,
            "retry_full_cpu_s": sum(o.solve_cpu_s + o.check_cpu_s for o in tried) - half,
            # every half-cycle plan read that did not pass: [how it failed, retried, its failed
            # criteria's relative excess (`FinalOutcome.excess`), the retry's verdict]
            "half_failed": [half_failed(o) for o in outcomes if o.half_failure]}


def half_failed(o: FinalOutcome) -> list[object]:
    """A half-cycle plan that did not pass, as a row field: [how it failed, retried, its failed
    criteria's relative excess, the retry's verdict (None: not retried)]."""
    excess = (o.half_tried or o).excess
    return [o.half_failure, o.half_tried is not None, [[n, e] for n, e in excess],
            o.ok if o.half_tried is not None else None]


def cmd_run(args: argparse.Namespace) -> None:
    settings = [parse_setting(s.strip()) for s in args.settings.split(",") if s.strip()]
    if not settings:
        raise SystemExit("--settings: no setting given")
    searches = parse_searches(args.searches)
    out = Path(args.out)
    save = Path(args.save) if args.save else None
    if save is not None and not save.is_dir():
        raise SystemExit(f"--save: {save} is not a directory; create it first")
    done = {(row["search"], row["setting"]) for row in _rows(out)} if out.exists() else set()
    for search in searches:
        for setting in settings:
            if (search.key, setting.name) in done:
                continue
            load = os.getloadavg()[0]
            r = run(search.robot, search.speed_m_s, setting.generations or args.generations,
                    args.workers, search.seed, True, "knot", "process", args.knots,
                    setting.warm_start, setting.abort, setting.swing_wrench, "stance",
                    search_swing_wrench=setting.search_swing_wrench,
                    search_max_iter=setting.search_max_iter, search_tol=setting.search_tol,
                    search_knots=setting.search_knots,
                    coarse_speed_tol=setting.coarse_speed_tol,
                    search_half_cycle=setting.search_half_cycle,
                    final_half_cycle=setting.final_half_cycle,
                    final_templates=setting.final_templates,
                    final_retry_full=setting.final_retry_full,
                    final_swing_wrench=setting.final_swing_wrench,
                    option_fields=option_fields(setting))
            row = record(search, setting, r, load)
            if save is not None:
                with (save / recording_name(search.key, setting.name)).open("wb") as fh:
                    pickle.dump(recording(search, setting, r, row, args.knots), fh)
            with out.open("a") as f:
                f.write(json.dumps(row) + "\n")
            print(_line(row), flush=True)


def recording_name(search: str, setting: str) -> str:
    """The file a run's recording is saved to (no "/" from a robot path)."""
    return f"{search}__{setting}.pkl".replace("/", "_")


def recording(search: Search, setting: Setting, r: SearchRun, row: dict, knots: int
              ) -> dict[str, object]:
    """What `replay` needs of a run: its local solves (template seeds first), the template
    names in seeding order, λ, and the recorded final phase's CPU (solve + check)."""
    res = r.result
    n_templates = len(res.template_costs)
    generations = res.cma.n_generations
    return {"search": asdict(search), "setting": asdict(setting), "row": row, "knots": knots,
            "records": list(res.samples), "templates": list(res.template_costs),
            "symmetric": res.symmetric, "generations": generations,
            "lam": (len(res.samples) - n_templates) // max(generations, 1),
            "final_cpu_s": sum(o.solve_cpu_s + o.check_cpu_s for o in res.final_outcomes)}


def _sample_cpu_s(result: LocalResult) -> float:
    return float(getattr(result, "cpu_s", 0.0)) + float(getattr(result, "accept_cpu_s", 0.0))


@dataclass
class FinalReplayer:
    """The final phase of one search (robot, speed, final options), run in this process; each
    schedule is solved and checked once (a cold solve is a function of the schedule)."""

    search: Search
    swing_wrench: str
    knots: int
    #: the final re-solves on the first half of a symmetric candidate's knots (as the search's
    #: `final_half_cycle`: `final_options`)
    half_cycle: bool = FINAL_HALF_CYCLE
    #: which candidates failed on half the knots are re-solved on the full NLP
    #: (`final_retry_full`: "all", "narrow", "off")
    retry_full: str = FINAL_RETRY_FULL
    #: the candidates' final re-solves' swing wrench (`search_gait(final_swing_wrench=)`; None:
    #: `swing_wrench`)
    final_swing_wrench: str | None = None
    #: further `PlannerOptions` fields of the recorded setting (`option_fields`)
    fields: tuple[tuple[str, object], ...] = ()

    def __post_init__(self) -> None:
        self.robot = robots.load(self.search.robot)
        self.options, acceptance = cli_search_options(self.robot, swing_wrench=self.swing_wrench,
                                                      speed_m_s=self.search.speed_m_s)
        self.options = replace(self.options, **dict(self.fields))
        #: the templates are solved as the template path plans them (`final_tasks`)
        self.template_half_cycle = self.options.half_cycle_solve
        self.template_swing_wrench = self.options.swing_wrench
        self.options = final_options(self.options, self.half_cycle, self.final_swing_wrench)
        self.seeds: dict[str, robots.ContactSchedule] = acceptance.get("seed_schedules", {})
        factory = acceptance["final_acceptance"]
        self.spec = FinalPlannerSpec.new(self.robot, self.knots, self.options,
                                         self.search.speed_m_s, factory)
        self.planner = GaitPlanner(self.robot, self.knots, self.options)
        self.check = factory()
        self.cache: dict[tuple[bool | float | str | None, ...], FinalOutcome] = {}

    def outcomes(self, tasks: Sequence[FinalTask]) -> Iterator[FinalOutcome]:
        for task in tasks:
            sch = task.schedule
            key = (task.half_cycle, task.retry_full, task.swing_wrench, sch.period_s,
                   *sch.touchdown_phase, *sch.duty_factor)
            if key not in self.cache:
                self.cache[key] = evaluate_task(self.planner, self.check, task)
            yield self.cache[key]

    def truncated(self, rec: dict, k: int, candidates: int = FINAL_CANDIDATES,
                  choice: str = FINAL_CHOICE_FIRST,
                  templates: str = DEFAULT_FINAL_TEMPLATES) -> dict[str, object]:
        """The row of `rec`'s search stopped after generation k (module docstring), its final
        phase re-solving up to `candidates` timings (`search_gait(final_candidates=...)`),
        choosing among them by `choice` (`search_gait(final_choice=...)`) and, with
        `templates` "compete", holding the winner against the cheapest accepted template
        (`search_gait(final_templates=...)`)."""
        records: list = rec["records"]
        names: list[str] = rec["templates"]
        n_t = len(names)
        cut = records[: n_t + rec["lam"] * k]
        seed_results = {name: r for name, (_, r) in zip(names, records[:n_t], strict=True)}
        costs = {name: (r.cost if r.feasible else math.inf) for name, r in seed_results.items()}
        best = min(costs, key=lambda n: costs[n])
        start = (records[names.index(best)][0], seed_results[best])
        space = TimingSpace.for_robot(self.robot, rec["symmetric"])
        own = {name: self.seeds.get(name) or make_schedule(self.robot, name) for name in names}
        tasks, searched, rival = ordered_final_tasks(
            self.spec, space, cut, candidates, start, seed_results, own, choice, templates,
            self.template_half_cycle, self.retry_full if self.half_cycle else FINAL_RETRY_OFF,
            self.template_swing_wrench)
        c0 = time.process_time()
        tipping = TippingCost.for_robot(self.robot, DEFAULT_TIPPING_WEIGHT)

        def total(plan: PlanResult) -> float:
            """The search's objective at full resolution (`search_gait`'s final score)."""
            return plan.cost + tipping(plan.schedule)

        chosen = choose_final(tasks, searched, self.outcomes(tasks), choice, total, rival)
        replay_cpu = sum(o.solve_cpu_s + o.check_cpu_s for o in chosen.read)
        base: dict = rec["row"]
        dropped = sum(_sample_cpu_s(r) for _, r in records[len(cut):])
        plan = chosen.plan
        verdict = ("infeasible" if not plan.feasible else
                   {True: "MuJoCo pass", False: "MuJoCo FAIL", None: "not simulated"}[
                       chosen.accepted])
        return {
            **base, "setting": replay_setting(base["setting"], k, candidates, choice),
            "generations": k, "final_candidates": candidates, "final_choice": choice,
            "final_templates": templates, "beaten_search_total": chosen.beaten_score,
            "utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
            "load_start": os.getloadavg()[0], "load_end": os.getloadavg()[0],
            "cpu_s": base["cpu_s"] - dropped - rec["final_cpu_s"] + replay_cpu,
            "solves": len(cut), "iterations": sum(max(r.n_fevals - 1, 0) for _, r in cut),
            "winner": label_gait(plan.schedule, self.robot), "search_cost": chosen.searched.cost,
            "best_template": best, "fallback_template": chosen.fallback_template,
            "final_cost": plan.cost if plan.feasible else None,
            "final_total": total(plan) if plan.feasible else None,
            "final_solves": len(chosen.read),
            # every outcome read, in order: [full-resolution cost + support term (None:
            # infeasible), verdict] — any "cheapest of the first m" rule can be computed from it
            "final_read": [[total(o.plan) if o.plan.feasible else None, o.ok]
                           for o in chosen.read], "verdict": verdict, "replayed": True,
            **retry_fields(chosen.read),
            "final_retried": chosen.retried,
            "replay_cpu_s": time.process_time() - c0,
        }


def recorded_setting(rec: dict) -> Setting:
    """The setting a recording was made with: one made before session 40 has no
    `final_swing_wrench` (its final re-solves took the options' own: None), one made before
    session 42 no `cold_mu_centrality` ("none") and no `separation_unit_leg_lengths` (metres:
    None)."""
    return Setting(**{"final_swing_wrench": None, "cold_mu_centrality": "none",
                      "separation_unit_leg_lengths": None, **rec["setting"]})


def replay_setting(setting: str, k: int, candidates: int,
                   choice: str = FINAL_CHOICE_FIRST) -> str:
    """The name of a replayed row: "SETTING+genK", "+finalC" if C is not the default,
    "+CHOICE" if the final choice is not "first"."""
    return (f"{setting}+gen{k}" + ("" if candidates == FINAL_CANDIDATES else f"+final{candidates}")
            + ("" if choice == FINAL_CHOICE_FIRST else f"+{choice}"))


def cmd_replay(args: argparse.Namespace) -> None:
    ks = _generations(args.generations)
    cs = _integers("--final-candidates", args.final_candidates, "4,8")
    rivals = _names("--final-templates", args.final_templates, FINAL_TEMPLATES)
    choices = _names("--final-choice", args.final_choice, FINAL_CHOICES)
    recs = []
    for name in args.recordings:
        try:
            with open(name, "rb") as fh:
                recs.append(pickle.load(fh))
        except (OSError, pickle.UnpicklingError, EOFError) as e:
            raise SystemExit(f"replay: cannot read recording {name}: {e}") from None
    out = Path(args.out)
    done = {(row["search"], row["setting"]) for row in _rows(out)} if out.exists() else set()
    replayers: dict[tuple[object, ...], FinalReplayer] = {}
    for rec in recs:
        search, setting = Search(**rec["search"]), recorded_setting(rec)
        recorded = (setting.final_half_cycle, setting.final_retry_full)
        policy = recorded if args.final_half_cycle is None else FINAL_SOLVE_TOKENS[
            REPLAY_FINAL_SOLVES[args.final_half_cycle]]
        # a policy that does not re-solve on half the knots retries nothing
        same = policy == recorded or not (policy[0] or recorded[0])
        final_swing = (setting.final_swing_wrench if args.final_swing_wrench is None
                       else args.final_swing_wrench)
        swing_name = ("" if final_swing == setting.final_swing_wrench else
                      f"+final{final_swing}")
        for k, c, ch, tm in ((k, c, ch, tm) for tm in rivals for ch in choices for c in cs
                             for k in ks):
            name = replay_setting(setting.name, k, c, ch) + (
                "" if same else final_solve_token(*policy)) + (
                "" if tm == setting.final_templates else f"+{tm}") + swing_name
            if k > rec["generations"] or (search.key, name) in done:
                continue
            key = (search.key, setting.swing_wrench, rec["knots"], *policy, final_swing,
                   option_fields(setting))
            if key not in replayers:
                replayers.clear()  # one search's planner at a time
                replayers[key] = FinalReplayer(search, setting.swing_wrench, rec["knots"],
                                               *policy, final_swing, option_fields(setting))
            row = {**replayers[key].truncated(rec, k, c, ch, tm), "setting": name}
            with out.open("a") as f:
                f.write(json.dumps(row) + "\n")
            print(_line(row), flush=True)


def rule_row(rec: dict, rows: dict[tuple[str, str], dict], generations: int | None = None
             ) -> tuple[dict, str]:
    """`rec`'s search, stopped after `generations` (None: as recorded), under the final-candidate
    rule (module docstring): its replayed row renamed, and a line saying what the rule chose and
    why."""
    records: list = rec["records"]
    n_t, lam = len(rec["templates"]), rec["lam"]
    dim = len(records[0][0])
    k = rec["generations"] if generations is None else generations
    if k > rec["generations"]:
        raise SystemExit(f"rule: {rec['row']['search']} was recorded with {rec['generations']} "
                         f"generations, --generations asks for {k}")
    cut = records[: n_t + lam * k]
    candidates = final_candidate_count(cut)
    setting = rec["row"]["setting"]
    name = replay_setting(setting, k, candidates)
    key = (rec["row"]["search"], name)
    if key not in rows:
        raise SystemExit(f"rule: no row {name!r} of {key[0]} in --runs; make it with "
                         f"`replay RECORDING --generations {k} --final-candidates {candidates}`")
    accepted = sum(1 for _, r in cut if r.feasible)
    named = f"{setting}+rule" if generations is None else f"{setting}+gen{k}+rule"
    row = {**rows[key], "setting": named, "rule": name, "dim": dim, "lam": lam,
           "rule_generations": k, "rule_final_candidates": candidates,
           "coarse_accepted": accepted}
    line = (f"{key[0]}: dimension {dim}, λ {lam}, {k} generations; {accepted} of {len(cut)} "
            f"samples accepted → {candidates} final candidates ({final_candidates_reason(cut)}): "
            f"{name}")
    return row, line


def cmd_rule(args: argparse.Namespace) -> None:
    if args.generations is not None and args.generations < 1:
        raise SystemExit(f"--generations: expected an integer ≥ 1, got {args.generations}")
    rows = {(r["search"], r["setting"]): r for r in _rows(Path(args.runs))}
    out = Path(args.out)
    done = {(row["search"], row["setting"]) for row in _rows(out)} if out.exists() else set()
    for name in args.recordings:
        try:
            with open(name, "rb") as fh:
                rec = pickle.load(fh)
        except (OSError, pickle.UnpicklingError, EOFError) as e:
            raise SystemExit(f"rule: cannot read recording {name}: {e}") from None
        row, line = rule_row(rec, rows, args.generations)
        print(line, flush=True)
        if (row["search"], row["setting"]) not in done:
            with out.open("a") as f:
                f.write(json.dumps(row) + "\n")


def _generations(text: str) -> list[int]:
    return _integers("--generations", text, "2,3,4,5,6")


def _names(option: str, text: str, allowed: Sequence[str]) -> list[str]:
    """Comma-separated names, each one of `allowed`; one-line `SystemExit` naming `option`
    otherwise."""
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names or any(t not in allowed for t in names):
        raise SystemExit(f"replay: {option} must be a comma-separated list of "
                         f"{', '.join(allowed)}, got {text!r}")
    return names


def _integers(option: str, text: str, example: str) -> list[int]:
    """Comma-separated integers ≥ 1; one-line `SystemExit` naming `option` otherwise."""
    try:
        ks = [int(k) for k in text.split(",") if k.strip()]
    except ValueError:
        ks = []
    if not ks or min(ks) < 1:
        raise SystemExit(f"{option}: expected comma-separated integers ≥ 1 "
                         f"(e.g. {example}), got {text!r}")
    return ks


def _rows(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _line(row: dict) -> str:
    cost = "—" if row["final_cost"] is None else f"{row['final_cost']:.6g}"
    fb = f" (fallback {row['fallback_template']})" if row["fallback_template"] else ""
    return (f"| {row['search']} | {row['setting']} | {row['cpu_s']:.1f} | {row['iterations']} | "
            f"{row['solves']} | {row['winner']}{fb} | {row['search_cost']:.5g} | {cost} | "
            f"{row['verdict']} | {row['utc'][11:16]} | {row['load_start']:.1f}→"
            f"{row['load_end']:.1f} |")


def passing(row: dict) -> bool:
    return row["verdict"] == "MuJoCo pass"


def sign_test_p(better: int, worse: int) -> float:
    """Two-sided exact sign test of `better` vs `worse` (ties dropped): scipy's binomial test
    at p = 1/2."""
    n = better + worse
    return 1.0 if n == 0 else float(binomtest(better, n, 0.5).pvalue)


def geo_ci(ratios: list[float]) -> str:
    """Geometric mean of the ratios and its two-sided 95 % Student-t interval (on the logs)."""
    if len(ratios) < 2:
        return "—"
    logs = [math.log(q) for q in ratios]
    m, se = statistics.fmean(logs), statistics.stdev(logs) / math.sqrt(len(logs))
    h = float(student_t.ppf(0.975, len(logs) - 1)) * se
    return f"{math.exp(m):.3f} [{math.exp(m - h):.3f}, {math.exp(m + h):.3f}]"


def _final_pair(base: dict, row: dict, cost: str) -> tuple[float, float]:
    """The two rows' final costs: the NLP's (`cost` "nlp"), or cost + support term, what the
    search minimises ("total": rows of `replay`, and of `run` since session 37)."""
    key = "final_total" if cost == "total" else "final_cost"
    if base.get(key) is None or row.get(key) is None:
        raise SystemExit(f"table --cost {cost}: {base['search']} has no {key} in setting "
                         f"{base['setting']!r} or {row['setting']!r} (rows before session 37 "
                         "have only the NLP cost: --cost nlp)")
    return base[key], row[key]


def summary(rows: list[dict], baseline: str, cost: str = "nlp") -> list[str]:
    """Per setting against `baseline`, over the searches both ran."""
    by = {(r["search"], r["setting"]): r for r in rows}
    searches = list(dict.fromkeys(r["search"] for r in rows))
    settings = list(dict.fromkeys(r["setting"] for r in rows))
    if baseline not in settings:
        raise SystemExit(f"--baseline: no run of setting {baseline!r} (have {', '.join(settings)})")
    lines = ["| setting | searches | CPU total ratio | CPU median ratio | CPU geometric mean "
             "[95 % CI] | iterations ratio | "
             "final cost ratio median / mean (best, worst) | geometric mean [95 % CI] | "
             "better / same / worse | sign test p | "
             "no passing gait (baseline) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in settings:
        pairs = [(by[(k, baseline)], by[(k, s)]) for k in searches
                 if (k, baseline) in by and (k, s) in by]
        if not pairs:
            continue
        cpu = [b["cpu_s"] for b, _ in pairs], [r["cpu_s"] for _, r in pairs]
        it = sum(b["iterations"] for b, _ in pairs), sum(r["iterations"] for _, r in pairs)
        costs = [_final_pair(b, r, cost) for b, r in pairs if passing(b) and passing(r)]
        ratios = [c / cb for cb, c in costs]
        better = sum(q < 1 - SAME_REL for q in ratios)
        worse = sum(q > 1 + SAME_REL for q in ratios)
        med = statistics.median(ratios) if ratios else math.nan
        mean = statistics.fmean(ratios) if ratios else math.nan
        lo, hi = (min(ratios), max(ratios)) if ratios else (math.nan, math.nan)
        lines.append(
            f"| {s} | {len(pairs)} | {sum(cpu[1]) / sum(cpu[0]):.3f} | "
            f"{statistics.median(r / b for b, r in zip(*cpu, strict=True)):.3f} | "
            f"{geo_ci([r / b for b, r in zip(*cpu, strict=True)])} | "
            f"{it[1] / it[0]:.3f} | {med:.4f} / {mean:.4f} ({lo:.3f}, {hi:.3f}) | "
            f"{geo_ci(ratios)} | {better} / "
            f"{len(ratios) - better - worse} / {worse} | {sign_test_p(better, worse):.2f} | "
            f"{sum(not passing(r) for _, r in pairs)} ({sum(not passing(b) for b, _ in pairs)}) |")
    return lines


def cmd_table(args: argparse.Namespace) -> None:
    rows = _rows(Path(args.runs))
    print("| search | setting | CPU [s] | iterations | solves | winner | search cost | "
          "final cost | MuJoCo | UTC | load |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        print(_line(row))
    print()
    print("\n".join(summary(rows, args.baseline, args.cost)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run the searches under every setting")
    r.add_argument("--searches", required=True, help="ROBOT@SPEED:SEEDS,... (seeds 3 or 0-4)")
    r.add_argument("--settings", default="base,coarse-bounds",
                   help="comma-separated settings, each +-joined tokens (see above)")
    r.add_argument("--out", required=True, help="JSON-lines file the runs are appended to")
    r.add_argument("--generations", type=int, default=6)
    r.add_argument("--workers", type=int, default=2)
    r.add_argument("--knots", type=int, default=30, help="knots of the final gait")
    r.add_argument("--save", help="directory to pickle each run's recording into (for replay)")
    p = sub.add_parser("replay", help="--generations k evaluated exactly on saved recordings")
    p.add_argument("recordings", nargs="+", help="pickles written by `run --save`")
    p.add_argument("--generations", default="2,3,4,5,6",
                   help="comma-separated k (a k above the recording's generations is skipped)")
    p.add_argument("--final-candidates", default=str(FINAL_CANDIDATES),
                   help="comma-separated counts of timings the final phase re-solves (the "
                        f"search's default: {FINAL_CANDIDATES}); rows named SETTING+genK+finalC "
                        "if not the default; one invocation solves each schedule once")
    p.add_argument("--final-choice", default=DEFAULT_FINAL_CHOICE,
                   help=f"comma-separated: {', '.join(FINAL_CHOICES)} (how the final phase picks "
                        f"among its candidates; default {DEFAULT_FINAL_CHOICE}, as the search; "
                        "rows are named '+CHOICE' unless 'first')")
    p.add_argument("--final-half-cycle", choices=tuple(REPLAY_FINAL_SOLVES), default=None,
                   help="re-solve the final candidates on the first half of a symmetric one's "
                        "knots (on), on all of them (off), on the first half with a failed "
                        "one re-solved on all of them (retry), or only one that fails the check "
                        "narrowly (narrow; `PlannerOptions.half_cycle_solve`,"
                        " `search_gait(final_retry_full=)`; rows named '+halffinal' / "
                        "'+fullfinal' / '+halfretry' / '+halfnarrow' when not as recorded; "
                        "default: as the recorded search did)")
    p.add_argument("--final-swing-wrench", choices=SWING_WRENCHES, default=None,
                   help="the candidates' final re-solves' swing wrench (`search_gait("
                        "final_swing_wrench=)`; the templates keep the recorded search's own; "
                        "rows named '+finalrows' / '+finalbounds' when not as recorded; "
                        "default: as the recorded search did)")
    p.add_argument("--final-templates", default=DEFAULT_FINAL_TEMPLATES,
                   help=f"comma-separated: {', '.join(FINAL_TEMPLATES)} (the templates only as "
                        "the fallback, or also held against the searched winner; rows named "
                        "'+compete' / '+fallback' when not as recorded)")
    p.add_argument("--out", required=True, help="JSON-lines file the rows are appended to")
    u = sub.add_parser("rule", help="each recording's replayed row under the budget rule")
    u.add_argument("recordings", nargs="+", help="pickles written by `run --save`")
    u.add_argument("--runs", required=True, help="JSON lines holding the replayed rows")
    u.add_argument("--out", required=True, help="JSON-lines file the rule's rows are appended to")
    u.add_argument("--generations", type=int, default=None,
                   help="stop each recording after this many generations (default: as recorded)")
    t = sub.add_parser("table", help="every run, and each setting against the baseline")
    t.add_argument("runs", help="the JSON-lines file of `run --out`")
    t.add_argument("--baseline", default="base")
    t.add_argument("--cost", choices=("nlp", "total"), default="nlp",
                   help="final cost compared: the NLP's, or + the support term (the search's "
                        "objective; what --final-templates compete and cheapest-of-2 compare)")
    args = ap.parse_args()
    {"run": cmd_run, "table": cmd_table, "replay": cmd_replay, "rule": cmd_rule}[args.command](args)


if __name__ == "__main__":
    main()

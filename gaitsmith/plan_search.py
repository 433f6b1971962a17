"""`gaitsmith plan ROBOT --search`: basin-CMA over the contact timings (W&P 2009 §4.1.1),
seeded with the templates and the user's own schedule, then the best gait and its search log
written next to each other (`planner.search.gait_search`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import robots
from gaitsmith.attitude_options import attitude_settings, resolved_gain
from gaitsmith.console import console
from gaitsmith.plan_output import DEFAULT_CYCLES, write_gait
from gaitsmith.search_options import sim_acceptance
from planner.errors import InfeasibleGaitError
from planner.nlp.config import PlannerOptions
from planner.search.budget import REASON_NONE_ACCEPTED
from planner.search.defaults import (
    DEFAULT_FINAL_CHOICE,
    DEFAULT_FINAL_TEMPLATES,
    FINAL_HALF_CYCLE,
    FINAL_SWING_WRENCH,
    SEARCH_HALF_CYCLE,
    SEARCH_INACTIVE_ROWS,
    SEARCH_SWING_WRENCH,
)
from planner.templates import default_gait_for
from planner.user_schedule import command_schedule
from robots.voltage import voltage_margin

USER_SEED = "your schedule"  # the name the user's --period/--duty/--phases/--schedule seed has


@dataclass(frozen=True)
class SearchSettings:
    """The `--search` options, as given on the command line."""

    generations: int
    popsize: int | None
    seed: int
    symmetric: bool
    executor: str
    workers: int | None
    address: str | None
    search_knots: int
    tipping_weight: float
    sim_accept: bool
    #: `PlannerOptions.swing_wrench` of the coarse solves (`--search-swing-wrench`)
    search_swing_wrench: str = SEARCH_SWING_WRENCH
    #: how the final phase picks its winner (`--final-choice`)
    final_choice: str = DEFAULT_FINAL_CHOICE
    #: the coarse solves on the first half of a symmetric sample's knots (`--search-half-cycle`)
    search_half_cycle: bool = SEARCH_HALF_CYCLE
    #: the templates only as the fallback, or competing with the winner (`--final-templates`)
    final_templates: str = DEFAULT_FINAL_TEMPLATES
    #: the final re-solves on the first half of a symmetric timing's knots (`--half-cycle`
    #: given; unset: `FINAL_HALF_CYCLE`, `gaitsmith.plan_options.search_final_half_cycle`)
    final_half_cycle: bool = FINAL_HALF_CYCLE
    #: `PlannerOptions.swing_wrench` of the candidates' final re-solves (`--final-swing-wrench`)
    final_swing_wrench: str = FINAL_SWING_WRENCH


def user_seed(bot: robots.Robot, gait: str | None, period: float | None, duty: str | None,
              phases: str | None, schedule_file: Path | None,
              ) -> tuple[str | None, robots.ContactSchedule | None]:
    """`--gait` and the user's own schedule seed, if any: --period/--duty/--phases/--schedule
    with --search seed it beside the templates (never ignored), built on --gait, which is then
    used up (None)."""
    if all(v is None for v in (period, duty, phases, schedule_file)):
        return gait, None
    schedule, _ = command_schedule(bot, gait or default_gait_for(bot), phases=phases, duty=duty,
                                   schedule_file=schedule_file, period_s=period)
    return None, schedule


def plan_search(bot: robots.Robot, gait: str | None, speed: float, output: Path, knots: int,
                st: SearchSettings, simulate: bool, cycles: int | None,
                supply_v: float | None, options: PlannerOptions, entry_cycles: int,
                seed_schedule: robots.ContactSchedule | None = None,
                extra_meta: dict[str, Any] | None = None,
                attitude_gain: float | None = None) -> None:
    """Search, print its progress and result, write the best gait (with `extra_meta` and the
    search's own record) and the search log. Every MuJoCo run — the acceptance of each sample
    and candidate, `--simulate`'s verdict — uses the attitude feedback the gait gets
    (`attitude_gain`, else the robot's rule per gait: `robots.attitude.gait_attitude_gain`)."""
    from planner.search.gait_search import SearchLogRow, search_gait, write_search_log

    if gait is not None:
        console.print(f"[yellow]--search starts from every template; --gait {gait} is ignored[/]")
    if seed_schedule is not None:
        console.print(f"  seeding also with your schedule (period {seed_schedule.period_s:.3f} "
                      f"s, duty {'/'.join(f'{d:.2f}' for d in seed_schedule.duty_factor)}): "
                      f"\"{USER_SEED}\"")
    console.print(f"searching gaits for [bold]{bot.name}[/] at {speed:.3f} m/s "
                  f"(basin-CMA, {st.generations} generations, executor {st.executor}, "
                  f"samples scored at {st.search_knots} knots"
                  + (", MuJoCo acceptance" if st.sim_accept else "")
                  + (", final re-solves on half the knots (a narrow MuJoCo failure re-solved "
                     "on all)" if st.final_half_cycle else ", final re-solves on all knots")
                  + ")")

    def progress(row: SearchLogRow) -> None:
        if row.generation < 0:
            console.print("  seeding with the gait templates…")
            return
        console.print(
            f"  gen {row.generation:3d}  best cost {row.best_cost:.5g}  feasible "
            f"{row.n_feasible}  solves {row.n_local_solves:4d}  {row.elapsed_s:6.1f} s  mean: "
            f"{row.gait_label}, period {row.period_s:.3f} s, duty "
            + "/".join(f"{d:.2f}" for d in row.duty_factor)
        )

    result = search_gait(
        bot, speed, n_knots=knots, options=options, symmetric=st.symmetric,
        max_generations=st.generations, popsize=st.popsize, seed=st.seed, executor=st.executor,
        workers=st.workers, address=st.address, search_knots=st.search_knots,
        tipping_weight=st.tipping_weight, progress=progress,
        search_swing_wrench=st.search_swing_wrench, final_choice=st.final_choice,
        search_half_cycle=st.search_half_cycle, final_templates=st.final_templates,
        final_half_cycle=st.final_half_cycle, final_swing_wrench=st.final_swing_wrench,
        seed_schedules=None if seed_schedule is None else {USER_SEED: seed_schedule},
        **sim_acceptance(bot, st.sim_accept, cycles or DEFAULT_CYCLES, entry_cycles,
                         attitude_gain),
    )
    for name, cost in result.template_costs.items():
        console.print(f"  template {name:18s} cost {cost:.5g}")
    best = result.best
    if not best.feasible:
        raise InfeasibleGaitError(
            f"{bot.name} at {speed} m/s: no feasible gait found; {best.message}; "
            "no gait file written; try a lower --speed or more --generations", best.binding)
    console.print(
        f"best gait: [bold]{result.label}[/], search cost {result.search_cost:.5g} (best "
        f"template {result.best_template}: {result.best_template_cost:.5g}; both at "
        f"{result.search_knots} knots incl. the tipping term), final cost at {knots} knots "
        f"{best.cost:.5g} + tipping {result.support_cost:.4g}, period "
        f"{best.schedule.period_s:.3f} s, duty "
        + "/".join(f"{d:.2f}" for d in best.schedule.duty_factor)
        + f", cost of transport {result.cost_of_transport:.3f}, Froude {result.froude:.3f}, "
        f"{result.cma.n_local_solves} local solves in {result.elapsed_s:.1f} s"
    )
    if result.final_candidates_reason == REASON_NONE_ACCEPTED:
        console.print(f"  the coarse MuJoCo check accepted no sample: up to "
                      f"{result.final_candidates} searched timings re-solved at {knots} knots")
    if result.accepted is False:
        console.print("[yellow]no searched candidate passed the MuJoCo acceptance check; "
                      "writing the cheapest feasible one[/]")
    if result.beaten_search_total is not None:
        console.print(f"  the template {result.fallback_template} at {knots} knots costs "
                      f"{best.cost + result.support_cost:.5g} (cost + tipping), less than the "
                      f"searched winner's {result.beaten_search_total:.5g}: writing the template")
    elif result.fallback_template is not None:
        console.print(f"[yellow]no searched timing passed the MuJoCo acceptance; the template "
                      f"{result.fallback_template} re-solved at {knots} knots did: writing it[/]")
    meta: dict[str, object] = {"search": {
        "method": "basin-CMA (W&P 2009 §4.1.1)", "generations": result.cma.n_generations,
        # the final phase's searched timings and why (`planner.search.budget`)
        "final_candidates": result.final_candidates,
        "final_candidates_reason": result.final_candidates_reason,
        "final_choice": st.final_choice,
        "search_half_cycle": st.search_half_cycle,
        "final_half_cycle": st.final_half_cycle,
        # which candidates failed on half the knots are re-solved full ("all", "narrow", "off":
        # `search_gait(final_retry_full=)`), whether the written plan is such a retry
        # (planner.solver.half_cycle then false) and why (how its half-cycle plan failed)
        "final_retry_full": result.final_retry_full, "final_retried": result.final_retried,
        "final_retry_reason": result.final_retry_reason,
        "final_templates": st.final_templates,
        "beaten_search_total": result.beaten_search_total,
        "local_solves": result.cma.n_local_solves, "elapsed_s": result.elapsed_s,
        "seed": st.seed, "symmetric": result.symmetric,  # as searched (a star has no pairs)
        "template_costs": {  # JSON has no inf: null = infeasible or rejected
            name: cost if math.isfinite(cost) else None
            for name, cost in result.template_costs.items()},
        "best_template": result.best_template, "search_cost": result.search_cost,
        "search_feasible": result.search_feasible,
        "search_knots": result.search_knots, "tipping_weight": st.tipping_weight,
        "search_swing_wrench": st.search_swing_wrench,
        "final_swing_wrench": st.final_swing_wrench,
        "search_inactive_rows": SEARCH_INACTIVE_ROWS,  # the final solves': planner.solver
        "tipping_amplification": result.tipping_amplification,
        "sim_accepted": result.accepted, "fallback_template": result.fallback_template,
        "cost_of_transport": result.cost_of_transport,
        "froude": result.froude,
    }}
    meta.update(extra_meta or {})  # supply_v, servo_params, entry cycles, stance compliance
    if supply_v is not None:
        console.print(voltage_margin(bot, best.joint_torques_nm, supply_v).summary())
    gait_obj = result.planner.to_gait(best, result.label, extra_metadata=meta)
    log_path = output.with_suffix(".search.csv")
    write_search_log(result, log_path)
    console.print(f"search log: {log_path}")
    attitude = attitude_settings(resolved_gain(attitude_gain, bot, gait_obj) if simulate else None)
    write_gait(gait_obj, bot, output, simulate, cycles, attitude=attitude)

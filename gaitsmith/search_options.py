"""Command-line options shared by `gaitsmith plan --search` and `gaitsmith sweep`."""

from __future__ import annotations

from typing import Any

import typer

import robots
from gaitsmith.errors import OptionError
from gaitsmith.options import check_choice, check_integer, check_knots, check_number
from planner.nlp.config import SWING_WRENCHES
from planner.search.defaults import (
    DEFAULT_FINAL_CHOICE,
    DEFAULT_FINAL_TEMPLATES,
    DEFAULT_SEARCH_KNOTS,
    DEFAULT_TIPPING_WEIGHT,
    FINAL_CHOICES,
    FINAL_SWING_WRENCH,
    FINAL_TEMPLATES,
    SEARCH_HALF_CYCLE,
    SEARCH_SWING_WRENCH,
)

EXECUTORS = ("serial", "process", "ray")


def executor_option() -> Any:
    return typer.Option("process", "--executor", help="serial | process | ray")


def workers_option() -> Any:
    return typer.Option(None, "--workers", help="parallel workers (default: one per core)")


def search_knots_option() -> Any:
    return typer.Option(DEFAULT_SEARCH_KNOTS, "--search-knots",
                        help="knots of the coarse NLP scoring each sample; the gait uses --knots")


def tipping_weight_option() -> Any:
    return typer.Option(DEFAULT_TIPPING_WEIGHT, "--tipping-weight",
                        help="weight of the open-loop tipping term; 0: the pure W&P objective")


def search_swing_wrench_option() -> Any:
    return typer.Option(SEARCH_SWING_WRENCH, "--search-swing-wrench",
                        help="how the coarse solves hold a swing foot's wrench at 0: rows | "
                        "bounds (fewer iterations; another draw of the search's course); the "
                        "final re-solves take --final-swing-wrench")


def final_swing_wrench_option() -> Any:
    return typer.Option(FINAL_SWING_WRENCH, "--final-swing-wrench",
                        help="how the final re-solves of the searched candidates hold a swing "
                        "foot's wrench at 0: rows | bounds; the templates they compete with "
                        "are planned as plan --gait plans them (bounds)")


def search_half_cycle_option() -> Any:
    return typer.Option(SEARCH_HALF_CYCLE, "--search-half-cycle/--search-full-cycle",
                        help="solve each symmetric sample's coarse NLP on the first half of its "
                        "knots, the second half its mirror image (half the KKT system), or on "
                        "all of them; the final re-solves follow --half-cycle/--full-cycle "
                        "(unset: the candidates and templates on half the knots where the "
                        "timing is symmetric, a candidate failing the check narrowly re-solved "
                        "on all)")


def final_choice_option() -> Any:
    return typer.Option(DEFAULT_FINAL_CHOICE, "--final-choice",
                        help="which re-solved candidate wins: first (the first accepted in "
                        "coarse rank order) | cheapest-of-2 (the cheaper accepted of the first "
                        "two at --knots) | cheapest (every candidate re-solved, the accepted one "
                        "cheapest at --knots wins)")


def final_templates_option() -> Any:
    return typer.Option(DEFAULT_FINAL_TEMPLATES, "--final-templates",
                        help="the templates the search started from: fallback (re-solved at "
                        "--knots only if no searched timing passes) | compete (those whose "
                        "coarse plan solved are re-solved too, as plan --gait NAME plans them, "
                        "and the cheapest that passes is written if it beats the searched "
                        "winner); either way a template is solved as plan --gait plans it")


def check_final_templates(value: str) -> None:
    check_choice("--final-templates", value, FINAL_TEMPLATES)


def check_final_choice(value: str) -> None:
    check_choice("--final-choice", value, FINAL_CHOICES)


def check_swing_wrench(option: str, value: str) -> None:
    if value not in SWING_WRENCHES:
        raise OptionError(f"{option} must be {' or '.join(SWING_WRENCHES)}, got {value!r}")


def sim_accept_option() -> Any:
    return typer.Option(True, "--sim-accept/--no-sim-accept",
                        help="reject samples whose gait does not walk in MuJoCo (slower)")


def check_executor(executor: str) -> None:
    if executor not in EXECUTORS:
        raise OptionError(
            f"--executor must be {', '.join(EXECUTORS[:-1])} or {EXECUTORS[-1]}, got {executor!r}")


MAX_GENERATIONS = 10_000
MAX_POPSIZE = 10_000
MAX_WORKERS = 1024
MAX_TIPPING_WEIGHT = 1e6


def check_search_options(executor: str, generations: int, popsize: int | None,
                         workers: int | None, search_knots: int, tipping_weight: float) -> None:
    """The shared search options in range (one-line `OptionError`s), before any solve."""
    check_executor(executor)
    check_integer("--generations", generations, 1, MAX_GENERATIONS)
    check_integer("--popsize", popsize, 2, MAX_POPSIZE)  # CMA-ES needs λ ≥ 2
    check_integer("--workers", workers, 1, MAX_WORKERS)
    check_knots("--search-knots", search_knots)
    check_number("--tipping-weight", tipping_weight, 0.0, MAX_TIPPING_WEIGHT)


def sim_acceptance(robot: robots.Robot, enabled: bool, final_cycles: int,
                   entry_cycles: int = 1, attitude_gain: float | None = None) -> dict[str, Any]:
    """`search_gait` keyword arguments for MuJoCo acceptance: samples are judged with the search
    criteria, the full-resolution candidates with the default ones over `final_cycles` — the
    cycles of the command's own `--simulate` validation, so that a gait that passed acceptance
    passes it too — both with the attitude feedback each gait gets (`attitude_gain`, i.e.
    ``--attitude-gain``, else the robot's rule per gait: `robots.attitude.gait_attitude_gain`)
    as `--simulate` then runs it (sim is imported only if enabled)."""
    if not enabled:
        return {}
    from sim.acceptance import SimAcceptance
    from sim.validate import PassCriteria

    root = str(robot.root_dir)
    return {"acceptance": SimAcceptance(root, entry_cycles=entry_cycles,
                                        attitude_gain=attitude_gain),
            "final_acceptance": SimAcceptance(root, final_cycles, PassCriteria(), entry_cycles,
                                              attitude_gain)}

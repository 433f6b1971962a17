"""Command-line options shared by `gaitsmith plan --search` and `gaitsmith sweep`."""

from __future__ import annotations

from typing import Any

import typer

import robots
from planner.errors import PlannerConfigError
from planner.gait_search import DEFAULT_SEARCH_KNOTS, DEFAULT_TIPPING_WEIGHT

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


def sim_accept_option() -> Any:
    return typer.Option(True, "--sim-accept/--no-sim-accept",
                        help="reject samples whose gait does not walk in MuJoCo (slower)")


def check_executor(executor: str) -> None:
    if executor not in EXECUTORS:
        raise PlannerConfigError(
            f"--executor must be {', '.join(EXECUTORS[:-1])} or {EXECUTORS[-1]}, got {executor!r}")


def sim_acceptance(robot: robots.Robot, enabled: bool, final_cycles: int) -> dict[str, Any]:
    """`search_gait` keyword arguments for MuJoCo acceptance: samples are judged with the search
    criteria, the full-resolution candidates with the default ones over `final_cycles` — the
    cycles of the command's own `--simulate` validation, so that a gait that passed acceptance
    passes it too (sim is imported only if enabled)."""
    if not enabled:
        return {}
    from sim.acceptance import SimAcceptance
    from sim.validate import PassCriteria

    root = str(robot.root_dir)
    return {"acceptance": SimAcceptance(root),
            "final_acceptance": SimAcceptance(root, final_cycles, PassCriteria())}

"""The gait search's budget by body: how many basin-CMA generations a search runs when none is
asked for, and how many of its cheapest timings the final phase re-solves.

Generations by the search's dimension (`TimingSpace.dim`: the period, the searched feet's
relative touchdown phases and their duty factors). A symmetric quadruped or biped searches
n ≤ 4 timing variables (period, one relative phase, two duties; a biped two), a symmetric
hexapod 6, a five-leg star 10. CMA-ES's population (4 + ⌊3 ln n⌋, `basin_cma.default_popsize`) and the
generations it needs to adapt its covariance both grow with n; over the recorded searches the
small spaces had settled after 4 generations (every quad12, spotmicro, bittle8, knee8 and biped
search wrote the same gait at 4 as at 6 generations) and the hexapods still improved in
generations 4-5 (docs/results/planner_speed_search.md, sessions 33 and 34). So n ≤
`SMALL_SEARCH_DIM` gets `SMALL_SEARCH_GENERATIONS`, every larger space `DEFAULT_GENERATIONS`.

Final candidates: `FINAL_CANDIDATES` of the cheapest timings, or `FINAL_CANDIDATES_NONE_ACCEPTED`
when the coarse MuJoCo check accepted no sample of the search (every candidate is then a plan
the coarse check rejected, ranked by cost only, and the one that walks at full resolution may
be fifth: spotmicro at 0.195 m/s, seed 0). Where a sample was accepted, the extra candidates
would be read only after the first four failed, before the template fallback, and re-solve
timings the coarse check already rejected.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from planner.errors import PlannerConfigError

if TYPE_CHECKING:  # `gaitsmith.search_options` imports this module: no numpy at option time
    import numpy as np

    from planner.search.basin_cma import LocalResult

#: generations of a search whose timing space has more than `SMALL_SEARCH_DIM` variables
DEFAULT_GENERATIONS = 6
#: the largest timing space that gets `SMALL_SEARCH_GENERATIONS` (a symmetric quadruped: 4)
SMALL_SEARCH_DIM = 4
SMALL_SEARCH_GENERATIONS = 4
#: timings the final phase re-solves at full resolution
FINAL_CANDIDATES = 4
#: ... when the coarse check accepted no sample of the search
FINAL_CANDIDATES_NONE_ACCEPTED = 8


@dataclass(frozen=True)
class SearchBudget:
    """The generations a search runs and why (written to the gait file and the search log)."""

    generations: int
    reason: str


def search_budget(dim: int, generations: int | None = None) -> SearchBudget:
    """`generations` if given (``--generations``), else the rule for a `dim`-variable timing
    space (module docstring)."""
    if dim < 1:
        raise PlannerConfigError(f"a timing space has at least 1 variable, got {dim}")
    if generations is not None:
        if generations < 1:
            raise PlannerConfigError(f"generations must be ≥ 1, got {generations}")
        return SearchBudget(generations, "given")
    if dim <= SMALL_SEARCH_DIM:
        return SearchBudget(SMALL_SEARCH_GENERATIONS,
                            f"{dim} timing variables ≤ {SMALL_SEARCH_DIM}")
    return SearchBudget(DEFAULT_GENERATIONS, f"{dim} timing variables > {SMALL_SEARCH_DIM}")


def any_accepted(records: Iterable[tuple[np.ndarray, LocalResult]]) -> bool:
    """Some sample was feasible and (with a coarse check) accepted: a rejected sample is
    ranked infeasible (`gait_search.REJECTED_VIOLATION`)."""
    return any(result.feasible for _, result in records)


def final_candidate_count(records: Iterable[tuple[np.ndarray, LocalResult]],
                          final_candidates: int | None = None) -> int:
    """`final_candidates` if given, else `FINAL_CANDIDATES`, or
    `FINAL_CANDIDATES_NONE_ACCEPTED` when no sample of `records` was accepted."""
    if final_candidates is not None:
        if final_candidates < 1:
            raise PlannerConfigError(f"final_candidates must be ≥ 1, got {final_candidates}")
        return final_candidates
    return FINAL_CANDIDATES if any_accepted(records) else FINAL_CANDIDATES_NONE_ACCEPTED


__all__ = [
    "DEFAULT_GENERATIONS",
    "FINAL_CANDIDATES",
    "FINAL_CANDIDATES_NONE_ACCEPTED",
    "SMALL_SEARCH_DIM",
    "SMALL_SEARCH_GENERATIONS",
    "SearchBudget",
    "any_accepted",
    "final_candidate_count",
    "search_budget",
]

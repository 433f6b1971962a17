"""How many of the search's cheapest timings its final phase re-solves at full resolution.

`FINAL_CANDIDATES`, or `FINAL_CANDIDATES_NONE_ACCEPTED` when the coarse MuJoCo check accepted
no sample of the search. Then every candidate is a plan the coarse check rejected, ranked by
cost alone, and the one that walks at full resolution may be fifth or later: spotmicro at
0.195 m/s, seed 0, wrote the 0.3641 trot template after four failed candidates and writes a
0.2398 trot (−34 %) with eight. Where a sample was accepted the rule keeps four: the extra
candidates would be read only after the first four failed, before the template fallback, and
would re-solve timings the coarse check had rejected. Over 28 recorded searches on 8 bodies
(quad12, hex18, spotmicro, bittle8, star5, phantomx18, knee8, the biped) the rule wrote the same
gait in 25, a 34 % cheaper one in 1, none worse (the other 2, knee8 recorded without the
servo-limited seed that `gaitsmith plan --search` gives it, pass nowhere; with the seed, seed 0
writes the servo-limited walk), at 1.01× the CPU (docs/results/planner_speed_search.md,
session 34).

Fewer basin-CMA generations for some bodies were judged on the same 28 searches and lost: 4
generations for a timing space of ≤ 4 variables (a symmetric quadruped or biped) kept all 13
quad12 and spotmicro gaits but wrote bittle8 gaits 3.2× and 1.46× as costly and biped gaits
1.54× and 1.03×; `search_gait` keeps 6 for every body.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from planner.errors import PlannerConfigError

if TYPE_CHECKING:
    import numpy as np

    from planner.search.basin_cma import LocalResult

#: timings the final phase re-solves at full resolution
FINAL_CANDIDATES = 4
#: ... when the coarse check accepted no sample of the search
FINAL_CANDIDATES_NONE_ACCEPTED = 8
#: `final_candidates_reason`'s answers (the search log and the gait file carry them)
REASON_GIVEN = "given"
REASON_ACCEPTED = "a sample passed the coarse check"
REASON_NONE_ACCEPTED = "the coarse check accepted no sample"


def any_accepted(records: Iterable[tuple[np.ndarray, LocalResult]]) -> bool:
    """Some sample was feasible and (with a coarse check) accepted: the search ranks a rejected
    sample as infeasible (`gait_search.REJECTED_VIOLATION`)."""
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


def final_candidates_reason(records: Iterable[tuple[np.ndarray, LocalResult]],
                            final_candidates: int | None = None) -> str:
    """Why the final phase re-solves `final_candidate_count` timings (for the search log and
    the gait file)."""
    if final_candidates is not None:
        return REASON_GIVEN
    return REASON_ACCEPTED if any_accepted(records) else REASON_NONE_ACCEPTED


__all__ = [
    "FINAL_CANDIDATES",
    "FINAL_CANDIDATES_NONE_ACCEPTED",
    "REASON_ACCEPTED",
    "REASON_GIVEN",
    "REASON_NONE_ACCEPTED",
    "any_accepted",
    "final_candidate_count",
    "final_candidates_reason",
]

"""The swing-clearance rows of stance (foot, knot) pairs freed per solve
(`PlannerOptions.stance_clearance`).

"swing clearance" (`planner.nlp.constraints`) asks every foot at every knot for
z − r − h_min ≥ 0, h_min the swing profile (`planner.nlp.variables.swing_height_profile`), which
is 0 where the schedule has the foot in contact. There the "stance height" row already holds the
foot at C·(z − r) = 0 with C = 1, so the clearance row reads z − r ≥ 0 on a point that must have
z − r = 0: it repeats the equality, sits on its bound at every feasible point, and its slack and
multiplier are one more degenerate pair at every stance (foot, knot) (hex18 tripod at N = 30:
108 of the 180 rows; docs/results/planner_speed_coldstart.md, session 39).

"free" gives those rows the bounds −∞ ≤ row ≤ ∞ for the solve: the feasible set is the same
(the equality holds the foot there), the KKT system loses one complementarity pair per row.
"rows" (the NLP as before) keeps them.
"""

from __future__ import annotations

import numpy as np

#: the group whose stance rows "free" unbounds
GROUP = "swing clearance"
#: the equality that makes them redundant
STANCE_GROUP = "stance height"


def free_stance_clearance(
    slices: dict[str, slice], contact: np.ndarray, lbg: np.ndarray
) -> np.ndarray:
    """`lbg` with the "swing clearance" rows of the (knot, foot) pairs in contact unbounded
    below (their upper bound is ∞ already); `contact`: N × F, nonzero in stance; `slices`: the
    NLP's row groups. Unchanged if the NLP has no clearance or no stance-height rows."""
    rows = slices.get(GROUP)
    if rows is None or STANCE_GROUP not in slices:
        return lbg
    stance = np.asarray(contact, dtype=bool).ravel()  # knot-major, feet within a knot
    if rows.stop - rows.start != stance.size:
        raise ValueError(f"{rows.stop - rows.start} {GROUP!r} rows for {stance.size} "
                         "(knot, foot) pairs")
    out = lbg.copy()
    out[np.arange(rows.start, rows.stop)[stance]] = -np.inf
    return out

"""The swing feet's zero wrench as bounds instead of rows (`PlannerOptions.swing_wrench`).

The NLP is built once per (robot, N), so a foot's contact force is a variable at every knot and
the schedule switches it off by rows: 0 ≤ f_z (a bound) and C·f_max − f_z ≥ 0 ("swing force"),
µ f_z ± f_x, µ f_z ± f_y ≥ 0 ("friction"), and for a flat foot its 16 contact-wrench-cone rows.
In swing (C = 0) these pin the wrench to 0 from both sides: a box of zero width around the start,
which IPOPT can only treat by relaxing the bounds (1e-8) and starting its slacks 1e-6 inside them
with multipliers 1e-6 (the cold options, `planner.nlp.spacetime.ipopt_options`), far from the
central path μ = 1e-2. Every swing foot-knot is such a degenerate corner: 5 rows and a bound each
on quad12 (16 + 5 on a flat foot).

"bounds" fixes the swing feet's wrench at 0 by its variable bounds, per solve, (IPOPT removes
fixed variables, `fixed_variable_treatment` make_parameter) and frees the rows that then read
0 ≥ 0 whatever the other variables are (lower bound −∞). The feasible set is the same: the
wrench of a swing foot is 0 either way; stance feet keep their rows. Measured in
docs/results/planner_speed_init.md.
"""

from __future__ import annotations

import numpy as np

from planner.nlp.model import RobotModel
from planner.nlp.variables import Layout

#: rows per (flat foot, knot) of the "contact wrench cone" group (`planner.nlp.flat_foot`)
_CWC_ROWS = 16


def swing_wrench_bounds(
    layout: Layout,
    model: RobotModel,
    contact: np.ndarray,
    slices: dict[str, slice],
    lbx: np.ndarray,
    ubx: np.ndarray,
    lbg: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lbx, ubx, lbg) with every swing foot's wrench fixed at 0 and the rows it pins freed.

    `contact`: N × F, 1 in stance; `slices`: the NLP's group name → rows of g; the bounds in
    physical units (unscaled)."""
    n, nf = layout.n_knots, layout.n_feet
    swing = ~np.asarray(contact, dtype=bool)  # N × F
    if swing.shape != (n, nf):
        raise ValueError(f"contact matrix {swing.shape}, expected {(n, nf)}")
    lbx, ubx, lbg = lbx.copy(), ubx.copy(), lbg.copy()
    flat = list(model.flat_feet)
    for bound in (lbx, ubx):
        layout.view(bound, "forces").reshape(n, nf, 3)[swing] = 0.0
        if flat:
            layout.view(bound, "moments").reshape(n, len(flat), 3)[swing[:, flat]] = 0.0
    per_foot = swing.ravel()  # row k·F + f of a (foot, knot) group column
    friction = slices.get("friction")
    if friction is not None:
        rows = np.arange(friction.start, friction.stop).reshape(4, n * nf)
        lbg[rows[:, per_foot].ravel()] = -np.inf
    force = slices.get("swing force")
    if force is not None:
        lbg[np.arange(force.start, force.stop)[per_foot]] = -np.inf
    cone = slices.get("contact wrench cone")
    if cone is not None and flat:
        cone_rows = np.arange(cone.start, cone.stop).reshape(n, len(flat), _CWC_ROWS)
        lbg[cone_rows[swing[:, flat]].ravel()] = -np.inf
    return lbx, ubx, lbg

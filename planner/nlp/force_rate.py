"""Normal-force rate bound: a foot's load builds up after touchdown and fades before lift-off.

Why (measured in MuJoCo on humanoid20, docs/results/zoo_gaits.md "Session 24"): the spacetime
NLP places forces at knots and differentiates positions by central differences, so nothing in
it stops a contact force from jumping between neighbouring knots. The cheapest walk of a
flat-footed servo biped redirects its centre of mass from falling to rising at each double
support with two one-knot spikes of ≈ 2.2 body weights — one on the landing foot's first stance
knot, one on the trailing foot's last — and carries ≈ 0.9 body weights on the knots in between.
Position servos behind a soft proportional loop (XL430: kp ≈ 6.4 N·m/rad) cannot put 40 N on a
sole within one 17 ms knot: in MuJoCo the trailing foot leaves the ground with no push-off spike,
and the same change of vertical momentum reaches the landing leg over the next ≈ 100 ms, in early
single support, where its knee is bent: 23-24 N on the sole against the planned 16-17 N, and a
knee torque of 0.85 of stall against the planned 0.41-0.47 (limit 0.8).

The bound: for every foot and every pair of neighbouring knots (cyclic, swing knots included,
where the force is 0),

    |f_z,k+1 − f_z,k| / h  ≤  ρ · m·g / √(L/g)          (h = T/N)

with ρ = `PlannerOptions.normal_force_rate_weights_per_t0`: the normal force may change by at
most ρ body weights per leg time unit √(L/g) (the time unit of dynamic similarity,
`planner.nlp.variables.time_unit_s`). Over the swing → stance step it bounds the first stance
knot's force by ρ·m·g·h/√(L/g) and the same for the last stance knot before lift-off, so the
load builds over several knots and unloads the same way — the smooth loading and unloading
flanks of a walking ground-reaction force. The bound is in continuous time (a rate), so it does
not depend on the knot count. Scaled by body weight and leg time, the same ρ asks the same of
dynamically similar robots (Alexander & Jayes 1983; W&P 2009 §3.2 normalise forces by body
weight). The W&P formulation (eqs 1-10) has no such row: its muscles produce any force profile
the dynamics allow; a position servo does not.

Rows are linear in the forces (the period is a parameter), one per foot and knot; None turns
them off (the NLP before the bound, bit for bit).

Measured (results file): on humanoid20's default template (N = 30) ρ = 4, 5, 6 and 8 walk all
20 cycles where the unbounded plan falls at 3.1 s; ρ = 10 falls at 3.3 s, ρ = 3 stops at the
iteration cap and falls. With ρ = 5 the other robots' template plans (built-in biped, quad12,
hex18, spotmicro, bittle8, star5, phantomx18 at Fr ≈ 0.02) passed MuJoCo as without it on the
servo catalogue of 2026-12-02 06:40, but after star5's MJCF moved to the identified STS3215 rotor
inertia its template with ρ = 5 (a bound it never reaches: 2.5 at most) converges to a
different, 0.7 % cheaper optimum that turns +6.1° in its entry cycle, where the plan without the
rows passes. So the default is off (None): no robot's plan changes unless asked
(`gaitsmith plan --force-rate RHO`). The stage-wise NLP (`planner.nlp.stagewise`, FATROP) has
no form of these rows (they tie two knots' controls) and refuses them;
`planner.nlp.fatrop_solver` plans without them.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

#: default of `PlannerOptions.normal_force_rate_weights_per_t0`: off (see the module docstring);
#: `gaitsmith plan --force-rate 5` asks for ρ = 5 (one body weight in 0.2·√(L/g))
NORMAL_FORCE_RATE_WEIGHTS_PER_T0: float | None = None


def force_rate_rows(fz_weights: Any, inv_h_per_s: Any, t0_s: float) -> Any:
    """(f_z,k+1 − f_z,k)·(N/T)·√(L/g) for every foot (rows) and knot (columns), column-major:
    the normal-force rate in body weights per leg time unit. `fz_weights`: F × N normal forces
    in body weights; `inv_h_per_s`: N/T; `t0_s`: √(L/g)."""
    n = fz_weights.shape[1]
    nxt = ca.horzcat(fz_weights[:, 1:], fz_weights[:, :1]) if n > 1 else fz_weights
    return ca.vec((nxt - fz_weights) * (inv_h_per_s * t0_s))


def force_rate_bounds(rate_weights_per_t0: float, n_feet: int, n_knots: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(lb, ub) of `force_rate_rows`: ±ρ on every row."""
    if not (np.isfinite(rate_weights_per_t0) and rate_weights_per_t0 > 0):
        raise ValueError(f"a force rate bound must be positive, got {rate_weights_per_t0!r}")
    size = n_feet * n_knots
    return np.full(size, -rate_weights_per_t0), np.full(size, rate_weights_per_t0)


def force_rate_labels(feet: tuple[str, ...], n_knots: int) -> list[str]:
    """Row labels, in the order of `force_rate_rows` (knot k: the change from k to k+1)."""
    return [f"foot {f}@knot {k}" for k in range(n_knots) for f in feet]

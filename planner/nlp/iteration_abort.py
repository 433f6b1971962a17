"""Stop a coarse search solve early when its constraint violation has stopped falling.

A sample of the gait search whose NLP is infeasible spends the coarse solve's whole iteration
budget (`DEFAULT_SEARCH_MAX_ITER`, 60) to be classified: in the README search (quad12 0.25 m/s)
10 of its 13 NLP-infeasible samples stop at the cap, 40 % of the search's iterations. IPOPT's
primal infeasibility `inf_pr` (the max-norm violation of the NLP's constraints, here of the
scaled rows g̃ = g/g_scale the planner hands IPOPT) of those samples is still 1e-2 to 0.4 at
iteration 30 and falls slowly or not at all, while every sample that ends feasible is below 0.03
by iteration 30 or still halving (docs/results/planner_speed_search.md, Sessions 26 and 29,
measured on the recorded searches of quad12, hex18 and spotmicro; `benchmarks/abort_replay.py`
replays the rule exactly on IPOPT's own per-iteration inf_pr).

`StallAbort` is that rule: at iteration k ≥ `after_iter`, stop if inf_pr_k > `min_violation`
and inf_pr_k ≥ `fall_factor` · min(inf_pr over the `window` iterations before k) (it has not
halved lately). `AbortCallback` is a CasADi ``iteration_callback`` that evaluates it on the
constraint values IPOPT reports each iteration (equal to IPOPT's inf_pr there, checked); IPOPT
then returns ``User_Requested_Stop`` and the planner judges the point it stopped at, which the
rule guarantees is infeasible (`planner.nlp.diagnostics.judge`); the gait search ranks such a
sample after every solved one (`planner.search.gait_search.TimingSolver`), so a search whose
stopped samples were never among a generation's elites takes the same course.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np


@dataclass(frozen=True)
class StallAbort:
    """Stop at iteration k ≥ `after_iter` if inf_pr_k > `min_violation` and inf_pr_k ≥
    `fall_factor` · min(inf_pr_{k−window} … inf_pr_{k−1})."""

    after_iter: int = 30
    min_violation: float = 0.03
    window: int = 5
    fall_factor: float = 0.5

    def fires(self, inf_pr: Sequence[float]) -> bool:
        """Whether the rule stops a solve whose violations so far (iteration 0 first) are
        `inf_pr`; judged at its last entry."""
        k = len(inf_pr) - 1
        if k < self.after_iter or inf_pr[k] <= self.min_violation:
            return False
        recent = inf_pr[max(0, k - self.window): k]
        return bool(recent) and inf_pr[k] >= self.fall_factor * min(recent)


class IterationCallback(ca.Callback):  # type: ignore[misc]
    """The interface of CasADi's ``iteration_callback``: at each iterate the solver's outputs
    (x, f, g, lam_x, lam_g, lam_p, as `ca.nlpsol_out` names them) come in and one flag goes out
    (1 stops the solve). A subclass sets its own attributes, then calls this ``__init__`` (which
    constructs the CasADi function), and implements `at_iterate`."""

    def __init__(self, name: str, n_x: int, n_g: int, n_p: int) -> None:
        ca.Callback.__init__(self)
        self._sizes = {"x": n_x, "lam_x": n_x, "g": n_g, "lam_g": n_g, "lam_p": n_p, "f": 1}
        self.construct(name, {})

    def at_iterate(self, values: dict[str, np.ndarray]) -> bool:
        """Whether to stop the solve at this iterate (`values`: the outputs by name)."""
        raise NotImplementedError

    def get_n_in(self) -> int:
        return int(ca.nlpsol_n_out())

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return str(ca.nlpsol_out(i))

    def get_name_out(self, i: int) -> str:
        return "stop"

    def get_sparsity_in(self, i: int) -> Any:
        name = str(ca.nlpsol_out(i))
        return ca.Sparsity.scalar() if name == "f" else ca.Sparsity.dense(self._sizes[name])

    def eval(self, arg: Sequence[Any]) -> list[int]:
        values = {str(ca.nlpsol_out(i)): np.asarray(a, dtype=float).ravel()
                  for i, a in enumerate(arg)}
        return [1 if self.at_iterate(values) else 0]


class AbortCallback(IterationCallback):
    """CasADi ``iteration_callback`` evaluating a `StallAbort` on g̃'s bound violation.

    Call `arm(lbg, ubg)` with the scaled row bounds before each solve; `fired` tells whether
    the rule stopped the last one, `inf_pr` holds its violations per iteration."""

    def __init__(self, rule: StallAbort, n_x: int, n_g: int, n_p: int) -> None:
        self.rule = rule
        self._lbg = np.full(n_g, -np.inf)
        self._ubg = np.full(n_g, np.inf)
        self.inf_pr: list[float] = []
        self.fired = False
        super().__init__("stall_abort", n_x, n_g, n_p)

    def arm(self, lbg: np.ndarray, ubg: np.ndarray) -> None:
        self._lbg, self._ubg = np.asarray(lbg, dtype=float), np.asarray(ubg, dtype=float)
        self.inf_pr, self.fired = [], False

    def at_iterate(self, values: dict[str, np.ndarray]) -> bool:
        g = values["g"]
        viol = np.maximum(np.maximum(self._lbg - g, g - self._ubg), 0.0)
        self.inf_pr.append(float(np.max(viol)) if viol.size else 0.0)
        self.fired = self.rule.fires(self.inf_pr)
        return self.fired


__all__ = ["AbortCallback", "IterationCallback", "StallAbort"]

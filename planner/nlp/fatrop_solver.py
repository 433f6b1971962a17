"""EXPERIMENTAL: the planner's NLP solved by FATROP on its stage-wise form (issue #16).

Not a user option: measured, it lost to IPOPT + MUMPS on both counts that matter (per-iteration
cost and convergence; docs/results/planner_speed_fatrop.md), so it is only reachable from the
benchmarks (`benchmarks/planner_bench.py --paths knot,fatrop`, `benchmarks/fatrop_bench.py`).

`FatropPlanner` is a `GaitPlanner` whose solver is FATROP (``nlpsol(..., "fatrop")`` with the
manual stage structure of `planner.nlp.stagewise`): every solve maps the start point into the
stage variables, solves, maps the solution back and judges it on the planner's own NLP
(`GaitPlanner._result`: the same constraint groups, bounds, verdict and cost terms as IPOPT's),
so a result is comparable with an IPOPT one row for row. FATROP returns no multipliers of the
planner's rows, so the result's multipliers are zeros (they only rank binding limits in reports)
and warm starts are primal only — the planner's policy anyway (`spacetime.WARM_START_DUALS`).
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import (
    _USER_STOP,
    GaitPlanner,
    PlanResult,
    SolveBounds,
    _sigint_watch,
)
from planner.nlp.stagewise import StagewiseNLP, build_stagewise, stage_bounds
from planner.nlp.variables import initial_guess, parameter_vector
from robots import ContactSchedule, Robot

#: FATROP's options for every solve: the planner's tolerance and iteration cap (set from
#: `PlannerOptions`), IPOPT's initial barrier parameter
FATROP_DEFAULTS: dict[str, Any] = {"mu_init": 1e-2}


class FatropPlanner(GaitPlanner):
    """A `GaitPlanner` whose NLP is solved stage-wise by FATROP (module docstring)."""

    #: `_make_solver` builds the stage-wise NLP `solve` reads: in `__init__`
    lazy_full_solver = False

    def __init__(
        self,
        robot: Robot,
        n_knots: int = 30,
        options: PlannerOptions | None = None,
        fatrop_options: dict[str, Any] | None = None,
    ) -> None:
        # the stage-wise NLP has no normal-force rate rows (`planner.nlp.force_rate`)
        options = options or PlannerOptions(normal_force_rate_weights_per_t0=None)
        if options.nondimensional:
            raise PlannerConfigError(
                "the FATROP planner solves the NLP in SI units; nondimensional=True is not "
                "supported"
            )
        self._fatrop_options = {**FATROP_DEFAULTS, **(fatrop_options or {})}
        self.stagewise: StagewiseNLP | None = None
        # the base class builds the planner's MX NLP (its rows judge every result); "expanded"
        # keeps it from building IPOPT's knot derivatives, which FATROP does not use
        # the stage-wise rows are the groups' own rows (`planner.nlp.stagewise`): no
        # `compact_rows`; the servo goals are a stage state already: not lifted
        super().__init__(robot, n_knots, dataclasses.replace(
            options, derivatives="expanded", nlp_jacobian="ad", compact_rows=(),
            servo_goal_form="direct",
        ))

    def stage_solve_bounds(self) -> SolveBounds:
        """The bounds of every stage-wise solve, on the planner's variables and rows: the built
        ones (the stage-wise rows are the groups' own, `planner.nlp.stagewise`, and nothing is
        freed or fixed per schedule)."""
        return SolveBounds(self._lbx, self._ubx, self._lbg, self._ubg)

    def _make_solver(self, warm: bool = False) -> Any:
        """The FATROP instance (one for cold and warm solves: `warm` is IPOPT's, unused here;
        FATROP's warm start is primal only)."""
        o = self.options
        sw = build_stagewise(self.model, self.n_knots, o, self.layout)
        self.stagewise = sw
        bounds = self.stage_solve_bounds()
        self._w_lbx, self._w_ubx = stage_bounds(sw, bounds.lbx, bounds.ubx)
        fatrop = {
            "tol": o.tol,
            "max_iter": o.max_iter,
            "print_level": o.print_level,
            **self._fatrop_options,
        }
        opts: dict[str, Any] = {
            "structure_detection": "manual",
            "N": sw.n_knots,
            "nx": list(sw.nx),
            "nu": list(sw.nu),
            "ng": list(sw.ng),
            "expand": True,
            "print_time": False,
            "error_on_fail": False,
            "fatrop": fatrop,
        }
        return ca.nlpsol("spacetime_fatrop", "fatrop", {"x": sw.w, "p": sw.p, "f": sw.f,
                                                       "g": sw.g}, opts)

    def solve(
        self,
        schedule: ContactSchedule,
        speed_m_s: float,
        warm_start: Any = None,
        *,
        vy_m_s: float = 0.0,
        yaw_rate_rad_s: float = 0.0,
        half_cycle: bool | None = None,
        swing_wrench: str | None = None,
    ) -> PlanResult:
        """As `GaitPlanner.solve`, by FATROP (warm starts: the primal point only; always the full
        stage-wise NLP, whatever `half_cycle` says, and its built bounds, whatever
        `swing_wrench` says: nothing is fixed per schedule, `stage_solve_bounds`)."""
        self._check(schedule, speed_m_s, vy_m_s, yaw_rate_rad_s)
        sw = self.stagewise
        if sw is None:  # pragma: no cover - set by _make_solver in __init__
            raise PlannerConfigError("the FATROP planner has no stage-wise NLP")
        p = parameter_vector(
            schedule, self.n_knots, speed_m_s, self.swing_clearance_m, vy_m_s, yaw_rate_rad_s
        )
        start = self._last if warm_start is None or warm_start is True else warm_start or None
        t0 = time.perf_counter()
        x0 = initial_guess(self.layout, self.model, schedule) if start is None else start.x
        w0 = np.asarray(sw.to_stage(x0, p)).ravel()
        with _sigint_watch() as interrupted:
            sol = self._solver(
                x0=w0, p=p, lbx=self._w_lbx, ubx=self._w_ubx, lbg=sw.lbg, ubg=sw.ubg
            )
        stats = self._solver.stats()
        if interrupted() or stats.get("return_status") in _USER_STOP:
            raise KeyboardInterrupt("FATROP stopped")
        elapsed = time.perf_counter() - t0
        x = np.asarray(sol["x"]).ravel()[sw.from_planner_index]
        status = "Solve_Succeeded" if stats.get("success") else (
            f"fatrop_return_flag_{stats.get('fatrop', {}).get('return_flag', '?')}"
        )
        plain = {
            "x": x,
            "lam_x": np.zeros_like(x),
            "lam_g": np.zeros_like(self._lbg),
            "f": float(sol["f"]),
        }
        facts = {"return_status": status, "iter_count": int(stats.get("iter_count", -1))}
        result = self._result(schedule, speed_m_s, p, plain, facts, elapsed,
                              self.stage_solve_bounds())
        result = dataclasses.replace(
            result,
            vy_m_s=float(vy_m_s),
            yaw_rate_rad_s=float(yaw_rate_rad_s),
            # the built bounds: the swing wrench held by the schedule's rows (gait-file metadata)
            stats={**result.stats, "fatrop": dict(stats.get("fatrop", {})),
                   "swing_wrench": "rows"},
        )
        if result.feasible:
            self._last = result.warm_start
        return result

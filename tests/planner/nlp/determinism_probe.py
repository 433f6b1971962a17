"""One fresh process's NLP and cold solve, printed as one JSON line of SHA-256 digests
(`test_determinism.py` runs it under different hash seeds and derivative caches).

    python -m tests.planner.nlp.determinism_probe quad12 trot 0.25 12

Digests: the NLP's bounds and scales, the cold start x0, the values and sparsity of IPOPT's
f, g, ∇f, jac_g and hess_l at x0 (multipliers fixed), and the solve's iterations, cost and x.
"""

from __future__ import annotations

import hashlib
import json
import sys
from typing import Any

import numpy as np

import robots
from planner.nlp.cold_start import StartCommand
from planner.nlp.command import VelocityCommand
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, parameter_vector
from planner.templates import make_schedule

#: IPOPT's oracle functions compared at the cold start
ORACLE = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")


def digest(values: Any) -> str:
    """SHA-256 of an array's float64 bytes (bit for bit) or of a string."""
    if isinstance(values, str):
        return hashlib.sha256(values.encode()).hexdigest()
    return hashlib.sha256(np.ascontiguousarray(values, dtype=np.float64).tobytes()).hexdigest()


def probe(robot_name: str, gait: str, speed_m_s: float, n_knots: int) -> dict[str, Any]:
    robot = robots.load(robot_name)
    planner = GaitPlanner(robot, n_knots, PlannerOptions())
    schedule = make_schedule(robot, gait)
    p = parameter_vector(schedule, n_knots, speed_m_s, planner.swing_clearance_m, 0.0, 0.0)
    x0 = planner._cold_start(schedule, p, StartCommand(
        VelocityCommand(speed_m_s, 0.0, 0.0), planner.swing_clearance_m))
    out: dict[str, Any] = {
        "directions_cached": planner.directions_cached,
        **{name: digest(getattr(planner, f"_{name}")) for name in
           ("lbg", "ubg", "lbx", "ubx", "x_scale", "g_scale")},
        "x0": digest(x0),
    }
    lam_g = np.random.default_rng(1).standard_normal(planner._lbg.size)
    for name in ORACLE:
        function = planner._solver.get_function(name)
        args: dict[str, Any] = {"x": x0 / planner._x_scale, "p": p}
        args.update({k: v for k, v in (("lam_f", 1.0), ("lam_g", lam_g))
                     if k in function.name_in()})
        for key, value in function.call(args).items():
            out[f"{name}.{key}"] = [digest(np.asarray(value.nonzeros())),
                                    digest(str(value.sparsity().get_triplet()))]
    result = planner.solve(schedule, speed_m_s, warm_start=False)
    out.update(iterations=result.iterations, cost=repr(result.cost),
               x=digest(result.warm_start.x), feasible=result.feasible)
    return out


if __name__ == "__main__":
    name, gait, speed, knots = sys.argv[1:5]
    print(json.dumps(probe(name, gait, float(speed), int(knots)), sort_keys=True))

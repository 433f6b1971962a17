"""Size of the NLP IPOPT sees and where an iteration's time goes, solver paths side by side.

    python benchmarks/kkt_profile.py quad12 trot knot,knot-ad,expanded 2

Builds one planner per `planner_bench.PATHS` name (N = 30) and cold-solves the robot's
template `reps` times at 0.25 m/s, the paths in turn. Prints the free variables (lbx < ubx:
IPOPT removes fixed ones), constraint rows (equalities), the non-zeros of the constraint
Jacobian and of the Lagrangian Hessian, and per solve: iterations, cost, wall and process CPU
time (the CPU time moves less with the load of a shared machine), CPU ms per
iteration in the NLP functions (CasADi's ``t_proc_nlp_*``) and in the rest (wall time minus
the functions' wall time: IPOPT, MUMPS, BLAS), and IPOPT's own wall timing of the whole KKT
solve (factorisation and backsolves), the backsolves and the function evaluations
(``print_timing_statistics``, read from each solve's log: IPOPT prints to the C stdout).
"""

from __future__ import annotations

import dataclasses
import os
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

from planner_bench import PATHS

import robots
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule

FUNCTIONS = ("nlp_hess_l", "nlp_jac_g", "nlp_grad_f", "nlp_g", "nlp_f")
#: IPOPT's timing lines read from its log (wall seconds): PDSystemSolverTotal is the whole KKT
#: solve (MUMPS' factorisations are inside it; IPOPT's
#: own "LinearSystemFactorization" timer stays 0 with MUMPS)
TIMERS = ("PDSystemSolverTotal", "LinearSystemBackSolve", "Function Evaluations")


def sizes(planner: GaitPlanner) -> str:
    solver = planner._solver
    jac = solver.get_function("nlp_jac_g").sparsity_out(1).nnz()
    hess = solver.get_function("nlp_hess_l").sparsity_out(0).nnz()
    free = int((planner._lbx < planner._ubx).sum())
    eq = int((planner._lbg == planner._ubg).sum())
    return (f"free variables {free}, rows {planner._lbg.size} ({eq} equalities), "
            f"jac_g nnz {jac}, hess_l nnz {hess}")


def timed_solve(
    planner: GaitPlanner, schedule: robots.ContactSchedule
) -> tuple[str, dict[str, float]]:
    """One cold solve with IPOPT's timing statistics on; its log's timers [s]."""
    with tempfile.TemporaryFile(mode="w+b") as log:
        saved = os.dup(1)
        sys.stdout.flush()
        os.dup2(log.fileno(), 1)
        try:
            cpu0 = time.process_time()
            result = planner.solve(schedule, 0.25, warm_start=False)
            cpu_s = time.process_time() - cpu0
        finally:
            sys.stdout.flush()
            os.dup2(saved, 1)
            os.close(saved)
        log.seek(0)
        text = log.read().decode(errors="replace")
    timers = {}
    for name in TIMERS:
        m = re.search(rf"{name}\.*:\s+[0-9.]+\s+\(sys:\s+[0-9.]+\s+wall:\s+([0-9.]+)\)", text)
        if m:
            timers[name] = float(m.group(1))
    stats = planner._solver.stats()
    it = max(result.iterations, 1)
    fun_wall = sum(stats[f"t_wall_{f}"] for f in FUNCTIONS)
    fun_cpu = sum(stats[f"t_proc_{f}"] for f in FUNCTIONS)
    per_fn = " ".join(f"{f[4:]} {stats[f't_proc_{f}'] / stats[f'n_call_{f}'] * 1e3:.1f}"
                      for f in FUNCTIONS if stats[f"n_call_{f}"])
    line = (f"{result.iterations} it, cost {result.cost:.9g}, feasible {result.feasible}, "
            f"{result.solve_time_s:.2f} s = {result.solve_time_s / it * 1e3:.0f} ms/it "
            f"(process CPU {cpu_s:.2f} s = {cpu_s / it * 1e3:.0f} ms/it): "
            f"functions {fun_cpu / it * 1e3:.1f} CPU ms/it ({per_fn} ms/call), rest "
            f"{(result.solve_time_s - fun_wall) / it * 1e3:.1f} ms/it; IPOPT wall ms/it: "
            + ", ".join(f"{k} {v / it * 1e3:.1f}" for k, v in timers.items()))
    return line, {"time": result.solve_time_s, "cpu": cpu_s, "it": it, **timers}


def main() -> None:
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    robot_name, gait, names, reps = sys.argv[1], sys.argv[2], sys.argv[3].split(","), sys.argv[4]
    robot = robots.load(robot_name)
    planners = {}
    for name in names:
        base = PATHS[name](robot, 30)
        timed = dataclasses.replace(base.options, print_level=5)
        planners[name] = type(base)(robot, 30, timed)
        print(f"{name}: {sizes(planners[name])}", flush=True)
    schedule = make_schedule(robot, gait)
    rows: dict[str, list[dict[str, float]]] = {name: [] for name in names}
    for _ in range(int(reps)):
        for name, planner in planners.items():
            line, row = timed_solve(planner, schedule)
            rows[name].append(row)
            print(f"{name}: {line}", flush=True)
    print(f"medians, {robot_name} {gait} N=30, {reps} reps, load {os.getloadavg()[0]:.1f}")
    for name in names:
        t = statistics.median(r["time"] for r in rows[name])
        fac = statistics.median(r.get(TIMERS[0], float("nan")) / r["it"] for r in rows[name])
        cpu = statistics.median(r["cpu"] for r in rows[name])
        print(f"{name}: solve {t:.2f} s (CPU {cpu:.2f} s), {rows[name][0]['it']:.0f} it, "
              f"KKT solve (PDSystemSolverTotal, wall) {fac * 1e3:.1f} ms/it")


if __name__ == "__main__":
    main()

"""Time before the first solve of a `gaitsmith plan` command (issue #16: "the second and later
commands on the same robot, N and options spend ≤ 1 s before the first solve").

    python benchmarks/startup_bench.py [ROBOT] [--gait trot] [--repeats 3]
        [--baseline DIR] [--cache DIR] [--search] [-- extra plan options]

Each repeat is a fresh interpreter (`python -c`, as the `gaitsmith` script is) that takes its
clock first thing, imports `gaitsmith.cli`, runs `gaitsmith plan ROBOT --gait GAIT --speed 0.25`
in-process and stops at the first call of `GaitPlanner.solve`. Printed per repeat: the CPU time
of each phase (importing `gaitsmith.cli`; the command before the planner: robot load, option
checks, template; the knot's J and H, `knot_jacobian_and_hessian`; IPOPT's construction,
`casadi.nlpsol`; the rest of `GaitPlanner.__init__`), then the wall and CPU time up to the first
solve (CPU times are the ones to compare on a shared machine).

The disk cache is a fresh temporary folder (or `--cache`): the first repeat of each checkout fills
it (a "first command"), the later ones are "second commands". `--baseline DIR`: another checkout
of gaitsmith (e.g. `git archive <commit> | tar -x -C DIR`) timed the same way, alternating with
this one repeat by repeat, each with its own cache folder. `PYTHONDONTWRITEBYTECODE` is dropped
from the children's environment (a user's Python caches bytecode; without it every repeat compiles
gaitsmith's ~90 modules again, ≈ 0.2 s). Interpreter start-up itself (≈ 20 ms) is not counted.

`--search`: `gaitsmith plan ROBOT --speed 0.25 --search` instead (extra options after --), run
from a script file as the `gaitsmith` console script runs it (so the pool's spawned workers
import `gaitsmith.cli` as it, their `__mp_main__`), stopped when the search's seeding batch (the
template solves) has its results. Printed per repeat: this process's CPU up to the first worker
start (`ProcessPoolExecutor.submit`) and from it to the end of seeding, the wall time to both,
and the workers' CPU split into the template solves, their MuJoCo checks and the rest
(interpreter, imports, NLP builds); the template costs and iterations must agree between
checkouts. This process's CPU after the first worker start runs beside the workers' start-up;
on two dedicated cores that is worth about half of it in wall time (three processes share the
two cores), all of it at most (docs/results/planner_speed_search.md, session 33: starting the
pool before the search, measured and left out).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

_CHILD = r"""
import json, resource, sys, time
t0 = time.perf_counter()
import gaitsmith.cli as cli
t_import = time.perf_counter() - t0
cpu_import_s = time.process_time()
from planner.nlp import spacetime

phase = {"jh_s": 0.0, "nlpsol_s": 0.0, "planner_s": 0.0, "planner_start_s": None,
         "cpu_jh_s": 0.0, "cpu_nlpsol_s": 0.0, "cpu_planner_s": 0.0, "cpu_planner_start_s": 0.0}

def timed(key, function):
    def wrapper(*args, **kwargs):
        t = time.perf_counter(), time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            phase[key] += time.perf_counter() - t[0]
            phase["cpu_" + key] += time.process_time() - t[1]
    return wrapper

class _FirstSolve(Exception):
    pass

def _stop(self, *args, **kwargs):
    raise _FirstSolve

init = spacetime.GaitPlanner.__init__
def _init(self, *args, **kwargs):
    if phase["planner_start_s"] is None:
        phase["planner_start_s"] = time.perf_counter() - t0
        phase["cpu_planner_start_s"] = time.process_time() - cpu_import_s
    timed("planner_s", init)(self, *args, **kwargs)

spacetime.GaitPlanner.__init__ = _init
spacetime.GaitPlanner.solve = _stop
spacetime.knot_jacobian_and_hessian = timed("jh_s", spacetime.knot_jacobian_and_hessian)
spacetime.ca.nlpsol = timed("nlpsol_s", spacetime.ca.nlpsol)
try:
    cli.app(sys.argv[1:], standalone_mode=False)
except _FirstSolve:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    print(json.dumps({"import_s": t_import, "first_solve_s": time.perf_counter() - t0,
                      "cpu_s": usage.ru_utime + usage.ru_stime, "cpu_import_s": cpu_import_s,
                      **phase}))
    sys.exit(0)
print(json.dumps({"error": "the command ended without calling GaitPlanner.solve"}))
sys.exit(1)
"""


_SEARCH_CHILD = r"""
import json, resource, sys, time
T0, C0 = time.perf_counter(), time.process_time()
import gaitsmith.cli as cli  # the console script's one import: spawned workers run it too


def _main():
    import concurrent.futures
    import planner.search.basin_cma as basin

    marks = {}
    submit = concurrent.futures.ProcessPoolExecutor.submit

    def first_submit(self, *args, **kwargs):
        marks.setdefault("spawn", (time.perf_counter() - T0, time.process_time() - C0))
        return submit(self, *args, **kwargs)

    class Seeded(Exception):
        pass

    seen = []

    def stop(local_solve, x0, *args, executor=None, **kwargs):
        marks["seeded"] = (time.perf_counter() - T0, time.process_time() - C0)
        seen.extend(r for _, r in executor.records)
        raise Seeded

    concurrent.futures.ProcessPoolExecutor.submit = first_submit
    basin.basin_cma = stop  # imported before the search's module binds it
    try:
        cli.main(sys.argv[1:])
    except Seeded:
        pass
    if "seeded" not in marks or "spawn" not in marks:
        print(json.dumps({"error": "the command ran no search on a process pool"}))
        sys.exit(1)
    use = resource.getrusage(resource.RUSAGE_CHILDREN)  # the workers, after the pool closed
    print(json.dumps({
        "spawn_s": marks["spawn"][0], "cpu_spawn_s": marks["spawn"][1],
        "seeded_s": marks["seeded"][0], "cpu_seeded_s": marks["seeded"][1],
        "workers_cpu_s": use.ru_utime + use.ru_stime,
        "solves_cpu_s": sum(r.cpu_s for r in seen),
        "checks_cpu_s": sum(r.accept_cpu_s for r in seen),
        "costs": [r.cost for r in seen], "iterations": [r.n_fevals - 1 for r in seen]}))


if __name__ == "__main__":
    _main()
"""


def _run_search(code_dir: Path, cache: Path, cmd: list[str], script: Path) -> dict[str, Any]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=str(code_dir), GAITSMITH_CACHE=str(cache))
    env.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")
    out = subprocess.run([sys.executable, str(script), *cmd], capture_output=True, text=True,
                         check=False, env=env, cwd=code_dir)
    last = out.stdout.strip().splitlines()[-1] if out.stdout.strip() else "{}"
    rec: dict[str, Any] = json.loads(last) if last.startswith("{") else {}
    if "seeded_s" not in rec:
        sys.exit(f"{code_dir}: {rec.get('error', out.stderr.strip()[-400:])}")
    return rec


def _search_line(label: str, i: int, rec: dict[str, Any]) -> str:
    """One repeat of `--search`: this process's CPU before and after the first worker start,
    wall times, the workers' CPU split."""
    rest = rec["workers_cpu_s"] - rec["solves_cpu_s"] - rec["checks_cpu_s"]
    return (
        f"{label:>8} {i + 1}: this process CPU to the first worker start "
        f"{rec['cpu_spawn_s']:.3f} s, after it to the end of seeding "
        f"{rec['cpu_seeded_s'] - rec['cpu_spawn_s']:.3f} s | wall to the first worker start "
        f"{rec['spawn_s']:.2f} s, to the end of seeding {rec['seeded_s']:.2f} s | workers CPU "
        f"{rec['workers_cpu_s']:.2f} s: template solves {rec['solves_cpu_s']:.2f}, checks "
        f"{rec['checks_cpu_s']:.2f}, start-up and builds {rest:.2f} | load "
        f"{os.getloadavg()[0]:.2f}"
    )


def _search_main(args: argparse.Namespace, checkouts: list[tuple[str, Path]]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp, "gaitsmith_search_child.py")
        script.write_text(_SEARCH_CHILD)
        cmd = ["plan", args.robot, "--speed", "0.25", "--search", "-o", f"{tmp}/g.json",
               *args.extra]
        print(f"gaitsmith {' '.join(cmd)}  (stopped when the seeding batch is solved), "
              f"{time.strftime('%H:%M:%S', time.gmtime())} UTC")
        records: dict[str, list[dict[str, Any]]] = {label: [] for label, _ in checkouts}
        for i in range(args.repeats):
            for label, code_dir in checkouts:
                cache = (args.cache or Path(tmp) / "cache") / label
                rec = _run_search(code_dir, cache, cmd, script)
                records[label].append(rec)
                print(_search_line(label, i, rec), flush=True)
        if args.baseline is not None:
            same = all(r["costs"] == records["this"][0]["costs"]
                       and r["iterations"] == records["this"][0]["iterations"]
                       for rs in records.values() for r in rs)
            print("template solves: " + ("the same costs and iterations in every repeat" if same
                                         else "DIFFERENT costs or iterations between repeats"))
            for key, name in (("seeded_s", "wall to the end of seeding"),
                              ("cpu_seeded_s", "this process's CPU")):
                new = sorted(r[key] for r in records["this"])
                old = sorted(r[key] for r in records["baseline"])
                print(f"median {name}: this {new[len(new) // 2]:.3f} s, baseline "
                      f"{old[len(old) // 2]:.3f} s")


def _run(code_dir: Path, cache: Path, cmd: list[str]) -> dict[str, float]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=str(code_dir), GAITSMITH_CACHE=str(cache))
    # no compile in the background between the repeats (planner.nlp.background_compile)
    env.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, *cmd],
        capture_output=True, text=True, check=False, env=env, cwd=code_dir,
    )
    last = out.stdout.strip().splitlines()[-1] if out.stdout.strip() else "{}"
    rec: dict[str, float] = json.loads(last)
    if "first_solve_s" not in rec:
        sys.exit(f"{code_dir}: {rec.get('error', out.stderr.strip()[-400:])}")
    return rec


def _line(label: str, i: int, rec: dict[str, float]) -> str:
    """One repeat: the CPU time of each phase, then the wall and CPU time to the first solve."""
    rest = rec["cpu_planner_s"] - rec["cpu_jh_s"] - rec["cpu_nlpsol_s"]
    kind = "first command " if i == 0 else "second command"
    return (
        f"{label:>8} {i + 1} ({kind}) CPU: import {rec['cpu_import_s']:.2f} | before the "
        f"planner {rec['cpu_planner_start_s']:.2f} | J,H {rec['cpu_jh_s']:.2f} | nlpsol "
        f"{rec['cpu_nlpsol_s']:.2f} | planner rest {rest:.2f} || before the first solve: wall "
        f"{rec['first_solve_s']:.2f} s, CPU {rec['cpu_s']:.2f} s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", nargs="?", default="quad12")
    parser.add_argument("--gait", default="trot")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--baseline", type=Path, help="another gaitsmith checkout to time too")
    parser.add_argument("--cache", type=Path, help="cache folder (default: a fresh temporary one)")
    parser.add_argument("--search", action="store_true",
                        help="time `plan ROBOT --speed 0.25 --search` to the end of its seeding")
    parser.add_argument("extra", nargs="*", help="more `gaitsmith plan` options (after --)")
    args = parser.parse_args()
    here = Path(__file__).resolve().parent.parent
    checkouts = [("this", here)]
    if args.baseline is not None:
        checkouts.append(("baseline", args.baseline.resolve()))
    if args.search:
        _search_main(args, checkouts)
        return
    with tempfile.TemporaryDirectory() as tmp:
        cmd = ["plan", args.robot, "--gait", args.gait, "--speed", "0.25", "-o", f"{tmp}/g.json"]
        cmd += args.extra
        print(f"gaitsmith {' '.join(cmd)}  (stopped at the first solve)")
        records: dict[str, list[dict[str, float]]] = {label: [] for label, _ in checkouts}
        for i in range(args.repeats):
            for label, code_dir in checkouts:
                cache = (args.cache or Path(tmp) / "cache") / label
                rec = _run(code_dir, cache, cmd)
                records[label].append(rec)
                print(_line(label, i, rec), flush=True)
        if args.baseline is not None and args.repeats > 1:
            for key, name in (("first_solve_s", "wall"), ("cpu_s", "CPU")):
                new = sorted(r[key] for r in records["this"][1:])
                old = sorted(r[key] for r in records["baseline"][1:])
                print(f"second commands, median {name}: this {new[len(new) // 2]:.2f} s, "
                      f"baseline {old[len(old) // 2]:.2f} s, ratio "
                      f"{new[len(new) // 2] / old[len(old) // 2]:.2f}")


if __name__ == "__main__":
    main()

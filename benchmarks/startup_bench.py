"""Time before the first solve of a `gaitsmith plan` command (issue #16: "the second and later
commands on the same robot, N and options spend ≤ 1 s before the first solve").

    python benchmarks/startup_bench.py [ROBOT] [--gait trot] [--repeats 3]
        [--baseline DIR] [--cache DIR] [-- extra plan options]

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
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

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
    parser.add_argument("extra", nargs="*", help="more `gaitsmith plan` options (after --)")
    args = parser.parse_args()
    here = Path(__file__).resolve().parent.parent
    checkouts = [("this", here)]
    if args.baseline is not None:
        checkouts.append(("baseline", args.baseline.resolve()))
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

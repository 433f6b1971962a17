"""A `gaitsmith plan` command's first solve against a second one in the same process (issue #16).

    python benchmarks/first_solve_bench.py [ROBOT] [--gait trot] [--speed 0.25] [--repeats 5]
        [--baseline DIR] [--cache DIR] [--end-to-end] [-- extra plan options]

Each repeat is a fresh interpreter that takes its clock first thing, imports `gaitsmith.cli` and
runs `gaitsmith plan ROBOT --gait GAIT --speed SPEED` in-process (`gaitsmith.cli.main`); at the
command's call of `GaitPlanner.solve` it times that solve (the first of the process), then a
second cold solve of the same schedule, and stops. Printed per repeat (wall / CPU): (a) start-up
to the planner built, (b) the first solve, (c) the second, the spans inside the first solve that
the second does not pay (the half-cycle reduced NLP's build, `GaitPlanner._build_half_cycle`; of
it the mirror probe, `reduced_nlp` and IPOPT's construction), the iterations, the cost and a
digest of x (the two checkouts must agree).

`--baseline DIR`: another checkout (e.g. `git archive <commit> | tar -x -C DIR`) timed the same
way, alternating repeat by repeat. `--cache DIR`: a cache folder per checkout is copied from DIR
(e.g. one `gaitsmith cache build` filled) into a temporary folder, once, before the repeats; the
first repeat of each checkout may fill entries of its own (a "first command") — ignore it when
comparing second commands. `--end-to-end`: time the whole command (`gaitsmith plan …` as a
subprocess, as the console script runs it: wall and the child's CPU) instead; extra plan options
such as `--simulate` after `--`. CPU times are the ones to compare on a shared machine.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

_CHILD = r"""
import hashlib, json, sys, time
T0, C0 = time.perf_counter(), time.process_time()
import gaitsmith.cli as cli
from planner.nlp import spacetime, half_cycle

spans = {}

def timed(key, function):
    def wrapper(*args, **kwargs):
        t, c = time.perf_counter(), time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            w, p = spans.get(key, (0.0, 0.0))
            spans[key] = (w + time.perf_counter() - t, p + time.process_time() - c)
    return wrapper

class _Done(Exception):
    pass

marks = {}
init = spacetime.GaitPlanner.__init__
def _init(self, *args, **kwargs):
    init(self, *args, **kwargs)
    marks.setdefault("built", (time.perf_counter() - T0, time.process_time() - C0))

solve = spacetime.GaitPlanner.solve
def _solve(self, schedule, speed, *args, **kwargs):
    out = {}
    for key in ("first", "second"):
        spans.clear()
        t, c = time.perf_counter(), time.process_time()
        result = solve(self, schedule, speed, warm_start=False,
                       **{k: v for k, v in kwargs.items() if k != "warm_start"})
        out[key] = {"wall_s": time.perf_counter() - t, "cpu_s": time.process_time() - c,
                    "iterations": result.iterations, "cost": result.cost,
                    "x": hashlib.sha256(result.warm_start.x.tobytes()).hexdigest()[:12],
                    "half": bool(result.stats.get("half_cycle")), "spans": dict(spans)}
    print(json.dumps({"built": marks["built"], **out}))
    raise _Done

spacetime.GaitPlanner.__init__ = _init
spacetime.GaitPlanner.solve = _solve
spacetime.GaitPlanner._build_half_cycle = timed(
    "half_build", spacetime.GaitPlanner._build_half_cycle)
half_cycle.nlp_mirror_defect = timed("mirror_probe", half_cycle.nlp_mirror_defect)
half_cycle.reduced_nlp = timed("reduced_nlp", half_cycle.reduced_nlp)
spacetime.ca.nlpsol = timed("nlpsol", spacetime.ca.nlpsol)
try:
    cli.main(sys.argv[1:])  # as the console script: its error handling and GC settings too
except _Done:
    sys.exit(0)
print(json.dumps({"error": "the command ended without calling GaitPlanner.solve"}))
sys.exit(1)
"""


def _env(code_dir: Path, cache: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=str(code_dir), GAITSMITH_CACHE=str(cache), OMP_NUM_THREADS="1")
    env.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")
    return env


def _run(code_dir: Path, cache: Path, cmd: list[str]) -> dict[str, Any]:
    out = subprocess.run([sys.executable, "-c", _CHILD, *cmd], capture_output=True, text=True,
                         check=False, env=_env(code_dir, cache), cwd=code_dir)
    last = out.stdout.strip().splitlines()[-1] if out.stdout.strip() else "{}"
    rec: dict[str, Any] = json.loads(last) if last.startswith("{") else {}
    if "first" not in rec:
        sys.exit(f"{code_dir}: {rec.get('error', out.stderr.strip()[-600:])}")
    return rec


def _end_to_end(code_dir: Path, cache: Path, cmd: list[str]) -> dict[str, Any]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    # as the `gaitsmith` console script runs it
    script = "import sys; from gaitsmith.cli import main; sys.exit(main())"
    out = subprocess.run([sys.executable, "-c", script, *cmd], capture_output=True,
                         text=True, check=False, env=_env(code_dir, cache), cwd=code_dir)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    if out.returncode != 0:
        sys.exit(f"{code_dir}: exit {out.returncode}: {out.stderr.strip()[-600:]}")
    return {"wall_s": wall, "cpu_s": cpu}


def _span(rec: dict[str, Any], key: str) -> str:
    w, c = rec["spans"].get(key, (0.0, 0.0))
    return f"{w:.3f}/{c:.3f}"


def _line(label: str, i: int, rec: dict[str, Any]) -> str:
    a, b = rec["first"], rec["second"]
    return (
        f"{label:>8} {i + 1}: (a) built {rec['built'][0]:.2f}/{rec['built'][1]:.2f} s | (b) first "
        f"{a['wall_s']:.3f}/{a['cpu_s']:.3f} s {a['iterations']} it | (c) second "
        f"{b['wall_s']:.3f}/{b['cpu_s']:.3f} s {b['iterations']} it | first's half build "
        f"{_span(a, 'half_build')} (probe {_span(a, 'mirror_probe')}, reduced_nlp "
        f"{_span(a, 'reduced_nlp')}, nlpsol {_span(a, 'nlpsol')}) | cost {a['cost']:.12g} "
        f"x {a['x']} {'=' if (a['x'], a['cost']) == (b['x'], b['cost']) else '≠'} second, "
        f"half {a['half']} | load {os.getloadavg()[0]:.2f}"
    )


def _median(values: list[float]) -> float:
    values = sorted(values)
    n = len(values)
    if n == 0:
        return float("nan")
    return values[n // 2] if n % 2 else 0.5 * (values[n // 2 - 1] + values[n // 2])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", nargs="?", default="quad12")
    parser.add_argument("--gait", default="trot")
    parser.add_argument("--speed", default="0.25")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--baseline", type=Path, help="another gaitsmith checkout to time too")
    parser.add_argument("--cache", type=Path, help="copy each checkout's cache from this folder")
    parser.add_argument("--end-to-end", action="store_true", help="time the whole command")
    parser.add_argument("extra", nargs="*", help="more `gaitsmith plan` options (after --)")
    args, unknown = parser.parse_known_args()
    args.extra = [*args.extra, *(u for u in unknown if u != "--")]  # e.g. -- --simulate
    checkouts = [("this", Path(__file__).resolve().parent.parent)]
    if args.baseline is not None:
        checkouts.append(("baseline", args.baseline.resolve()))
    with tempfile.TemporaryDirectory() as tmp:
        caches = {}
        for label, _ in checkouts:
            caches[label] = Path(tmp, "cache", label)
            if args.cache is not None:
                shutil.copytree(args.cache, caches[label])
        cmd = ["plan", args.robot, "--gait", args.gait, "--speed", args.speed, "-o",
               f"{tmp}/g.json", *args.extra]
        print(f"gaitsmith {' '.join(cmd)}  {time.strftime('%H:%M:%S', time.gmtime())} UTC, "
              f"load {os.getloadavg()[0]:.2f}", flush=True)
        records: dict[str, list[dict[str, Any]]] = {label: [] for label, _ in checkouts}
        for i in range(args.repeats):
            for label, code_dir in (checkouts if i % 2 == 0 else checkouts[::-1]):
                if args.end_to_end:
                    rec = _end_to_end(code_dir, caches[label], cmd)
                    print(f"{label:>8} {i + 1}: wall {rec['wall_s']:.2f} s, CPU "
                          f"{rec['cpu_s']:.2f} s | load {os.getloadavg()[0]:.2f}", flush=True)
                else:
                    rec = _run(code_dir, caches[label], cmd)
                    print(_line(label, i, rec), flush=True)
                records[label].append(rec)
        print(f"end {time.strftime('%H:%M:%S', time.gmtime())} UTC, load "
              f"{os.getloadavg()[0]:.2f}")
        for label, recs in records.items():
            if args.end_to_end:
                print(f"{label:>8} median of {len(recs)}: wall "
                      f"{_median([r['wall_s'] for r in recs]):.3f} s, CPU "
                      f"{_median([r['cpu_s'] for r in recs]):.3f} s")
                continue
            keys = [("built", lambda r: r["built"][1]), ("first", lambda r: r["first"]["cpu_s"]),
                    ("second", lambda r: r["second"]["cpu_s"]),
                    ("first − second", lambda r: r["first"]["cpu_s"] - r["second"]["cpu_s"]),
                    ("built + first", lambda r: r["built"][1] + r["first"]["cpu_s"]),
                    ("first wall", lambda r: r["first"]["wall_s"]),
                    ("second wall", lambda r: r["second"]["wall_s"])]
            print(f"{label:>8} median of {len(recs)} (CPU unless wall): " + ", ".join(
                f"{name} {_median([get(r) for r in recs]):.3f} s" for name, get in keys))
        if args.baseline is not None and not args.end_to_end:
            same = {(r[k]["x"], r[k]["cost"], r[k]["iterations"])
                    for recs in records.values() for r in recs for k in ("first", "second")}
            print("x, cost, iterations: " + ("identical in every solve of both checkouts"
                                             if len(same) == 1 else f"{len(same)} DIFFERENT"))


if __name__ == "__main__":
    main()

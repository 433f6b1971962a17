"""Time before the first solve of a `gaitsmith plan` command (issue #16: "the second and later
commands on the same robot, N and options spend ≤ 1 s before the first solve").

    python benchmarks/startup_bench.py [ROBOT] [--gait trot] [--repeats 3] [-- extra plan options]

Each repeat is a fresh interpreter (`python -c`, as the `gaitsmith` script is) that takes its
clock first thing, imports `gaitsmith.cli`, runs `gaitsmith plan ROBOT --gait GAIT --speed 0.25`
in-process and stops at the first call of `GaitPlanner.solve`. Printed per repeat: the CLI's
import time, then everything up to the first solve (robot load, option checks, template, NLP build
from the disk cache). The first repeat may fill the disk cache (`~/.cache/gaitsmith`); the later
ones are "second commands". Interpreter start-up itself (≈ 20 ms) is not counted.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile

_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import gaitsmith.cli as cli
t_import = time.perf_counter() - t0
from planner.nlp.spacetime import GaitPlanner

class _FirstSolve(Exception):
    pass

def _stop(self, *args, **kwargs):
    raise _FirstSolve

GaitPlanner.solve = _stop
try:
    cli.app(sys.argv[1:], standalone_mode=False)
except _FirstSolve:
    print(json.dumps({"import_s": t_import, "first_solve_s": time.perf_counter() - t0}))
    sys.exit(0)
print(json.dumps({"error": "the command ended without calling GaitPlanner.solve"}))
sys.exit(1)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", nargs="?", default="quad12")
    parser.add_argument("--gait", default="trot")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("extra", nargs="*", help="more `gaitsmith plan` options (after --)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cmd = ["plan", args.robot, "--gait", args.gait, "--speed", "0.25", "-o", f"{tmp}/g.json"]
        cmd += args.extra
        print(f"gaitsmith {' '.join(cmd)}  (stopped at the first solve)")
        for i in range(args.repeats):
            out = subprocess.run(
                [sys.executable, "-c", _CHILD, *cmd], capture_output=True, text=True, check=False
            )
            last = out.stdout.strip().splitlines()[-1] if out.stdout.strip() else "{}"
            rec = json.loads(last)
            if "first_solve_s" not in rec:
                sys.exit(f"repeat {i + 1} failed: {rec.get('error', out.stderr.strip()[-400:])}")
            print(
                f"repeat {i + 1}: import gaitsmith.cli {rec['import_s']:.2f} s | "
                f"before the first solve {rec['first_solve_s']:.2f} s"
            )


if __name__ == "__main__":
    main()

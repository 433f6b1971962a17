"""Intel MKL PARDISO under IPOPT against MUMPS, screened (issue #16; planner_speed_ipopt.md,
session 33). Needs ``pip install mkl`` (the screen only: gaitsmith does not use MKL) and gcc.

    python benchmarks/pardiso_mkl_screen.py [--cases quad12:12,quad12:30,hex18:30]
        [--max-files 40] [--dump-iter 40] [--e2e-iter 150] [--work /tmp/pardiso_screen]

casadi's IPOPT 3.14 loads a pardiso-project.org PARDISO at run time (``linear_solver pardiso``,
``pardisolib``), not MKL's. `pardiso_mkl/pardiso_mkl.c` is that interface on top of MKL's
pardiso (the iparm translated, the inertia copied back); `pardiso_mkl/kkt_screen.c` times MUMPS
(casadi's libcoinmumps and OpenBLAS, IPOPT's ICNTL/CNTL) and MKL through the shim on the same
matrices in one process. Both are compiled with gcc into ``--work``. Per case (robot:knots, the
robot's default template at 0.25 m/s, cold):

1. dump: IPOPT + the shim solves with ``IPOPT_WRITE_MAT`` set, which makes IPOPT's
   PardisoSolverInterface write every KKT matrix it solves with (upper CSR, one-based, with the
   right-hand side), at most ``--dump-iter`` iterations. ``perturb_always_cd`` and
   ``pardiso_repeated_perturbation_means_singular`` keep the matrices regular: the constraint
   block is structurally singular (MKL perturbed 48 pivots of quad12's N = 12 KKT matrix at
   every iteration without them), which IPOPT + MUMPS meets as a singular factorisation and
   regularises (its "Dj"/"l" tags).
2. kkt: on the first ``--max-files`` matrices, analysis once, then numeric factorisation and one
   solve per matrix in order, MUMPS against MKL with IPOPT's iparm ("ipopt": weighted matching
   and scaling on) and without matching and scaling ("nomatch", $GAITSMITH_PARDISO_IPARM
   "10=0,12=0"); CPU ms per matrix, negative eigenvalues against MUMPS', perturbed pivots,
   worst residual of the single solve.
3. e2e: the same solve with MUMPS and with the shim ("ipopt" iparm with and without the two
   IPOPT options above; "nomatch" with ``perturb_always_cd`` and
   ``pardiso_redo_symbolic_fact_only_if_inertia_wrong``), alternating in one process:
   iterations, cost, status, CPU.
"""

from __future__ import annotations

import argparse
import glob
import os
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import casadi

import robots
from planner.nlp import spacetime
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.templates import default_gait_for, make_schedule

HERE = Path(__file__).resolve().parent / "pardiso_mkl"
#: MKL iparm overrides (after the shim's translation) per configuration
IPARM = {"ipopt": "", "nomatch": "10=0,12=0"}
#: the IPOPT options a configuration adds to the planner's
REGULAR = {"perturb_always_cd": "yes", "pardiso_repeated_perturbation_means_singular": "yes"}
E2E: dict[str, tuple[str, dict[str, Any]]] = {
    "mumps": ("", {}),
    "mkl-ipopt": ("ipopt", {}),
    "mkl-ipopt-regular": ("ipopt", REGULAR),
    "mkl-nomatch": ("nomatch", {"perturb_always_cd": "yes",
                                "pardiso_redo_symbolic_fact_only_if_inertia_wrong": "yes"}),
}


def find_mkl_rt() -> Path:
    """libmkl_rt of the `mkl` wheel (installed into the interpreter's lib directory)."""
    roots = {Path(sysconfig.get_config_var("LIBDIR") or sys.prefix), Path(sys.prefix) / "lib"}
    for root in roots:
        hits = sorted(glob.glob(str(root / "libmkl_rt.so*")))
        if hits:
            return Path(hits[-1])
    raise SystemExit(f"libmkl_rt.so not found in {', '.join(map(str, roots))}: pip install mkl")


def build(work: Path) -> tuple[Path, Path]:
    """The shim and the screening harness, compiled with gcc into `work`."""
    gcc = shutil.which("gcc")
    if gcc is None:
        raise SystemExit("gcc not found on the PATH: the screen compiles two small C files")
    work.mkdir(parents=True, exist_ok=True)
    shim, harness = work / "libpardiso_mkl.so", work / "kkt_screen"
    mkl = find_mkl_rt()
    subprocess.run([gcc, "-O2", "-fPIC", "-shared", f'-DGS_MKL_RT="{mkl}"', "-o", str(shim),
                    str(HERE / "pardiso_mkl.c"), "-ldl"], check=True)
    ca_dir = Path(casadi.__file__).parent
    subprocess.run([gcc, "-O2", "-o", str(harness), str(HERE / "kkt_screen.c"),
                    f"-I{ca_dir / 'include' / 'coin-or' / 'mumps'}", f"-L{ca_dir}",
                    "-l:libcoinmumps.so.3", f"-Wl,-rpath,{ca_dir}", "-ldl", "-lm"], check=True)
    return shim, harness


def make_solver(planner: GaitPlanner, extra: dict[str, Any]) -> Any:
    base = spacetime.ipopt_options
    spacetime.ipopt_options = lambda options, warm: {**base(options, warm), **extra}
    try:
        return planner._make_solver()
    finally:
        spacetime.ipopt_options = base


def pardiso_options(shim: Path, extra: dict[str, Any]) -> dict[str, Any]:
    return {"linear_solver": "pardiso", "pardisolib": str(shim), **extra}


def solve(planner: GaitPlanner, solver: Any, iparm: str | None) -> tuple[Any, float]:
    """One cold solve of the default template; $GAITSMITH_PARDISO_IPARM set for the shim."""
    robot = planner.robot
    schedule = make_schedule(robot, default_gait_for(robot))
    planner._solver = solver
    if iparm is not None:
        os.environ["GAITSMITH_PARDISO_IPARM"] = IPARM[iparm]
    try:
        t0 = time.process_time()
        result = planner.solve(schedule, 0.25, warm_start=False)
        return result, time.process_time() - t0
    finally:
        os.environ.pop("GAITSMITH_PARDISO_IPARM", None)


def dump(planner: GaitPlanner, shim: Path, directory: Path, max_iter: int) -> list[str]:
    """The KKT matrices of one IPOPT + shim solve, written by IPOPT (IPOPT_WRITE_MAT)."""
    shutil.rmtree(directory, ignore_errors=True)
    directory.mkdir(parents=True)
    solver = make_solver(planner, pardiso_options(shim, {**REGULAR, "max_iter": max_iter}))
    cwd = os.getcwd()
    os.chdir(directory)  # IPOPT writes mat-ipopt_<iter>-<count>.iajaa into the working directory
    os.environ["IPOPT_WRITE_MAT"] = "1"
    try:
        result, _ = solve(planner, solver, "ipopt")
    finally:
        os.environ.pop("IPOPT_WRITE_MAT", None)
        os.chdir(cwd)
    print(f"  dump: {result.iterations} it, {result.status}", flush=True)
    return sorted(glob.glob(str(directory / "*.iajaa")))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cases", default="quad12:12,quad12:30,hex18:30")
    ap.add_argument("--max-files", type=int, default=40)
    ap.add_argument("--dump-iter", type=int, default=40)
    ap.add_argument("--e2e-iter", type=int, default=150)
    ap.add_argument("--reps", type=int, default=2, help="rounds of the matrix sequence")
    ap.add_argument("--work", type=Path, default=Path("/tmp/pardiso_screen"))
    ap.add_argument("--skip", default="", help="comma list of stages to skip: kkt,e2e")
    args = ap.parse_args()
    cases = []
    for item in args.cases.split(","):
        name, _, knots = item.partition(":")
        if not knots.isdigit():
            ap.error(f"--cases {item!r}: write robot:knots, e.g. quad12:30")
        cases.append((name, int(knots)))
    skip = set(filter(None, args.skip.split(",")))
    shim, harness = build(args.work)
    print(f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.1f}; "
          f"MKL {find_mkl_rt()}", flush=True)
    for name, knots in cases:
        robot = robots.load(name)
        planner = GaitPlanner(robot, knots, PlannerOptions())
        print(f"{name} N = {knots}, {default_gait_for(robot)}:", flush=True)
        if "kkt" not in skip:
            files = dump(planner, shim, args.work / f"{name}_{knots}", args.dump_iter)
            for config, iparm in IPARM.items():
                env = {**os.environ, "GAITSMITH_PARDISO_IPARM": iparm}
                out = subprocess.run([str(harness), str(shim), str(args.reps),
                                      *files[:args.max_files]], env=env, capture_output=True,
                                     text=True, check=False)
                lines = out.stdout.strip().splitlines()
                bad = sum("negative eigenvalues" in line for line in out.stderr.splitlines())
                print(f"  kkt {config} (MKL slots {iparm or 'as translated'}; "
                      f"{bad} inertia lines on stderr):", flush=True)
                for line in lines or [out.stderr.strip()[-300:]]:
                    print(f"    {line}", flush=True)
        if "e2e" not in skip:
            solvers = {}
            for label, (iparm, extra) in E2E.items():
                options = {"max_iter": args.e2e_iter}
                if iparm:
                    options = pardiso_options(shim, {**options, **extra})
                solvers[label] = make_solver(planner, options)
            for label, (iparm, _extra) in E2E.items():
                result, cpu_s = solve(planner, solvers[label], iparm or None)
                it = max(1, result.iterations)
                print(f"  e2e {label}: {result.iterations} it, cost {result.cost:.8g}, "
                      f"{result.status}, feasible {result.feasible}, CPU {cpu_s:.2f} s "
                      f"({1e3 * cpu_s / it:.1f} ms/it)", flush=True)
    print(f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

"""`PlannerOptions.inactive_rows`' values side by side, in one process (issue #16).

    python benchmarks/inactive_rows_bench.py --knots 30 --random 4 --warm 4
    python benchmarks/inactive_rows_bench.py --robot biped,tests/zoo/star5 --variants rows,free

For quad12 (trot, 0.25 m/s) and hex18 (tripod, 0.15 m/s) (`--robot`: other robots, by name or
folder; the biped walks at 0.2 m/s, the rest their default template at Froude 0.02, `case`): one
planner per value of
`--variants` (the first is the baseline), every template and `--random` random schedules
(`planner_bench.random_schedule`, the seed as `planner_bench compare`) solved cold by each,
alternating, then a chain of `--warm` perturbed
warm solves (`planner_bench.perturbed`). IPOPT writes its log at print level 6 to a file per
planner; from it each solve's factorisations are counted: every "Number of trial
factorizations performed" (one per KKT solve with a new matrix, more than 1 when the inertia was
corrected or the matrix was singular), the singular ones (MUMPS INFO(1) = −10) and the
iteration whose log line carries "Dj" (IPOPT's degeneracy test marked the constraint Jacobian
degenerate). Prints per solve and in total: iterations, factorisations, singular
factorisations, process CPU, CPU ms per iteration (also over the solves every variant converged
in), the cost and whether each variant reached the baseline's optimum (same feasibility, cost
within `planner_bench.SAME_COST_RTOL` relative, or lower; pairs in which either stopped at the
iteration cap are not compared).
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("GAITSMITH_BACKGROUND_COMPILE", "0")

import numpy as np

import robots
from planner.errors import PlannerConfigError
from planner.nlp import spacetime
from planner.nlp.config import INACTIVE_ROWS, PlannerOptions, speed_for_froude
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.templates import default_gait_for, make_schedule, templates_for
from robots.errors import RobotsError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from planner_bench import SAME_COST_RTOL, perturbed, random_schedule

_TRIALS = re.compile(r"Number of trial factorizations performed: (\d+)")
_ITER_LINE = re.compile(r"^\s*(\d+)\s+\S+\s+\S+\s+\S+\s+\S+\s+\S+\s+\S+\s+\S+\s+\S+\s+\d+\s*(.*)$")


class LoggedPlanner:
    """A planner whose IPOPT instances write their log to `log` (print level 6)."""

    def __init__(self, robot: robots.Robot, n_knots: int, inactive: str, log: Path) -> None:
        self.log = log
        with _logging_to(log):
            self.planner = GaitPlanner(robot, n_knots, PlannerOptions(inactive_rows=inactive))

    def solve(self, schedule: robots.ContactSchedule, speed: float, warm: bool
              ) -> tuple[PlanResult, float, dict[str, Any]]:
        start = self.log.stat().st_size if self.log.exists() else 0
        with _logging_to(self.log):  # a warm solve may create the warm IPOPT instance
            t0 = time.process_time()
            res = self.planner.solve(schedule, speed, warm_start=None if warm else False)
            cpu = time.process_time() - t0
        with self.log.open() as fh:
            fh.seek(start)
            text = fh.read()
        return res, cpu, log_counts(text)


_LOG_PATH: list[Path] = []
_ORIGINAL_OPTIONS = spacetime.ipopt_options


def _with_log(options: PlannerOptions, warm: bool) -> dict[str, Any]:
    ipopt = _ORIGINAL_OPTIONS(options, warm)
    if _LOG_PATH:
        ipopt.update({"output_file": str(_LOG_PATH[-1]), "file_print_level": 6,
                      "file_append": "yes"})
    return ipopt


class _logging_to:
    def __init__(self, path: Path) -> None:
        self.path = path

    def __enter__(self) -> None:
        _LOG_PATH.append(self.path)
        spacetime.ipopt_options = _with_log  # type: ignore[assignment]

    def __exit__(self, *exc: object) -> None:
        _LOG_PATH.pop()
        if not _LOG_PATH:
            spacetime.ipopt_options = _ORIGINAL_OPTIONS  # type: ignore[assignment]


def log_counts(text: str) -> dict[str, Any]:
    """Factorisations, singular factorisations and the "Dj" iteration of one solve's log."""
    dj = None
    for line in text.splitlines():
        m = _ITER_LINE.match(line)
        if m and "Dj" in m.group(2).split() and dj is None:
            dj = int(m.group(1))
    return {
        "factorizations": sum(int(v) for v in _TRIALS.findall(text)),
        "singular": text.count("matrix is singular"),
        "dj": dj,
    }


def log_path(work: Path, robot: robots.Robot, n_knots: int, variant: str) -> Path:
    """The IPOPT log file of one planner in `work`: named by the robot's own name (not the
    path it was loaded from: IPOPT refuses an output file in a folder that does not exist),
    N and the variant, with anything but letters, digits, '.', '_' and '-' replaced by '_'."""
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", f"{robot.name}_{n_knots}_{variant}")
    return work / f"{stem}.log"


def _same(a: PlanResult, b: PlanResult) -> tuple[bool, float]:
    rel = (b.cost - a.cost) / max(abs(a.cost), 1e-12)
    if a.feasible != b.feasible:
        return False, rel
    return (not a.feasible) or rel <= SAME_COST_RTOL, rel


def run(robot_name: str, gait: str, speed: float, n_knots: int, n_random: int, n_warm: int,
        seed: int, work: Path, variants: list[str]) -> None:
    """Every variant on the same schedules, alternating; the first is the baseline."""
    robot = robots.load(robot_name)
    planners = {name: LoggedPlanner(robot, n_knots, name, log_path(work, robot, n_knots, name))
                for name in variants}
    rng = np.random.default_rng(seed)
    base = make_schedule(robot, gait)
    schedules = [(name, make_schedule(robot, name)) for name in templates_for(robot)]
    schedules += [(f"random{i}", random_schedule(base, rng)) for i in range(n_random)]
    warm_rng = np.random.default_rng(seed + 1)
    chain = [perturbed(base, warm_rng) for _ in range(n_warm)]
    print(f"{robot_name} {gait} {speed} m/s N={n_knots}: {', '.join(variants)} "
          f"({time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.1f})")
    keys = ("it", "fact", "sing", "cpu", "n")
    totals = {name: dict.fromkeys(keys, 0.0) for name in variants}
    # the solves both paths converged in (IPOPT's optimality test) or both found infeasible
    judged = {name: dict.fromkeys(keys, 0.0) for name in variants}
    same = dict.fromkeys(variants[1:], 0)
    compared = dict.fromkeys(variants[1:], 0)
    worst = dict.fromkeys(variants[1:], 0.0)
    runs = [(label, s, False) for label, s in schedules]
    runs += [("warm start", base, False)] + [(f"warm{i}", s, True) for i, s in enumerate(chain)]
    for label, schedule, warm in runs:
        out: dict[str, tuple[PlanResult, float, dict[str, Any]]] = {}
        try:
            for name, lp in planners.items():
                out[name] = lp.solve(schedule, speed, warm)
        except PlannerConfigError:
            continue
        line = []
        a = out[variants[0]][0]
        all_converged = all(r.optimal for r, _, _ in out.values())
        for name, (res, cpu, counts) in out.items():
            for tally in (totals[name], *([judged[name]] if all_converged else [])):
                for key, value in zip(keys, (res.iterations, counts["factorizations"],
                                             counts["singular"], cpu, 1), strict=True):
                    tally[key] += value
            text = (f"{name} {res.cost:.8g} {res.iterations} it {counts['factorizations']} "
                    f"fact ({counts['singular']} singular, Dj@{counts['dj']}) CPU {cpu:.2f} s"
                    f"{'' if res.optimal else ' ' + res.status}")
            if name != variants[0]:
                if (a.optimal and res.optimal) or not (a.feasible or res.feasible):
                    ok, rel = _same(a, res)
                    compared[name] += 1
                    same[name] += ok
                    if a.feasible and res.feasible:
                        worst[name] = max(worst[name], abs(rel))
                    text += f" rel {rel:+.1e}{'' if ok else ' DIFFERENT'}"
                else:
                    text += " (not both converged)"
            line.append(text)
        print(f"  {label}: " + " | ".join(line))
    for label, table in (("all solves", totals), ("solves every variant converged in", judged)):
        print(f"  {label}:")
        for name, t in table.items():
            print(f"    {name}: {t['n']:.0f} solves, {t['it']:.0f} it, {t['fact']:.0f} "
                  f"factorisations ({t['sing']:.0f} singular), CPU {t['cpu']:.2f} s, "
                  f"{1e3 * t['cpu'] / max(1, t['it']):.1f} ms/it")
        r = table[variants[0]]
        for name in variants[1:]:
            f = table[name]
            if not r["it"]:
                continue
            print(f"    {name}/{variants[0]}: iterations {f['it'] / r['it']:.3f}, "
                  f"factorisations {f['fact'] / r['fact']:.3f}, CPU {f['cpu'] / r['cpu']:.3f}, "
                  f"CPU ms/it {(f['cpu'] / f['it']) / (r['cpu'] / r['it']):.3f}")
    for name in variants[1:]:
        print(f"  {name}: same optimum {same[name]}/{compared[name]} compared (worst |rel| "
              f"{worst[name]:.1e})")


#: the gait and speed of the robots measured before (planner_speed_ipopt.md, session 33)
CASES = {"quad12": ("trot", 0.25), "hex18": ("tripod", 0.15), "biped": ("biped_walk", 0.2)}
#: other robots: their default template at this Froude number (`zoo_must_show.py`'s default)
FROUDE = 0.02


def case(robot: robots.Robot) -> tuple[str, float]:
    """(gait, speed in m/s) a robot is benchmarked at: `CASES`, else its default template
    (`planner.templates.default_gait_for`) at Froude number `FROUDE` (v = √(Fr·g·L))."""
    if robot.name in CASES:
        return CASES[robot.name]
    return default_gait_for(robot), round(speed_for_froude(FROUDE, robot.leg_length_m), 3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--random", type=int, default=4)
    ap.add_argument("--warm", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--robot", default="both",
                    help="both (quad12 and hex18), or robots by name or folder, comma-separated")
    ap.add_argument("--variants", default=",".join(INACTIVE_ROWS),
                    help="values of PlannerOptions.inactive_rows, baseline first")
    args = ap.parse_args()
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    unknown = sorted(set(variants) - set(INACTIVE_ROWS))
    if unknown or len(variants) < 2:
        ap.error(f"--variants {args.variants!r}: name two or more of {', '.join(INACTIVE_ROWS)}")
    names = ["quad12", "hex18"] if args.robot == "both" else [
        r.strip() for r in args.robot.split(",") if r.strip()]
    loaded = []
    for name in names:
        try:
            loaded.append((name, robots.load(name)))
        except RobotsError as exc:
            ap.error(f"--robot {name!r}: {exc}")
    if not loaded:
        ap.error(f"--robot {args.robot!r}: name a robot (a built-in name or a robot folder)")
    with tempfile.TemporaryDirectory(prefix="inactive_rows_") as work:
        for name, robot in loaded:
            gait, speed = case(robot)
            run(name, gait, speed, args.knots, args.random, args.warm, args.seed, Path(work),
                variants)


if __name__ == "__main__":
    main()

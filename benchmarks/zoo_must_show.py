"""Issue #14's must-show, as the user types it: every robot's template plan with no gait and no
flags (and optionally `--search`) at one Froude number, judged in MuJoCo, one table.

    python benchmarks/zoo_must_show.py                      # templates, Fr 0.02, every robot
    python benchmarks/zoo_must_show.py --search             # + `--search`, 4 generations, 1 worker
    python benchmarks/zoo_must_show.py --robots knee8,biped --froude 0.03 -- --period 1.3

Each row runs the real command line in a subprocess (`python -m gaitsmith.cli plan ROBOT
--speed V -o FILE --simulate [extra flags after --]`), V = √(Fr·g·L) with L the robot's leg
length, and reads the verdict, achieved speed, peak torque and heading from the written gait
file's `validation` block (what `--simulate` records). A command that writes no file (no
feasible gait, an error) is a FAIL row with the command's last output line. Prints a markdown
table (robot, legs, how, gait, duty/period, speed commanded/achieved, peak τ/stall planned (the
largest knot torque, planner metadata `servo_load`) and in MuJoCo, heading, verdict, wall and CPU
seconds) and writes it with the commands to `--out` (default zoo_must_show.md in the working
directory); `--keep DIR` keeps the gait files. Wall times depend on the machine's load; the CPU
seconds (children's user + system) less so.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import robots

ROOT = Path(__file__).resolve().parent.parent
ZOO = ROOT / "tests" / "zoo"
#: every robot of the zoo and the built-ins, as a user names them on the command line
ROBOTS = (
    "tests/zoo/spotmicro", "tests/zoo/bittle8", "tests/zoo/star5", "tests/zoo/phantomx18",
    "tests/zoo/humanoid20", "tests/zoo/knee8", "quad12", "hex18", "biped",
)
GRAVITY_M_S2 = 9.81
SEARCH_FLAGS = ("--search", "--generations", "4", "--workers", "1")


@dataclass(frozen=True)
class Row:
    robot: str
    legs: int
    how: str
    gait: str
    timing: str
    speed_cmd_m_s: float
    speed_m_s: float | None
    peak_torque: float | None
    plan_peak_torque: float | None
    heading_deg: float | None
    verdict: str
    wall_s: float
    cpu_s: float
    knife_edge: str = "–"  # `plan --knife-edge`'s "k of n runs pass" (template rows, --knife-edge)

    def markdown(self) -> str:
        def num(v: float | None, fmt: str) -> str:
            return "–" if v is None else format(v, fmt)

        def pct(v: float | None) -> str:
            return num(None if v is None else 100 * v, ".0f")

        return (f"| {self.robot} | {self.legs} | {self.how} | {self.gait} | {self.timing} | "
                f"{self.speed_cmd_m_s:.3f} / {num(self.speed_m_s, '.3f')} | "
                f"{pct(self.plan_peak_torque)} / {pct(self.peak_torque)} % | "
                f"{num(self.heading_deg, '+.1f')}° | {self.verdict} | {self.knife_edge} | "
                f"{self.wall_s:.0f} s | {self.cpu_s:.0f} s |")


HEADER = ("| robot | legs | how | gait | duty / period | speed cmd / achieved [m/s] "
          "| peak τ / stall, plan / MuJoCo | heading | MuJoCo | knife edge | wall | CPU |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|")
#: `sim.robustness.KnifeEdgeCheck`'s summary line, as `plan --knife-edge` prints it
KNIFE_EDGE_LINE = re.compile(r"(robust|knife edge|fails): (\d+) of (\d+) runs pass")


def froude_speed_m_s(bot: robots.Robot, froude: float) -> float:
    """v = √(Fr·g·L), rounded to the millimetre per second the command line prints."""
    return round(math.sqrt(froude * GRAVITY_M_S2 * bot.leg_length_m), 3)


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _metric(metrics: dict[str, Any], name: str) -> float | None:
    value = metrics.get(name)
    return float(value) if isinstance(value, (int, float)) else None


def _degrees(rad: float | None) -> float | None:
    return None if rad is None else math.degrees(rad)


def _plan_peak_torque(data: dict[str, Any]) -> float | None:
    """The plan's largest knot |τ|/τ_stall over all joints (planner metadata `servo_load`)."""
    load = (data.get("planner") or {}).get("servo_load") or {}
    peaks = [v.get("peak_torque_over_stall") for v in load.values() if isinstance(v, dict)]
    values = [float(p) for p in peaks if isinstance(p, (int, float))]
    return max(values) if values else None


def robot_path(robot: str) -> str:
    """A built-in robot's name as given, a folder relative to the repository made absolute."""
    return str(ROOT / robot) if (ROOT / robot).is_dir() else robot


def run_row(robot: str, froude: float, search: bool, extra: list[str], tmp: Path,
            knife_edge: bool = False) -> Row:
    """One command, one row (see the module docstring); `knife_edge`: the template command
    also runs `--knife-edge` (perturbed re-plans, minutes) and the row says how many pass."""
    bot = robots.load(robot_path(robot))
    speed = froude_speed_m_s(bot, froude)
    out = tmp / f"{bot.name}{'_search' if search else ''}.json"
    out.unlink(missing_ok=True)
    cmd = [sys.executable, "-m", "gaitsmith.cli", "plan", robot, "--speed", f"{speed:g}",
           "-o", str(out), "--simulate", *(SEARCH_FLAGS if search else ()), *extra]
    knife_edge = knife_edge and not search  # plan refuses --knife-edge with --search
    if knife_edge:
        cmd.append("--knife-edge")
    cpu0, t0 = _children_cpu_s(), time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, cwd=ROOT,
                          env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")})
    wall, cpu = time.perf_counter() - t0, _children_cpu_s() - cpu0
    how = ("--search" if search else "template") + (f" {' '.join(extra)}" if extra else "")
    if not out.exists():
        last = (proc.stderr.strip() or proc.stdout.strip() or "no output").splitlines()[-1]
        return Row(bot.name, len(bot.legs), how, "–", "–", speed, None, None, None, None,
                   f"**FAIL**: {last[:160]}", wall, cpu, "–")
    data = json.loads(out.read_text(encoding="utf-8"))
    validation = data.get("validation") or {}
    metrics = validation.get("metrics") or {}
    duty = (data.get("schedule") or {}).get("duty_factor") or []
    period = data.get("period_s")
    timing = (f"{min(duty):.2f}–{max(duty):.2f} / {period:.2f} s"
              if duty and isinstance(period, (int, float)) else "–")
    passed = bool(validation.get("passed"))
    reasons = "; ".join(str(r) for r in validation.get("reasons") or [])
    verdict = "**PASS**" if passed else f"**FAIL**: {reasons[:160] or 'not simulated'}"
    found = KNIFE_EDGE_LINE.search(" ".join(proc.stdout.split()))
    robust = (f"{found[2]} of {found[3]}" if found else "no summary") if knife_edge else "–"
    return Row(
        bot.name, len(bot.legs), how, str(data.get("gait_label") or "?"), timing,
        speed,
        _metric(metrics, "achieved_speed_m_s"),
        _metric(metrics, "peak_torque_fraction"),
        _plan_peak_torque(data),
        _degrees(_metric(metrics, "heading_error_rad")),
        verdict, wall, cpu, robust,
    )


def main(argv: list[str] | None = None) -> int:
    args_in = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in args_in:
        cut = args_in.index("--")
        args_in, extra = args_in[:cut], args_in[cut + 1:]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default=",".join(ROBOTS),
                        help="comma-separated robots (built-in names or folders)")
    parser.add_argument("--froude", type=float, default=0.02)
    parser.add_argument("--search", action="store_true", help="also run each robot's --search")
    parser.add_argument("--out", type=Path, default=Path("zoo_must_show.md"))
    parser.add_argument("--knife-edge", action="store_true",
                        help="the template commands also run plan --knife-edge (7 perturbed "
                        "re-plans each: judge a default by how many pass, not by one run)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="write the gait files here (default: a temporary folder)")
    args = parser.parse_args(args_in)
    if not (math.isfinite(args.froude) and 0 < args.froude <= 1):
        parser.error(f"--froude must lie in (0, 1], got {args.froude}")
    names = [r for r in args.robots.split(",") if r]
    for robot in names:  # every robot loads before the first (minutes-long) command
        try:
            robots.load(robot_path(robot))
        except robots.RobotsError as exc:
            parser.error(f"--robots: {exc}")
    rows: list[Row] = []
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    print(HEADER, flush=True)
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="zoo_must_show_") as tmp:
        folder = Path(tmp) if args.keep is None else args.keep.resolve()
        for robot in names:
            for search in (False, True) if args.search else (False,):
                row = run_row(robot, args.froude, search, extra, folder, args.knife_edge)
                rows.append(row)
                print(row.markdown(), flush=True)
    load = os.getloadavg()[0]
    text = (f"Run {started} (load at the end {load:.1f}), Fr {args.froude:g}, "
            f"extra flags: {' '.join(extra) or 'none'}\n\n"
            f"    python benchmarks/zoo_must_show.py {' '.join(sys.argv[1:])}\n\n"
            + HEADER + "\n" + "\n".join(r.markdown() for r in rows) + "\n")
    args.out.write_text(text, encoding="utf-8")
    failed = sum("PASS" not in r.verdict for r in rows)
    print(f"{len(rows) - failed} of {len(rows)} pass; table in {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

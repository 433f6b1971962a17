"""Measurements on built gait libraries (the figures of docs/results/gait_library.md).

    python benchmarks/library_check.py track LIB.json -- VX,VY,W [VX,VY,W ...]
    python benchmarks/library_check.py transitions LIB.json [--accel 0.5] [--yaw-accel 2.0]
    python benchmarks/library_check.py warm ROBOT [--knots 30]

- `track`: the blender's 100 Hz stream from the stand for each command into the MuJoCo servo
  model (`tests/sim/test_blend_tracking.blended_run`); achieved vx, vy and yaw rate in the
  world frame over the steady cycles, judged with the default `PassCriteria` tolerances (vx for
  straight commands, yaw rate for turning ones — as `sim.validate` judges the entries).
- `transitions`: stand → the grid's top corner → its opposite corner → zero, with the command
  speed budget (`BlendLimits.command_speed_share`) and without: on how many ticks the per-tick
  speed clip had to cut the targets, and that the run ends standing.
- `warm`: IPOPT iterations and CPU time of a cold solve and of a solve warm-started from the
  (0, 0, 0) solution, at one grid step in vx and in yaw rate (`planner.library.default_grid`).
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace

import numpy as np

from robots import Velocity
from robots import library as libfile
from robots.blend import BlendLimits, GaitBlender


def track(path: str, commands: list[str]) -> None:
    from sim.validate import PassCriteria
    from tests.sim.test_blend_tracking import blended_run

    lib = libfile.load(path)
    robot = libfile.robot_for(lib, path)
    pc = PassCriteria()
    print("| command | achieved vx, vy [m/s], yaw rate [rad/s] | judged | tolerance | verdict |")
    print("|---|---|---|---|---|")
    for text in commands:
        cmd = Velocity(*(float(x) for x in text.split(",")))
        t, xy, yaw, full_at = blended_run(robot, lib, cmd, 14.0)
        i0 = int(np.argmax(t >= full_at + pc.warmup_cycles * lib.entries[0].gait.period_s))
        span = t[-1] - t[i0]
        c0, s0 = math.cos(yaw[0]), math.sin(yaw[0])
        dx, dy = (xy[-1] - xy[i0]) / span
        vx, vy, w = c0 * dx + s0 * dy, -s0 * dx + c0 * dy, (yaw[-1] - yaw[i0]) / span
        if cmd.yaw_rate_rad_s == 0.0:
            name, got, want = "vx", vx, cmd.vx_m_s
            tol = max(pc.speed_rel_tol * abs(want), pc.speed_abs_tol_m_s)
        else:
            name, got, want = "yaw rate", w, cmd.yaw_rate_rad_s
            tol = max(pc.yaw_rate_rel_tol * abs(want), pc.yaw_rate_abs_tol_rad_s)
        verdict = "pass" if abs(got - want) <= tol else "FAIL"
        print(f"| {text} | {vx:+.4f}, {vy:+.4f}, {w:+.4f} | {name} | ±{tol:.3f} | {verdict} |")


def transitions(path: str, accel: float, yaw_accel: float) -> None:
    lib = libfile.load(path)
    robot = libfile.robot_for(lib, path)
    lo, hi = lib.command_bounds()
    script = ([Velocity()] * 50 + [hi] * 600 + [Velocity(lo.vx_m_s, 0.0, lo.yaw_rate_rad_s)] * 600
              + [Velocity()] * 900)
    limits = BlendLimits.for_robot(robot, accel, yaw_accel)
    for share in (limits.command_speed_share, None):
        b = GaitBlender(lib, replace(limits, command_speed_share=share))
        q = [b.targets_rad]
        clipped = 0
        for c in script:
            q.append(b.step(c, 0.01))
            clipped += b.speed_clipped
        speed = np.abs(np.diff(np.array(q), axis=0)) / 0.01 / limits.joint_speed_rad_s
        if not b.standing:
            raise SystemExit(f"did not end standing ({b.state})")
        print(f"{robot.name}: accel {accel} m/s², {yaw_accel} rad/s², command speed share "
              f"{share}: speed clip acted on {clipped} of {len(script)} ticks; peak speed / "
              f"limit {speed.max():.3f}; ends standing")


def warm(robot_name: str, knots: int) -> None:
    import robots
    from planner.library import default_grid
    from planner.nlp.spacetime import GaitPlanner
    from planner.templates import default_gait_for, make_schedule

    robot = robots.load(robot_name)
    schedule = make_schedule(robot, default_gait_for(robot))
    grid = default_grid(robot)
    planner = GaitPlanner(robot, knots)
    t0 = time.process_time()
    base = planner.solve(schedule, 0.0, False)
    print(f"cold (0, 0, 0): {base.iterations} iterations, {time.process_time() - t0:.1f} s CPU")
    for vx, w in ((grid.vx_m_s[2], 0.0), (0.0, grid.yaw_rate_rad_s[-1])):
        t0 = time.process_time()
        cold = planner.solve(schedule, vx, False, yaw_rate_rad_s=w)
        t1 = time.process_time()
        hot = planner.solve(schedule, vx, base.warm_start, yaw_rate_rad_s=w)
        t2 = time.process_time()
        print(f"({vx}, 0, {w}): cold {cold.iterations} it {t1 - t0:.1f} s, cost {cold.cost:.5g}; "
              f"warm {hot.iterations} it {t2 - t1:.1f} s, cost {hot.cost:.5g}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    a = sub.add_parser("track")
    a.add_argument("library")
    a.add_argument("commands", nargs="+")
    b = sub.add_parser("transitions")
    b.add_argument("library")
    b.add_argument("--accel", type=float, default=0.5)
    b.add_argument("--yaw-accel", type=float, default=2.0)
    c = sub.add_parser("warm")
    c.add_argument("robot")
    c.add_argument("--knots", type=int, default=30)
    args = ap.parse_args()
    if args.what == "track":
        track(args.library, args.commands)
    elif args.what == "transitions":
        transitions(args.library, args.accel, args.yaw_accel)
    else:
        warm(args.robot, args.knots)


if __name__ == "__main__":
    main()

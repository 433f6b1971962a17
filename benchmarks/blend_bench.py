"""Blending cost per tick [µs] for 12 and 18 servos, against a plain `Gait.joint_targets` call.

    python benchmarks/blend_bench.py [--ticks 20000] [--library lib.json ...]

Per robot: a `GaitBlender` over a library, stepped with a command inside a grid cell (all 2³
corners active when the grid has three axes) while walking, with the per-tick speed and
joint-limit clip; the baseline is one `Gait.joint_targets(t)` call on one of the library's gaits
(what the player does per tick for a single gait), timed in the same run; and the blender while
its command changes every tick (the joint speed budget of a command change costs two more
spline blends). Times are CPU time per
call (`time.process_time`), so that the shared machine's load does not count.

Without `--library` the synthetic library of the tests (`tests/robots/library_fixture.py`:
N = 30 knots, a 3 × 3 × 3 grid) is used for quad12 (12 servos) and hex18 (18 servos): the cost
depends on the joint and knot counts and the number of active corners, not on the gaits' values.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import robots
from robots import Velocity
from robots import library as libfile
from robots.blend import BlendLimits, GaitBlender
from robots.library import GaitLibrary, velocity_tuple


def _synthetic(robot: robots.Robot) -> GaitLibrary:
    from tests.robots import library_fixture as fx

    return fx.make_library(robot, vx=(0.0, 0.1, 0.2), vy=(-0.05, 0.0, 0.05),
                           yaw=(-0.5, 0.0, 0.5), n_knots=30)


def _inside(lib: GaitLibrary) -> Velocity:
    """A command 0.37 of the way across the first cell of every axis with two values or more."""
    c = np.array([velocity_tuple(e.command) for e in lib.entries])
    out = []
    for a in range(3):
        values = np.unique(c[:, a])
        out.append(float(values[0] + 0.37 * (values[1] - values[0])) if len(values) > 1
                   else float(values[0]))
    return Velocity(*out)


def _per_call_us(fn: object, n: int, repeats: int = 5) -> float:
    """Median over `repeats` of the mean CPU time per call of `fn()` over `n` calls [µs]
    (process CPU time, not wall time: the figure holds on a loaded machine too)."""
    runs = []
    for _ in range(repeats):
        t0 = time.process_time()
        for _ in range(n):
            fn()  # type: ignore[operator]
        runs.append((time.process_time() - t0) / n * 1e6)
    return statistics.median(runs)


def bench(robot: robots.Robot, lib: GaitLibrary, ticks: int) -> tuple[float, float, float, int]:
    limits = BlendLimits.for_robot(robot, accel_m_s2=0.5, yaw_accel_rad_s2=2.0)
    blender = GaitBlender(lib, limits)
    cmd = _inside(lib)
    dt = 0.01
    for _ in range(2000):  # ramp in, blend in, reach the command
        blender.step(cmd, dt)
    assert blender.state == "gait" and blender.command == cmd, (blender.state, blender.command)
    active = len(blender._grid.weights(velocity_tuple(cmd))[0])
    gait = lib.entries[0].gait
    t = [0.0]

    def plain() -> None:
        t[0] += dt
        gait.joint_targets(t[0])

    blend_us = _per_call_us(lambda: blender.step(cmd, dt), ticks)
    plain_us = _per_call_us(plain, ticks)
    # the command changing every tick (towards a far corner and back): the speed budget runs
    lo, hi = lib.command_bounds()
    flip = [0]

    def changing() -> None:
        flip[0] += 1
        blender.step(hi if (flip[0] // 50) % 2 else lo, dt)

    changing_us = _per_call_us(changing, ticks)
    return blend_us, changing_us, plain_us, active


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=20000)
    ap.add_argument("--library", nargs="*", default=[], help="library files (default: synthetic)")
    args = ap.parse_args()
    cases = []
    if args.library:
        for path in args.library:
            lib = libfile.load(path)
            cases.append((libfile.robot_for(lib, path), lib, path))
    else:
        for name in ("quad12", "hex18"):
            robot = robots.load(name)
            cases.append((robot, _synthetic(robot), "synthetic 3×3×3, N=30"))
    print("| robot | servos | library | entries | active corners | blend step [µs] | "
          "… command changing [µs] | Gait.joint_targets [µs] | ratio (steady) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for robot, lib, what in cases:
        blend_us, changing_us, plain_us, active = bench(robot, lib, args.ticks)
        print(f"| {robot.name} | {robot.dof} | {what} | {len(lib.entries)} | {active} | "
              f"{blend_us:.1f} | {changing_us:.1f} | {plain_us:.1f} | "
              f"{blend_us / plain_us:.2f} |")


if __name__ == "__main__":
    main()

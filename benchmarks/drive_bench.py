"""Drive loop rate and jitter, and the blender's cost per tick, each beside its `run` baseline.

    PYTHONPATH=. python benchmarks/drive_bench.py [--seconds 8] [--rate 100] [--library LIB]

1. Blending cost per tick [µs], for quad12 (12 servos) and hex18 (18): `GaitBlender.step` at a
   command that wanders through the library's grid (new cell, new weights every 20 ticks),
   beside what `run` computes per tick (`Gait.joint_targets`, one periodic spline), both timed
   in this process, one after the other (median and p99 over `--steps` ticks, after warm-up),
   in wall time and in this thread's CPU time (which a loaded machine's preemption leaves out).
2. Loop rate and wake-up jitter at `--rate`, real time, on the in-process virtual bus (vendor
   SDK + byte-level emulator; one sync-write + one sync-read per tick, a status read every 10):
   `drive` (scripted JSON-line commands on a pipe, walking for `--seconds`) beside `run` (a
   bring-up gait for the same time), same robot, same process.

Without `--library` the grid is the synthetic one of the tests (`tests/robots/library_fixture`:
vx × yaw = 3 × 3 entries, 24 knots; a planned library has more knots, which costs nothing per
tick: a spline segment is a gather, not a solve); with it, that library's robot is timed.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from collections.abc import Callable

import numpy as np

import robots
from hardware.bus.servo_bus import BusConfig
from hardware.play.clock import MonotonicClock
from hardware.play.command_sources import StreamSource
from hardware.play.drive import drive_from_library
from hardware.play.player import Player, PlayerConfig, PlayResult
from hardware.play.virtual_rig import bringup_gait, virtual_robot_bus
from robots.blend import BlendLimits, GaitBlender
from robots.gait import Velocity
from robots.library import GaitLibrary
from robots.library import load as load_library


def _library(robot_name: str, path: str | None) -> tuple[robots.Robot, GaitLibrary]:
    if path is not None:
        lib = load_library(path)
        return robots.load(lib.robot), lib
    from tests.robots.library_fixture import make_library

    robot = robots.load(robot_name)
    return robot, make_library(robot)


def _timed(fn: Callable[[int], object], steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall and CPU time [µs] of `fn(k)` for k < steps (CPU time: this thread's, so another
    process taking the core during a call does not count)."""
    wall, cpu = np.empty(steps), np.empty(steps)
    for k in range(steps):
        c0, w0 = time.thread_time_ns(), time.perf_counter_ns()
        fn(k)
        wall[k] = time.perf_counter_ns() - w0
        cpu[k] = time.thread_time_ns() - c0
    return wall / 1e3, cpu / 1e3


def blend_cost_us(robot: robots.Robot, lib: GaitLibrary, steps: int) -> dict[str, float]:
    """Median / p99 [µs] of one `GaitBlender.step` and of one `Gait.joint_targets`, wall
    and CPU time."""
    limits = BlendLimits.for_robot(robot, accel_m_s2=2.0, yaw_accel_rad_s2=5.0, speed_fraction=0.9)
    blender = GaitBlender(lib, limits)
    lo, hi = lib.command_bounds()
    rng = np.random.default_rng(1)
    dt = 0.01
    commands = [
        Velocity(*(rng.uniform([lo.vx_m_s, lo.vy_m_s, lo.yaw_rate_rad_s],
                               [hi.vx_m_s, hi.vy_m_s, hi.yaw_rate_rad_s])))
        for _ in range(steps // 20 + 1)
    ]  # fmt: skip
    for _ in range(300):  # warm-up: enter walking
        blender.step(commands[0], dt)
    gait = lib.entries[0].gait
    gait.joint_targets(0.0)
    bw, bc = _timed(lambda k: blender.step(commands[k // 20], dt), steps)  # new command / 20
    sw, sc = _timed(lambda k: gait.joint_targets(k * dt), steps)
    out = {}
    for name, a in (("blend", bw), ("blend_cpu", bc), ("run", sw), ("run_cpu", sc)):
        out[f"{name}_p50"], out[f"{name}_p99"] = float(np.median(a)), float(np.percentile(a, 99))
    return out


def _script(seconds: float, lib: GaitLibrary) -> StreamSource:
    _, hi = lib.command_bounds()
    lines = [
        {"t": round(0.1 * i, 3), "vx": hi.vx_m_s / 2, "yaw_rate": hi.yaw_rate_rad_s / 2}
        for i in range(int(seconds / 0.1))
    ] + [{"t": seconds, "end": True}]
    data = "".join(json.dumps(c) + "\n" for c in lines).encode()
    fd, path = tempfile.mkstemp(suffix=".jsonl")
    os.write(fd, data)
    os.lseek(fd, 0, os.SEEK_SET)
    os.unlink(path)
    return StreamSource(fd, "script")


def loop_stats(robot: robots.Robot, lib: GaitLibrary, seconds: float, rate: float
               ) -> dict[str, tuple[PlayResult, float]]:  # fmt: skip
    """Per loop: its result and its CPU time per tick [ms] (the process's, bus emulation
    included: what the loop costs whatever else the machine runs)."""
    out: dict[str, tuple[PlayResult, float]] = {}
    cfg = PlayerConfig(rate_hz=rate, cycles=None, ramp_s=0.5, force=True)
    clock = MonotonicClock()
    bus = virtual_robot_bus(robot, clock=clock.now_s).connect(BusConfig(timeout_s=0.003))
    driver = drive_from_library(robot, lib, _script(seconds, lib), bus=bus, config=cfg,
                                clock=clock)  # fmt: skip
    c0 = time.process_time()
    play = driver.drive_run().play
    out["drive"] = play, (time.process_time() - c0) / max(1, play.ticks) * 1e3
    gait = bringup_gait(robot, period_s=0.8)
    clock = MonotonicClock()
    bus = virtual_robot_bus(robot, clock=clock.now_s).connect(BusConfig(timeout_s=0.003))
    run_cfg = PlayerConfig(rate_hz=rate, cycles=seconds / gait.period_s, ramp_s=0.5, force=True)
    c0 = time.process_time()
    play = Player(robot, gait, bus=bus, config=run_cfg, clock=clock).run()
    out["run"] = play, (time.process_time() - c0) / max(1, play.ticks) * 1e3
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=8.0, help="walking time per loop [s]")
    ap.add_argument("--rate", type=float, default=100.0, help="requested rate [Hz]")
    ap.add_argument("--steps", type=int, default=20000, help="ticks timed per blend figure")
    ap.add_argument("--library", default=None, help="a gaitsmith.library/1 file (its robot)")
    args = ap.parse_args()
    names = ["quad12", "hex18"] if args.library is None else [None]
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print("blending cost per tick [µs] (median / p99) vs run's gait spline:")
    libs = []
    for name in names:
        robot, lib = _library(name or "", args.library)
        libs.append((robot, lib))
        c = blend_cost_us(robot, lib, args.steps)
        for kind in ("", "_cpu"):
            print(
                f"  {robot.name:7s} {robot.dof:2d} servos, {len(lib.entries)} entries, "
                f"{'CPU ' if kind else 'wall'}: blend {c[f'blend{kind}_p50']:6.1f} / "
                f"{c[f'blend{kind}_p99']:7.1f}   run {c[f'run{kind}_p50']:6.1f} / "
                f"{c[f'run{kind}_p99']:7.1f}   ratio (median) "
                f"{c[f'blend{kind}_p50'] / c[f'run{kind}_p50']:.1f}×"
            )
    print(f"loop at {args.rate:g} Hz, real time, in-process virtual bus:")
    for robot, lib in libs:
        for label, (r, cpu_ms) in loop_stats(robot, lib, args.seconds, args.rate).items():
            print(
                f"  {robot.name:7s} {label:5s} CPU/tick {cpu_ms:.2f} ms  ticks {r.ticks:5d}  "
                "achieved "
                f"{r.achieved_rate_hz:7.2f} Hz (ratio {r.achieved_rate_hz / args.rate:.4f})  "
                f"jitter p50 {r.jitter_p50_s * 1e3:.3f} ms  p99 {r.jitter_p99_s * 1e3:.3f} ms  "
                f"max {r.jitter_max_s * 1e3:.3f} ms  work p99 {r.work_p99_s * 1e3:.2f} ms  "
                f"overruns {r.overruns}  stop {r.stop.reason.value}"
            )

if __name__ == "__main__":
    main()

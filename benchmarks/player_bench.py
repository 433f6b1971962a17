"""Player loop rate and jitter, real time, on the in-process virtual bus.

    python benchmarks/player_bench.py [--robot quad12] [--seconds 8] [--rate 100]

Streams a bring-up gait to the robot's servos (12 × STS3215 for quad12) through the vendor SDK
and the byte-level emulator, one sync-write + one sync-read per tick and a status read every
10 ticks, on the wall clock. Prints achieved / requested rate, wake-up jitter percentiles,
overruns and the per-tick work time.
"""

from __future__ import annotations

import argparse

import numpy as np

import robots
from hardware.bus.servo_bus import BusConfig
from hardware.play.clock import MonotonicClock
from hardware.play.player import Player, PlayerConfig
from hardware.play.telemetry import TelemetryWriter, read_telemetry
from hardware.play.virtual_rig import bringup_gait, virtual_robot_bus


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--seconds", type=float, default=8.0, help="gait time to stream [s]")
    ap.add_argument("--rate", type=float, default=100.0, help="requested rate [Hz]")
    ap.add_argument("--telemetry", default="/tmp/player_bench.csv")
    args = ap.parse_args()

    robot = robots.load(args.robot)
    gait = bringup_gait(robot, period_s=0.8)
    clock = MonotonicClock()
    bus = virtual_robot_bus(robot, clock=clock.now_s).connect(BusConfig(timeout_s=0.003))
    ids = [j.bus_id for j in robot.joints]
    writer = TelemetryWriter(args.telemetry, robot.joint_names, ids)
    cfg = PlayerConfig(
        rate_hz=args.rate, cycles=args.seconds / gait.period_s, ramp_s=0.5, force=True
    )
    result = Player(robot, gait, bus=bus, config=cfg, clock=clock, telemetry=writer).run()
    tel = read_telemetry(args.telemetry)
    loop_ms = np.array([float(r) for r in _column(args.telemetry, "loop_s")]) * 1e3
    jit_ms = tel.jitter_s * 1e3
    print(f"robot {robot.name}: {len(ids)} servos, {robot.servo_protocol}, in-process virtual bus")
    print(f"stop: {result.stop.reason.value} ({result.stop.message})")
    ratio = result.achieved_rate_hz / args.rate
    print(
        f"ticks {result.ticks}, requested {args.rate:.1f} Hz, "
        f"achieved {result.achieved_rate_hz:.2f} Hz, ratio {ratio:.4f}"
    )
    print(
        "wake-up jitter [ms]: p50 {:.3f}  p99 {:.3f}  max {:.3f}".format(
            *np.percentile(jit_ms, [50, 99]), jit_ms.max()
        )
    )
    print(
        "tick work [ms]: p50 {:.3f}  p99 {:.3f}  max {:.3f}  (budget {:.1f} ms, ratio p99/budget "
        "{:.2f})".format(
            *np.percentile(loop_ms, [50, 99]), loop_ms.max(), 1e3 / args.rate,
            np.percentile(loop_ms, 99) * args.rate / 1e3,
        )
    )  # fmt: skip
    print(f"overruns {result.overruns}, skipped deadlines {result.skipped}, "
          f"missed reads {result.misses}")  # fmt: skip


def _column(path: str, name: str) -> list[str]:
    import csv

    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    i = rows[0].index(name)
    return [r[i] for r in rows[1:] if r[1] != "stop"]


if __name__ == "__main__":
    main()

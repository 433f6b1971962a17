"""Check `gaitsmith-play budget` against the player on a virtual bus that emulates wire time.

    python benchmarks/bus_budget_check.py [--robot quad12 --robot hex18] [--seconds 4]
        [--rate 100] [--latency-ms 16] [--baud B]

For each robot: the budget (`hardware.bus.budget.for_robot`) at the robot's baud, the servos'
factory return delay and the given USB adapter latency; then a real-time player run of a bring-up
gait on the in-process virtual bus with `WireTiming(baud, latency)` (every reply released when a
real line and adapter would deliver it). Prints the achieved loop rate next to the budget's.
"""

from __future__ import annotations

import argparse

import robots
from hardware.bus import budget as bus_budget
from hardware.bus.servo_bus import BusConfig
from hardware.bus.virtual import WireTiming
from hardware.play.clock import MonotonicClock
from hardware.play.player import Player, PlayerConfig, PlayResult
from hardware.play.virtual_rig import bringup_gait, virtual_robot_bus


def measure(
    robot_name: str, seconds: float, rate_hz: float, latency_ms: float, baud: int | None = None
) -> tuple[bus_budget.BusBudget, PlayResult]:
    """(budget, player result) for one robot on the wire-timed virtual bus."""
    robot = robots.load(robot_name)
    baud = baud or robot.bus_baud
    budget = bus_budget.for_robot(robot, baud=baud, latency_ms=latency_ms)
    gait = bringup_gait(robot, period_s=0.8)
    clock = MonotonicClock()
    vbus = virtual_robot_bus(robot, clock=clock.now_s)
    vbus.wire = WireTiming(baud, latency_ms / 1000.0)
    bus = vbus.connect(BusConfig(timeout_s=0.003, baudrate=baud))
    cfg = PlayerConfig(rate_hz=rate_hz, cycles=seconds / gait.period_s, ramp_s=0.5, force=True)
    return budget, Player(robot, gait, bus=bus, config=cfg, clock=clock).run()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", action="append", default=None)
    ap.add_argument("--seconds", type=float, default=4.0, help="gait time to stream [s]")
    ap.add_argument("--rate", type=float, default=100.0, help="requested rate [Hz]")
    ap.add_argument("--latency-ms", type=float, default=bus_budget.FTDI_DEFAULT_LATENCY_MS)
    ap.add_argument("--baud", type=int, default=None)
    args = ap.parse_args()
    for name in args.robot or ["quad12", "hex18"]:
        budget, result = measure(name, args.seconds, args.rate, args.latency_ms, args.baud)
        ratio = result.achieved_rate_hz / budget.mean_rate_hz
        print(
            f"{name}: budget {budget.mean_rate_hz:.1f} Hz (dominant: {budget.dominant}); player "
            f"asked {args.rate:g} Hz achieved {result.achieved_rate_hz:.1f} Hz over "
            f"{result.ticks} ticks, ratio {ratio:.3f}; stop {result.stop.reason.value}; missed "
            f"reads {result.misses}, p99 tick work {result.work_p99_s * 1e3:.1f} ms"
        )


if __name__ == "__main__":
    main()

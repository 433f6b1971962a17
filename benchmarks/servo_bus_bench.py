"""Servo-bus throughput: sync-write + sync-read of 12 servos through the drivers (vendor SDKs)
on the in-process virtual bus, for both protocols; the codec-only rate is the baseline.

    python benchmarks/servo_bus_bench.py [--seconds 2]

Prints cycles/s for (a) the full driver path: DynamixelBus / FeetechBus → vendor SDK →
VirtualPort → VirtualServoBus (emulated servos) and back, and (b) the raw codec path alone:
build the same instruction packets, parse them, build and parse the 12 status packets. The
ratio shows how much of a control cycle is SDK/driver/emulation overhead rather than framing.
For scale: on a real 1 Mbps bus one such cycle is ~0.5-0.6 ms of wire time alone.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

from hardware.bus.protocol import dynamixel2 as dxl
from hardware.bus.protocol import feetech as ft
from hardware.bus.servo_bus import BusConfig
from hardware.bus.virtual import VirtualServoBus
from robots.servo import servo_model

IDS = list(range(1, 13))
MODELS = {"dynamixel2": "XL430_W250", "feetech_sts": "STS3215_7V4"}


def _rate(cycle: Callable[[int], None], seconds: float) -> float:
    n, t0 = 0, time.perf_counter()
    while (elapsed := time.perf_counter() - t0) < seconds:
        for _ in range(50):
            cycle(n)
            n += 1
    return n / elapsed


def driver_rate(protocol: str, seconds: float) -> float:
    model = servo_model(MODELS[protocol])
    vbus = VirtualServoBus({i: model for i in IDS}, protocol)
    bus = vbus.connect(BusConfig(timeout_s=0.01, retries=0))
    bus.torque_on(IDS)

    def cycle(n: int) -> None:
        bus.sync_write_positions({i: 1800 + (n + i) % 400 for i in IDS})
        got = bus.sync_read_positions(IDS)
        assert len(got) == len(IDS)

    rate = _rate(cycle, seconds)
    bus.close()
    return rate


def codec_rate(protocol: str, seconds: float) -> float:
    if protocol == "dynamixel2":

        def cycle(n: int) -> None:
            goals = {i: (1800 + (n + i) % 400).to_bytes(4, "little") for i in IDS}
            dxl.parse_packet(dxl.sync_write(116, 4, goals))
            dxl.parse_packet(dxl.sync_read(132, 4, IDS))
            for i in IDS:
                dxl.parse_packet(dxl.build_status(i, 0, goals[i]))

    else:
        parse = ft.parse_packet

        def cycle(n: int) -> None:
            goals = {i: (1800 + (n + i) % 400).to_bytes(2, "little") for i in IDS}
            parse(ft.sync_write(42, 2, goals), "instruction")
            parse(ft.sync_read(56, 2, IDS), "instruction")
            for i in IDS:
                parse(ft.build_status(i, 0, goals[i]), "status")

    return _rate(cycle, seconds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="measuring time per case [s]")
    args = ap.parse_args()
    print(f"sync-write + sync-read of {len(IDS)} servos, in-process virtual bus")
    print(
        f"{'protocol':<12} {'driver+SDK [cyc/s]':>19} {'codec only [cyc/s]':>19} "
        f"{'codec/driver':>13} {'driver cycle [ms]':>18}"
    )
    for protocol in ("dynamixel2", "feetech_sts"):
        d = driver_rate(protocol, args.seconds)
        c = codec_rate(protocol, args.seconds)
        print(f"{protocol:<12} {d:>19.0f} {c:>19.0f} {c / d:>12.1f}x {1000 / d:>18.3f}")


if __name__ == "__main__":
    main()

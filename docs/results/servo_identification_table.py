"""True vs fitted servos as the Markdown table of servo_identification.md.

Usage: python docs/results/servo_identification_table.py ROBOT TRUE.toml FITTED.toml
kp [N·m/rad] = gain_scale · factory duty per rad · strength · stall torque (`robots.servo_params`).
"""

from __future__ import annotations

import sys

import tomllib

import robots
from robots.servo import factory_gains

KEYS = ("gain_scale", "latency_ms", "strength")
HEADER = (
    "| joint | kp true [N·m/rad] | fitted | latency true [ms] | fitted | strength × true | fitted "
    "| worst error | held-back RMS [°] |"
)


def main(robot_name: str, true_path: str, fit_path: str) -> None:
    robot = robots.load(robot_name)
    with open(true_path, "rb") as fh:
        true = tomllib.load(fh)["joints"]
    with open(fit_path, "rb") as fh:
        fit = tomllib.load(fh)["joints"]
    print(HEADER)
    print("|---|---|---|---|---|---|---|---|---|")
    worst_all = 0.0
    for joint in robot.joints:
        t, f = true[joint.name], fit.get(joint.name)
        unit = factory_gains(joint.servo)[0] * joint.servo.stall_torque_nm

        def kp(s: dict[str, float], unit: float = unit) -> float:
            return s["gain_scale"] * s["strength"] * unit

        lat, s = t["latency_ms"], t["strength"]
        if f is None:
            cells = f"{kp(t):.2f} | — | {lat:.2f} | — | {s:.3f} | —"
            print(f"| {joint.name} | {cells} | left out | — |")
            continue
        err = max([abs(f[k] / t[k] - 1) for k in KEYS] + [abs(kp(f) / kp(t) - 1)])
        worst_all = max(worst_all, err)
        print(
            f"| {joint.name} | {kp(t):.2f} | {kp(f):.2f} | {lat:.2f} | {f['latency_ms']:.2f} "
            f"| {s:.3f} | {f['strength']:.3f} | {100 * err:.1f} % | {f['held_out_rms_deg']:.3f} |"
        )
    print(f"\nworst relative error over the fitted joints: {100 * worst_all:.1f} %")


if __name__ == "__main__":
    main(*sys.argv[1:4])

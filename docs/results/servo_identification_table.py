"""True vs fitted servos as the Markdown table of servo_identification.md.

python docs/results/servo_identification_table.py TRUE.toml FITTED.toml
"""

from __future__ import annotations

import sys

import tomllib

KEYS = ("gain_scale", "latency_ms", "strength")
HEADER = (
    "| joint | gain × true | fitted | latency true [ms] | fitted | strength × true | fitted "
    "| worst error | held-back RMS [°] |"
)


def main(true_path: str, fit_path: str) -> None:
    with open(true_path, "rb") as fh:
        true = tomllib.load(fh)["joints"]
    with open(fit_path, "rb") as fh:
        fit = tomllib.load(fh)["joints"]
    print(HEADER)
    print("|---|---|---|---|---|---|---|---|---|")
    worst_all = 0.0
    for name, t in true.items():
        f = fit.get(name)
        g, lat, s = t["gain_scale"], t["latency_ms"], t["strength"]
        if f is None:
            print(f"| {name} | {g:.3f} | — | {lat:.2f} | — | {s:.3f} | — | left out | — |")
            continue
        err = max(abs(f[k] / t[k] - 1) for k in KEYS)
        worst_all = max(worst_all, err)
        print(
            f"| {name} | {g:.3f} | {f['gain_scale']:.3f} | {lat:.2f} | {f['latency_ms']:.2f} "
            f"| {s:.3f} | {f['strength']:.3f} | {100 * err:.1f} % | {f['held_out_rms_deg']:.3f} |"
        )
    print(f"\nworst relative error over the fitted joints: {100 * worst_all:.1f} %")


if __name__ == "__main__":
    main(*sys.argv[1:3])

"""Print the swing slack (`planner.swing_slack`) of robots' default templates, one row each.

    python benchmarks/swing_slack_table.py                       # the zoo at issue #14's speeds
    python benchmarks/swing_slack_table.py quad12:0.4 tests/zoo/knee8:0.182

Columns: robot, speed, template, period, duty, slack, tightest joint, its excursion Δq, swing
time / fastest swing, armature / joint inertia, mechanical time constant τ_c = I·ω₀/(0.8·τ_stall),
and session 25's rotor figure Γ = I_a·g/(τ_stall·L) (docs/results/heavy_rotor.md, section 6).
"""

from __future__ import annotations

import sys

import robots
from planner.swing_slack import joint_swings, swing_slack
from planner.templates import default_gait_for, make_schedule

ZOO = ("tests/zoo/spotmicro:0.195", "tests/zoo/bittle8:0.130", "tests/zoo/star5:0.117",
       "tests/zoo/phantomx18:0.149", "tests/zoo/humanoid20:0.215", "tests/zoo/knee8:0.182",
       "quad12:0.25", "hex18:0.145", "biped:0.293")


def row(name: str, speed: float) -> str:
    bot = robots.load(name)
    gait = default_gait_for(bot)
    schedule = make_schedule(bot, gait)
    slack = swing_slack(bot, schedule, speed)
    js = {j.joint: j for j in joint_swings(bot)}[slack.joint]
    tau_c = js.inertia_kg_m2 * js.no_load_speed_rad_s / (0.8 * js.stall_torque_nm)
    gamma = max(j.armature_kg_m2 * 9.81 / (j.stall_torque_nm * bot.leg_length_m)
                for j in joint_swings(bot))
    return (f"| {name} | {speed:.3f} | {gait} | {schedule.period_s:.3f} | "
            f"{schedule.duty_factor[0]:.2f} | {slack.ratio:.2f} | {slack.joint} | "
            f"{slack.excursion_rad:.2f} | {slack.swing_s * 1000:.0f} / "
            f"{slack.fastest_swing_s * 1000:.0f} | {js.armature_kg_m2:.4f} / "
            f"{js.inertia_kg_m2:.4f} | {tau_c * 1000:.0f} | {gamma:.2f} |")


def main(argv: list[str]) -> None:
    for arg in argv or list(ZOO):
        name, speed = arg.rsplit(":", 1)
        print(row(name, float(speed)))


if __name__ == "__main__":
    main(sys.argv[1:])

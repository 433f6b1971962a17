"""Flat feet vs point feet on the same biped: planned sole tilt, yaw slip, solve time.

    python benchmarks/flat_foot_bench.py          # tests/planner/fixtures/biped12, N = 12

Plans a stand (both feet down, speed 0) and a slow walk (duty 0.75, feet half a period apart,
0.05 m/s, T = 1 s) twice: with the fixture's flat feet and with the same robot declared with
point feet (a 4 mm sphere at the sole's centre). For each it prints IPOPT's status, iterations and
solve time and, over the stance knots, the sole's largest tilt (angle of its normal from the
vertical) and its largest heading change between consecutive stance knots (yaw slip), measured
on the planned poses with MuJoCo's kinematics.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import mujoco
import numpy as np

import robots
from planner.nlp.spacetime import GaitPlanner, PlanResult
from robots import ContactSchedule, Robot
from robots.sole import sole_pose_world

BIPED = Path(__file__).parents[1] / "tests" / "planner" / "fixtures" / "biped12"
N_KNOTS = 12


def point_foot_copy(folder: Path) -> Path:
    """The biped with `foot = "flat"` removed (its foot sites sit at the sole centres)."""
    root = folder / "biped12_point"
    shutil.copytree(BIPED, root)
    toml = root / "robot.toml"
    toml.write_text(toml.read_text().replace('foot = "flat"\n', ""))
    return root


def schedules(robot: Robot) -> dict[str, tuple[ContactSchedule, float]]:
    feet = robot.foot_names
    return {
        "stand": (ContactSchedule(1.0, feet, (0.0, 0.0), (1.0, 1.0)), 0.0),
        "walk 0.05 m/s": (ContactSchedule(1.0, feet, (0.0, 0.5), (0.75, 0.75)), 0.05),
    }


def sole_tilt_and_yaw_slip_deg(
    flat: Robot, planner: GaitPlanner, result: PlanResult
) -> tuple[float, float]:
    """Largest stance tilt and stance heading change [°] of the soles (the flat robot's geoms)."""
    model = flat.mj_model()
    data = mujoco.MjData(model)
    contact = result.schedule.contact_matrix(N_KNOTS)
    tilt, yaw = 0.0, 0.0
    headings = np.zeros((N_KNOTS, len(flat.legs)))
    for k in range(N_KNOTS):
        data.qpos[:] = planner.model.mujoco_qpos(result.base_pose[k], result.joint_angles_rad[k])
        mujoco.mj_kinematics(model, data)
        for f, leg in enumerate(flat.legs):
            _, rot = sole_pose_world(model, data, leg)
            headings[k, f] = np.arctan2(rot[1, 0], rot[0, 0])
            if contact[k, f]:
                tilt = max(tilt, float(np.degrees(np.arccos(np.clip(rot[2, 2], -1, 1)))))
    for k in range(N_KNOTS):
        both = contact[k] & contact[(k + 1) % N_KNOTS]
        change = np.angle(np.exp(1j * (headings[(k + 1) % N_KNOTS] - headings[k])))
        if both.any():
            yaw = max(yaw, float(np.degrees(np.abs(change[both]).max())))
    return tilt, yaw


def main() -> None:
    flat = robots.load(BIPED)
    with tempfile.TemporaryDirectory() as tmp:
        point = robots.load(point_foot_copy(Path(tmp)))
        for kind, robot in (("point", point), ("flat", flat)):
            planner = GaitPlanner(robot, n_knots=N_KNOTS)
            print(f"{kind} feet: NLP built in {planner.build_time_s:.1f} s")
            for name, (schedule, speed) in schedules(robot).items():
                result = planner.solve(schedule, speed, warm_start=False)
                # the soles of both plans measured with the flat robot's sole geometry
                tilt, yaw = sole_tilt_and_yaw_slip_deg(flat, planner, result)
                stall = np.array([j.servo.stall_torque_nm for j in robot.joints])
                print(
                    f"  {name:14s} {result.status:22s} {result.iterations:3d} it "
                    f"{result.solve_time_s:6.2f} s  stance sole tilt ≤ {tilt:6.2f}°  "
                    f"yaw slip ≤ {yaw:5.2f}°  peak |τ|/τ_stall "
                    f"{(np.abs(result.joint_torques_nm) / stall).max():.2f}"
                )


if __name__ == "__main__":
    main()

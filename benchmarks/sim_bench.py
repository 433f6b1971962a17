"""Simulation and rendering speed of `sim` (run: python benchmarks/sim_bench.py).

Measures, per built-in robot, with a kinematic walking gait (`sim.synthetic`):

- baseline: bare `mj_step` of the robot's MJCF (no actuators, no sensors) through
  `mujoco.rollout`, same number of steps — the engine alone (the unactuated robot slumps onto
  its belly, so its contact set differs; the ratio shows what the servo model costs);
- the validation run: servo actuators + logging sensors + target stream (ZOH, delay line),
  ramp-in and chunked rollout (`sim.validate.simulate`);
- metrics + verdict on the logged run (`sim.validate.evaluate`);
- 10 s of 640×480 MP4 (offscreen EGL render + H.264 encode), and the render alone.

Prints times, × real time, and ratios against the baseline measured in the same run. Targets:
validation ≥ 50× real time, 10 s of 640×480 video in ≤ 20 s.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse
import tempfile
import time
from pathlib import Path

import mujoco
import mujoco.rollout
import numpy as np

import robots
from sim.render import iter_frames, render_video
from sim.synthetic import kinematic_gait, trot_schedule
from sim.validate import evaluate, simulate

SIM_TARGET_X = 50.0
VIDEO_TARGET_S = 20.0


def _best(fn, repeats: int) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def bench_robot(name: str, cycles: int, repeats: int, video: bool) -> None:
    robot = robots.load(name)
    speed = 0.1 if len(robot.legs) > 4 else 0.12
    gait = kinematic_gait(robot, trot_schedule(robot, 0.5, 0.6), speed)
    sim, traj = simulate(gait, robot, cycles)  # warm-up (and the run we render)
    sim_s = float(traj.time_s[-1])
    n = traj.n_steps

    bare = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))
    data = mujoco.MjData(bare)
    data.qpos[2] = robot.stance_base_height_m
    state = np.empty(mujoco.mj_stateSize(bare, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(bare, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    ctrl = np.zeros((1, n, 0))
    t_bare = _best(lambda: mujoco.rollout.rollout(bare, data, state[None], ctrl, nstep=n), repeats)
    t_sim = _best(lambda: simulate(gait, robot, cycles), repeats)
    t_eval = _best(lambda: evaluate(traj, gait, sim), repeats)
    x_bare, x_sim = sim_s / t_bare, sim_s / (t_sim + t_eval)
    print(
        f"\n{name}: {cycles} cycles = {sim_s:.2f} s simulated, {n} steps of "
        f"{sim.model.opt.timestep * 1000:.1f} ms, {robot.dof} servos"
    )
    print(f"  bare mj_step (baseline)      {t_bare:7.3f} s  {x_bare:7.1f}× real time   1.00")
    print(
        f"  validation run (servo model) {t_sim:7.3f} s  {sim_s / t_sim:7.1f}× real time  "
        f"{t_sim / t_bare:5.2f}× baseline"
    )
    print(f"  + metrics/verdict            {t_eval:7.3f} s")
    print(
        f"  validate() total             {t_sim + t_eval:7.3f} s  {x_sim:7.1f}× real time  "
        f"(target ≥ {SIM_TARGET_X:.0f}×: {'ok' if x_sim >= SIM_TARGET_X else 'MISSED'})"
    )
    if not video:
        return
    seconds = min(10.0, sim_s)
    t = time.perf_counter()
    frames = sum(1 for _ in iter_frames(sim, traj, duration_s=seconds))
    t_frames = time.perf_counter() - t
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        render_video(Path(tmp) / "bench.mp4", sim, traj, duration_s=seconds)
        t_video = time.perf_counter() - t
    print(
        f"  render {frames} frames 640×480   {t_frames:7.2f} s  "
        f"({t_frames / frames * 1000:.1f} ms/frame)"
    )
    print(
        f"  {seconds:.0f} s MP4 640×480 (render+enc) {t_video:5.2f} s  "
        f"{seconds / t_video:5.2f}× real time, encode overhead {t_video / t_frames:4.2f}× render "
        f"(target ≤ {VIDEO_TARGET_S:.0f} s: {'ok' if t_video <= VIDEO_TARGET_S else 'MISSED'})"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["quad12", "hex18"])
    ap.add_argument("--cycles", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-video", action="store_true")
    args = ap.parse_args()
    print(
        f"mujoco {mujoco.__version__}, {os.cpu_count()} CPUs, MUJOCO_GL={os.environ['MUJOCO_GL']}"
    )
    for name in args.robots:
        bench_robot(name, args.cycles, args.repeats, not args.no_video)


if __name__ == "__main__":
    main()

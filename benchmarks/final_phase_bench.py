"""The search's final phase alone, in this process vs on a 2-worker pool, interleaved.

    python benchmarks/final_phase_bench.py [--robot quad12 --speed 0.25 --gaits a,b,c] [--repeats 3]

The final phase of `search_gait` with fixed candidates: the given templates' schedules as the
search encodes them (first foot at phase 0), re-solved at 30 knots and judged by the command
line's final MuJoCo check (`gaitsmith.search_options.sim_acceptance`), first accepted wins
(`planner.search.final_phase.choose_final`). "serial": this process builds the final planner
and check, then solves and checks in rank order (the code before session 32). "process": a
2-worker spawn pool whose workers have built their final planner and check beforehand (as the
search's barrier idle time does, `ProcessExecutor.idle_task`) reads the same tasks speculatively
while this process builds its own final planner; the phase ends when the pool is closed (a worker
still solving an unread candidate is terminated). Wall time of the phase, the CPU of this process
and of the outcomes read, and the choice, which must be the same in both.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="quad12")
    ap.add_argument("--speed", type=float, default=0.25)
    ap.add_argument("--gaits", default="diagonal_walk,pace,trot",
                    help="templates, in rank order (their search encodings are solved)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()

    import robots
    from gaitsmith.search_options import sim_acceptance
    from planner.nlp.config import PlannerOptions
    from planner.nlp.spacetime import GaitPlanner
    from planner.search.basin_cma import LocalResult
    from planner.search.executors import ProcessExecutor, SerialExecutor
    from planner.search.final_phase import (
        FinalPlannerSpec,
        FinalTask,
        choose_final,
        evaluate_final,
        prepare_final,
        worker_final_solve,
    )
    from planner.search.gait_search import TimingSpace
    from planner.templates import make_schedule

    bot = robots.load(args.robot)
    space = TimingSpace.for_robot(bot)
    options = PlannerOptions()
    check_factory = sim_acceptance(bot, True, 20)["final_acceptance"]
    spec = FinalPlannerSpec.new(bot, 30, options, args.speed, check_factory)
    tasks = []
    for name in args.gaits.split(","):
        x = space.encode(make_schedule(bot, name))
        if x is None:
            raise SystemExit(f"--gaits: {name} does not fit {bot.name}'s symmetric encoding")
        tasks.append(FinalTask(spec, space.decode(x)))
    searched = [LocalResult(space.encode(t.schedule), 0.0, True) for t in tasks]  # type: ignore[arg-type]

    def serial() -> tuple[float, float, str]:
        t0, c0 = time.perf_counter(), time.process_time()
        final = GaitPlanner(bot, 30, options)
        check = check_factory()
        with SerialExecutor().ordered(
                lambda t: evaluate_final(final, check, t.schedule, args.speed), tasks) as out:
            choice = choose_final(tasks, searched, out)
        return (time.perf_counter() - t0, time.process_time() - c0,
                f"{len(choice.read)} read, winner cost {choice.plan.cost:.6g} ok {choice.accepted}")

    def parallel() -> tuple[float, float, str]:
        ex = ProcessExecutor(None, workers=2)
        ex.map(prepare_final, [spec, spec, spec, spec])  # both workers, most likely: built
        t0, c0 = time.perf_counter(), time.process_time()
        with ex, ex.ordered(worker_final_solve, tasks) as out:
            GaitPlanner(bot, 30, options)  # this process's final planner, overlapped
            choice = choose_final(tasks, searched, out)
            cpu = sum(o.solve_cpu_s + o.check_cpu_s + o.build_cpu_s for o in choice.read)
        wall = time.perf_counter() - t0
        return (wall, time.process_time() - c0 + cpu,
                f"{len(choice.read)} read, winner cost {choice.plan.cost:.6g} ok {choice.accepted}"
                + ("" if all(o.build_cpu_s == 0 for o in choice.read) else ", a worker built"))

    print(f"final_phase_bench: {bot.name} {args.speed} m/s, tasks {args.gaits}; "
          f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.2f}")
    walls: dict[str, list[float]] = {"serial": [], "process": []}
    for _ in range(args.repeats):
        for name, fn in (("serial", serial), ("process", parallel)):
            wall, cpu, what = fn()
            walls[name].append(wall)
            print(f"  {name:8s} wall {wall:6.2f} s, CPU read (this process + outcomes) "
                  f"{cpu:6.2f} s; {what}; load {os.getloadavg()[0]:.2f}", flush=True)
    med = {k: sorted(v)[len(v) // 2] for k, v in walls.items()}
    print(f"  median wall: serial {med['serial']:.2f} s, process {med['process']:.2f} s, ratio "
          f"{med['process'] / med['serial']:.2f}; "
          f"{time.strftime('%H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

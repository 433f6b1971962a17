"""The README's search command, run as the command line runs it, its time split into parts.

    python benchmarks/readme_split.py [-- PLAN ARGUMENTS]
    # default: plan quad12 --speed 0.25 --search -o /tmp/readme_split/quad12.json

Runs `gaitsmith.cli.main` in this process with the given `gaitsmith` arguments (default: issue
#16's `gaitsmith plan quad12 --speed 0.25 --search`, MuJoCo acceptance on, process executor),
keeps the `GaitSearchResult` the command computed (by wrapping `search_gait`, which the command
imports when it runs), and prints where the command's wall time and CPU time went:

- wall: start-up (imports, options, robot), the search's phases (`GaitSearchResult.phase_s`:
  seeding = pool start + worker builds + template solves, basin-CMA, final NLP build, final
  re-solves + their MuJoCo checks) and the writing after the search;
- CPU: this process (`time.process_time`) before, during and after the search, and the worker
  processes (`RUSAGE_CHILDREN`, read after the pool has shut down), split into the coarse solves
  (`TimingResult.cpu_s`), the samples' MuJoCo checks (`TimingResult.accept_cpu_s`) and the rest
  (interpreter start, imports, NLP builds: the workers' total minus those two);
- the four parts of issue #16's question: build, coarse solves, fine (30-knot) solves, MuJoCo —
  CPU seconds, from the CPU each final re-solve and check reports (`final_outcomes`), in this
  process or, with the final phase on the workers (`final_on_workers`, the process pool's
  default since session 32), in a worker; there the final planner's build overlaps the final
  phase (its wall time is inside the final phase's) and the workers' CPU of speculative re-solves
  nobody read, and of their final planners' builds, is in the workers' "build" part.

The command's output is printed as usual; the split follows, with the load average before and
after. Measured in docs/results/planner_speed_search.md (Session 29).
"""

from __future__ import annotations

import os
import resource
import sys
import time

import numpy as np

T_START = time.perf_counter()
C_START = time.process_time()
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")

DEFAULT_ARGS = ["plan", "quad12", "--speed", "0.25", "--search", "-o",
                "/tmp/readme_split/quad12.json"]


def _children_cpu_s() -> float:
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def _first_batch(res: object, schedule: object) -> str:
    """"seeds", "gen K" or "-": the first batch of the search whose sample decodes to
    `schedule` (templates: the seed batch; a fallback template's own schedule: "-")."""
    import planner.search.gait_search as gs

    assert isinstance(res, gs.GaitSearchResult)
    space = gs.TimingSpace.for_robot(res.robot, res.symmetric)
    n_seeds = len(res.template_costs)
    per_gen = max(1, (len(res.samples) - n_seeds) // max(1, res.cma.n_generations))
    lo, hi = space.bounds()
    for i, (x, _) in enumerate(res.samples):
        if gs.identical_schedules(space.decode(np.clip(x, lo, hi)), schedule):  # type: ignore[arg-type]
            return "seeds" if i < n_seeds else f"gen {(i - n_seeds) // per_gen}"
    return "-"


def main(argv: list[str]) -> int:
    args = argv or DEFAULT_ARGS
    load0 = os.getloadavg()
    utc0 = time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime())
    import planner.search.gait_search as gs
    from gaitsmith import cli

    captured: dict[str, object] = {}
    inner = gs.search_gait

    def recording_search_gait(*a: object, **kw: object) -> gs.GaitSearchResult:
        captured["t0"], captured["c0"] = time.perf_counter(), time.process_time()
        captured["w0"] = _children_cpu_s()
        result = inner(*a, **kw)  # type: ignore[arg-type]
        captured["t1"], captured["c1"] = time.perf_counter(), time.process_time()
        captured["epoch1"] = time.time()
        captured["w1"] = _children_cpu_s()
        captured["result"] = result
        return result

    gs.search_gait = recording_search_gait  # type: ignore[assignment]
    try:
        code = cli.main(args)
    finally:
        gs.search_gait = inner  # type: ignore[assignment]
    t_end, c_end, w_end = time.perf_counter(), time.process_time(), _children_cpu_s()
    if "result" not in captured:
        print(f"readme_split: the command ran no search (exit code {code}); nothing to split",
              file=sys.stderr)
        return 2
    res = captured["result"]
    assert isinstance(res, gs.GaitSearchResult)
    t0, t1 = float(captured["t0"]), float(captured["t1"])  # type: ignore[arg-type]
    c0 = float(captured["c0"])  # type: ignore[arg-type]
    c1 = float(captured["c1"])  # type: ignore[arg-type]
    w0, w1 = float(captured["w0"]), float(captured["w1"])  # type: ignore[arg-type]
    ph = res.phase_s
    samples = [r for _, r in res.samples]
    coarse_cpu = sum(float(getattr(r, "cpu_s", 0.0)) for r in samples)
    accept_cpu = sum(float(getattr(r, "accept_cpu_s", 0.0)) for r in samples)
    iterations = sum(max(r.n_fevals - 1, 0) for r in samples)
    workers_cpu = w1 - w0
    wall = t_end - T_START
    cpu = (c_end - C_START) + (w_end - 0.0)
    pc = res.phase_cpu_s
    rows = [
        ("start-up: imports, options, robot (this process)", t0 - T_START, c0 - C_START),
        ("seeding: pool start, worker builds, template solves", ph["seed"], pc["seed"]),
        ("basin-CMA generations", ph["cma"], pc["cma"]),
        ("final NLP build (this process)" + (", overlapped" if res.final_on_workers else ""),
         ph["final_build"], pc["final_build"]),
        ("final re-solves + MuJoCo checks " + ("(workers; wall incl. the build)"
                                              if res.final_on_workers else "(this process)"),
         ph["final"], pc["final"]),
        ("search, worker processes' CPU", None, workers_cpu),
        ("after the search: gait file, search log (this process)", t_end - t1, c_end - c1),
    ]
    print(f"\nreadme_split: gaitsmith {' '.join(args)}")
    print(f"  {utc0} UTC, load average {load0[0]:.2f} at the start, "
          f"{os.getloadavg()[0]:.2f} at the end; {len(samples)} coarse solves, {iterations} "
          f"IPOPT iterations; winner {res.label}, search cost {res.search_cost:.6g}, final "
          f"cost {res.best.cost:.6g}, MuJoCo "
          + {True: "pass", False: "FAIL", None: "not checked"}[res.accepted])
    print(f"  {'part':62s} {'wall s':>8s} {'CPU s':>8s}")
    for name, w, c in rows:
        print(f"  {name:62s} {'' if w is None else f'{w:8.2f}':>8s} "
              f"{'' if c is None else f'{c:8.2f}':>8s}")
    print(f"  {'total (wall; CPU of this process and its workers)':62s} {wall:8.2f} {cpu:8.2f}")
    fine_cpu = sum(o.solve_cpu_s for o in res.final_outcomes)
    final_check_cpu = sum(o.check_cpu_s for o in res.final_outcomes)
    where = "workers" if res.final_on_workers else "this process"
    other_workers = workers_cpu - coarse_cpu - accept_cpu
    main_other = (c_end - C_START) - pc["final_build"]
    if res.final_on_workers:
        other_workers -= fine_cpu + final_check_cpu
    else:
        main_other -= fine_cpu + final_check_cpu
    parts = [
        ("build: workers' start, imports, NLP builds (+ unread final solves)", other_workers),
        ("build: final NLP (this process)", pc["final_build"]),
        ("coarse solves (workers)", coarse_cpu),
        (f"fine solves ({where})", fine_cpu),
        ("MuJoCo: samples' checks (workers)", accept_cpu),
        (f"MuJoCo: final checks ({where})", final_check_cpu),
        ("the rest of this process (start-up, writing, bookkeeping)", main_other),
    ]
    print(f"  CPU by issue #16's parts (of {cpu:.2f} s):")
    for name, v in parts:
        print(f"    {name:60s} {v:8.2f}  {v / cpu:6.1%}")
    final_start = float(captured["epoch1"]) - ph["final"]  # type: ignore[arg-type]
    print("  final re-solves at full resolution, in the order tried (the batch whose sample "
          "first had the timing: when it was known; [pid: start-end s into the final phase]):")
    for o in res.final_outcomes:
        plan = o.plan
        print(f"    [{_first_batch(res, plan.schedule)}]", end="")
        verdict = {True: "MuJoCo pass", False: "MuJoCo FAIL", None: "not checked"}[o.ok]
        print(f"    {gs.label_gait(plan.schedule, res.robot):16s} cost {plan.cost:.6g} "
              f"({plan.iterations} it, {plan.status}) {verdict}; CPU solve "
              f"{o.solve_cpu_s:.2f} s, check {o.check_cpu_s:.2f} s"
              + (f", final planner build {o.build_cpu_s:.2f} s" if o.build_cpu_s else "")
              + f" [{o.pid}: {o.started_at_s - final_start:.1f}-{o.ended_at_s - final_start:.1f}]")
    return code


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))

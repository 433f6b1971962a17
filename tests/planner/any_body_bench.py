"""Cold solves of every template on the factory robots (5-leg star, 0.23 kg quadruped).

Two steps, so the same schedules can be solved by another checkout of the planner (e.g. main,
which has no azimuth templates for 5 legs)::

    PYTHONPATH=. python -m tests.planner.any_body_bench write /tmp/bots /tmp/scheds.json
    PYTHONPATH=. python -m tests.planner.any_body_bench solve /tmp/scheds.json 16 \
        [nondimensional=true,swing_clearance_m=0.025,body_clearance_m=0.03]
    PYTHONPATH=/path/to/main python tests/planner/any_body_bench.py solve /tmp/scheds.json 16

`write` builds the robots into a folder and stores each template's schedule and the default
(Froude) speed; `solve` runs them at N knots with the given `PlannerOptions` fields (omitted:
the checkout's defaults), and prints iterations, status and time per template.
The `solve` step imports only `robots` and `planner.nlp.spacetime`/`planner.nlp.config`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any


def write(folder: str, out: str) -> None:
    import robots
    from planner.nlp.config import default_speed_m_s
    from planner.templates import make_schedule, templates_for
    from tests.planner.robot_factory import small_quadruped, star_robot

    base = Path(folder)
    data: dict[str, Any] = {}
    for d in (small_quadruped(base / "mini4"), star_robot(base / "star5", 5)):
        r = robots.load(d)
        data[str(d)] = {
            "speed": round(default_speed_m_s(r.leg_length_m), 3),
            "schedules": {
                g: [s.period_s, list(s.touchdown_phase), list(s.duty_factor)]
                for g in templates_for(r) if g != "stand" for s in [make_schedule(r, g)]
            },
        }
    Path(out).write_text(json.dumps(data, indent=1))


def solve(path: str, n_knots: int, settings: str | None) -> None:
    """`settings`: PlannerOptions fields as ``name=value,…`` (numbers or true/false)."""
    import robots
    from planner.nlp.config import PlannerOptions
    from planner.nlp.spacetime import GaitPlanner

    kw: dict[str, Any] = {}
    for item in (settings or "").split(","):
        if item:
            key, value = item.split("=")
            kw[key] = value == "true" if value in ("true", "false") else float(value)
    for d, spec in json.loads(Path(path).read_text()).items():
        r = robots.load(d)
        speed = spec["speed"]
        p = GaitPlanner(r, n_knots=n_knots, options=PlannerOptions(**kw))
        print(f"{r.name} ({r.mass_kg:.3f} kg, leg {r.leg_length_m:.3f} m) N={n_knots} "
              f"v={speed} m/s options={kw or 'default'} build {p.build_time_s:.1f} s", flush=True)
        iters = feasible = 0
        secs = 0.0
        for g, (period, ph, du) in spec["schedules"].items():
            s = robots.ContactSchedule(period, r.foot_names, tuple(ph), tuple(du))
            res = p.solve(s, speed, warm_start=False)
            iters += res.iterations
            secs += res.solve_time_s
            feasible += res.feasible
            print(f"  {g:18s} feasible={res.feasible!s:5s} {res.status:28s} "
                  f"it={res.iterations:4d} t={res.solve_time_s:6.2f}s "
                  f"viol={res.max_violation:.1e} cost={res.cost:.4g}", flush=True)
        print(f"  TOTAL {feasible}/{len(spec['schedules'])} feasible, {iters} iterations, "
              f"{secs:.1f} s", flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "write":
        write(sys.argv[2], sys.argv[3])
    else:
        solve(sys.argv[2], int(sys.argv[3]), sys.argv[4] if len(sys.argv) > 4 else None)

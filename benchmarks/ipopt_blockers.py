"""Which slacks cut IPOPT's first primal steps on a cold solve (issue #16, session 39).

    python benchmarks/ipopt_blockers.py hex18 tripod 0.15 --iterations 3

Solves the template cold with the default options (the half-cycle solve where it fits) for
``--iterations`` iterations, with IPOPT's vector output (``file_print_level`` 8) written to a
temporary file, and reads back every iteration's slacks: the variables' distances to their
bounds (``curr_slack_x_L/U``) and the inequality rows' slack distances (``curr_slack_s_L/U``),
mapped to variable kinds and row groups. For each step k → k+1 it prints the slacks that shrank
most (new/old; the fraction-to-the-boundary rule stops a step where one falls to 1 − τ of
its value, τ = max(0.99, 1 − μ): a ratio ≈ 0.01 or below marks the blocking slack) and, at
iteration k, how many slacks of each kind are below 1e-5, and the barrier parameter IPOPT's
μ oracle chose. Only the half-cycle NLP is mapped (a schedule it does not fit is refused).
"""

from __future__ import annotations

import argparse
import os
import re
import tempfile
from collections import Counter
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import robots
from planner.nlp import spacetime as st
from planner.nlp.config import PlannerOptions
from planner.nlp.variables import initial_guess, parameter_vector
from planner.templates import make_schedule

_VECTOR = re.compile(r'^DenseVector "([^"]+)" with (\d+) elements')
_ITERATION = re.compile(r"\*\*\* Beginning Iteration (\d+)")
_MU = re.compile(r"Barrier parameter mu computed by oracle is (\S+)")
#: row groups of one row per (knot, foot), repeated (`planner.nlp.constraints.group_labels`)
PER_FOOT = ("stance height", "stance no-slip", "swing clearance", "swing force", "friction")
SLACKS = ("curr_slack_x_L", "curr_slack_x_U", "curr_slack_s_L", "curr_slack_s_U")


def read_vectors(path: Path) -> tuple[dict[tuple[int, str], np.ndarray], list[float]]:
    """IPOPT's printed vectors by (iteration, name), and the μ its oracle chose per iteration."""
    vectors: dict[tuple[int, str], list[float]] = {}
    mus: list[float] = []
    key: tuple[int, str] | None = None
    iteration = -1
    with path.open() as fh:
        for line in fh:
            if m := _ITERATION.match(line):
                iteration, key = int(m.group(1)), None
            elif m := _VECTOR.match(line):
                key = (iteration, m.group(1))
                vectors[key] = []
            elif m := _MU.match(line):
                mus.append(float(m.group(1)))
            elif key is not None and line.startswith(key[1]) and "]=" in line:
                vectors[key].append(float(line.split("=")[1]))
            elif key is not None and line.strip():
                key = None
    return {k: np.asarray(v) for k, v in vectors.items()}, mus


def slack_labels(planner: st.GaitPlanner, schedule: robots.ContactSchedule,
                 speed: float) -> dict[str, list[str]]:
    """Labels of IPOPT's four slack vectors for the half-cycle NLP of `schedule`: variable kinds
    (joints as J, feet as foot) and row groups, in IPOPT's order (bounded entries only; the
    inequality rows d are the kept rows with lb < ub)."""
    p = parameter_vector(schedule, planner.n_knots, speed, planner.swing_clearance_m, 0.0, 0.0)
    b = planner._solve_bounds(schedule)
    half = planner._build_half_cycle(p, initial_guess(planner.layout, planner.model, schedule))
    if half is None:
        raise SystemExit("this body has no half-cycle NLP")
    m, rows = half.mirror, half.rows

    def kind(label: str) -> str:
        out = re.sub(r"foot \d+ ", "foot ", label.split("@")[0])
        for joint in planner.robot.joint_names:
            out = out.replace(joint, "J")
        return out

    x_kind = [kind(lbl) for lbl in np.asarray(planner._x_labels, dtype=object)[m.half]]
    lbx, ubx = b.lbx[m.half], b.ubx[m.half]
    group = np.empty(b.lbg.size, dtype=object)
    contact = schedule.contact_matrix(planner.n_knots).astype(bool).ravel()  # knot-major
    for name, sl in planner._slices:
        group[sl] = name
        if name in PER_FOOT:  # rows per (knot, foot), the group repeated: tag stance / swing
            index = np.arange(sl.stop - sl.start) % contact.size
            group[sl] = [f"{name} ({'stance' if contact[i] else 'swing'})" for i in index]
    lbg, ubg = rows.weight * b.lbg[rows.keep], rows.weight * b.ubg[rows.keep]
    ineq = lbg < ubg
    d_group, d_lb, d_ub = group[rows.keep][ineq], lbg[ineq], ubg[ineq]
    return {
        "curr_slack_x_L": [k for k, v in zip(x_kind, lbx, strict=True) if np.isfinite(v)],
        "curr_slack_x_U": [k for k, v in zip(x_kind, ubx, strict=True) if np.isfinite(v)],
        "curr_slack_s_L": list(d_group[np.isfinite(d_lb)]),
        "curr_slack_s_U": list(d_group[np.isfinite(d_ub)]),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("robot", help="robot name or folder")
    ap.add_argument("gait")
    ap.add_argument("speed", type=float)
    ap.add_argument("--iterations", type=int, default=3)
    ap.add_argument("--knots", type=int, default=30)
    ap.add_argument("--show", type=int, default=4, help="smallest ratios shown per step")
    a = ap.parse_args()
    robot = robots.load(a.robot)
    schedule = make_schedule(robot, a.gait)
    with tempfile.TemporaryDirectory(prefix="ipopt_blockers_") as tmp:
        log = Path(tmp) / "ipopt.out"
        original = st.ipopt_options

        def logged(options: PlannerOptions, warm: bool) -> dict[str, object]:
            return {**original(options, warm), "output_file": str(log), "file_print_level": 8,
                    "max_iter": a.iterations}

        st.ipopt_options = logged  # type: ignore[assignment]
        planner = st.GaitPlanner(robot, a.knots, PlannerOptions())
        res = planner.solve(schedule, a.speed, warm_start=False)
        st.ipopt_options = original
        if not res.stats.get("half_cycle"):
            raise SystemExit(f"{a.gait} was not solved on the half-cycle NLP")
        vectors, mus = read_vectors(log)
    labels = slack_labels(planner, schedule, a.speed)
    print(f"{robot.name} {a.gait} {a.speed} m/s, N={a.knots}, cold, half-cycle NLP; μ chosen "
          "by the oracle per iteration: " + ", ".join(f"{mu:.1e}" for mu in mus))
    for k in range(a.iterations):
        ratios: list[tuple[float, str, str, float, float]] = []
        small: Counter[tuple[str, str]] = Counter()
        for name in SLACKS:
            old, new = vectors.get((k, name)), vectors.get((k + 1, name))
            if old is None or new is None or old.size == 0:
                continue
            if old.size != len(labels[name]):
                raise SystemExit(f"{name}: {old.size} entries, {len(labels[name])} labels")
            for i in np.argsort(new / old)[: a.show]:
                ratios.append((float(new[i] / old[i]), name, labels[name][i], old[i], new[i]))
            small.update((name, lbl) for lbl, v in zip(labels[name], old, strict=True) if v < 1e-5)
        ratios.sort()
        print(f"step {k} → {k + 1}: slacks that shrank most (new/old):")
        for r, name, lbl, old_v, new_v in ratios[: a.show]:
            print(f"    {r:.2e}  {name:15s} {lbl:30s} {old_v:.2e} → {new_v:.2e}")
        print(f"  slacks < 1e-5 at iteration {k}: "
              + ", ".join(f"{lbl} ({name[-3:]}) {n}" for (name, lbl), n in sorted(small.items())))


if __name__ == "__main__":
    main()

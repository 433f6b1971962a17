"""Gait from speed: run the basin-CMA gait search over a range of speeds (W&P 2009 §6, Fig. 3).

For each speed the search picks the contact timing; the table records what came out — gait
label, duty factor, period, cost of transport — against speed and Froude number
Fr = v²/(g·L) (L: the robot's hip-to-foot leg length at stance), the dynamic-similarity measure
under which animals of different size switch gaits at similar values (Alexander; Murphy et al.
2008 use it to retarget gaits between bodies).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner
from planner.search.defaults import (
    DEFAULT_FINAL_TEMPLATES,
    DEFAULT_GENERATIONS,
    FINAL_HALF_CYCLE,
    SEARCH_HALF_CYCLE,
)
from planner.search.gait_search import (
    DEFAULT_SEARCH_KNOTS,
    DEFAULT_TIPPING_WEIGHT,
    FINAL_CANDIDATES,
    GaitAcceptance,
    GaitSearchResult,
    SearchLogRow,
    final_options,
    search_gait,
)
from planner.templates import gait_family
from robots import ContactSchedule, Robot
from robots.files import atomic_path, atomic_write_text


@dataclass(frozen=True)
class SweepRow:
    speed_m_s: float
    froude: float
    gait_label: str
    best_template: str
    period_s: float
    mean_duty_factor: float
    cost: float
    best_template_cost: float
    cost_of_transport: float
    feasible: bool
    local_solves: int
    elapsed_s: float
    family: str = ""
    search_cost: float = math.nan  # coarse-NLP cost incl. the support term (vs the template's)
    search_feasible: bool = True  # False: the winner failed at the search resolution (fallback)
    tipping_amplification: float = math.nan
    sim_passed: bool | None = None  # MuJoCo verdict of the written gait (None: not simulated)
    sim_speed_m_s: float = math.nan
    #: planned share of the cycle with no foot on the ground (> 0: a run, W&P §6)
    flight_fraction: float = math.nan
    #: measured in MuJoCo over the steady cycles (`SimOutcome`): share of the steps with no foot
    #: touching the ground, and with every foot touching it
    sim_flight_fraction: float = math.nan
    sim_double_support_fraction: float = math.nan
    #: the IMU attitude feedback's gain the MuJoCo verdict was reached with (0: open loop)
    sim_attitude_gain: float = math.nan
    #: knots of the final NLP with no foot in stance, and its knot count (`airborne_knots`)
    airborne_knots: int = -1
    n_knots: int = 0

    @property
    def sim_gait(self) -> str:
        """What the gait did in MuJoCo (`measured_label`), '-' when not simulated."""
        return measured_label(self.sim_flight_fraction, self.sim_double_support_fraction)


def flight_fraction(schedule: ContactSchedule, samples: int = 1000) -> float:
    """Share of the cycle in which no foot is in stance (sampled at `samples` phases)."""
    in_stance = schedule.contact_matrix(samples)  # samples × feet
    return float(np.mean(~np.any(in_stance, axis=1)))


def airborne_knots(schedule: ContactSchedule, n_knots: int) -> int:
    """Knots at which no foot is in stance: the flight the NLP actually plans. The planner
    imposes contact at its N knots only (`planner.nlp.variables.parameter_vector`), so a short
    flight window between two knots exists in the schedule but not in the plan — the built-in
    biped's duty-0.42 run at N = 12 (16 % flight in the schedule) has none, and MuJoCo measured
    0.4 % flight for it."""
    return int(np.sum(~np.any(schedule.contact_matrix(n_knots), axis=1)))


#: biped labels by flight: a two-legged gait with a planned flight phase is a run, one without
#: is a walk (the human definition, Alexander 1989), whatever template its duty factor is nearest
BIPED_WALK, BIPED_RUN = "biped_walk", "biped_run"


def flight_label(template_label: str, schedule: ContactSchedule) -> str:
    """`template_label` (`planner.templates.label_gait`), except for two feet: `biped_run` when
    the schedule has a flight phase (`flight_fraction` > 0), else `biped_walk`. Nearest-template
    labels call a duty-0.48 gait (4 % flight) a walk because 0.48 is nearer the walk's 0.60."""
    if len(schedule.feet) != 2 or template_label not in (BIPED_WALK, BIPED_RUN):
        return template_label
    return BIPED_RUN if flight_fraction(schedule) > 0.0 else BIPED_WALK


@dataclass(frozen=True)
class SimOutcome:
    """A search result's gait in simulation: the verdict, the achieved speed and the measured
    shares of the steady steps in flight (no foot touching) and in full support (every foot)."""

    passed: bool
    speed_m_s: float
    flight_fraction: float = math.nan
    double_support_fraction: float = math.nan
    attitude_gain: float = 0.0  # the IMU feedback's gain it was judged with (0: open loop)


#: the `SimOutcome` of a search result's gait; supplied by the caller so that the planner
#: package does not import the simulator.
Validator = Callable[[GaitSearchResult], SimOutcome]

#: timings re-solved at full resolution per speed for the final MuJoCo check (the first that
#: passes wins, `search_gait`): twice the single search's, because the sweep's point is a gait
#: that passes at every speed, and a run's verdict flips between neighbouring timings (the
#: 0.5 m/s winner of `--speeds 0.1,0.5 --knots 12 --generations 3` failed at 97 % of stall
#: and −5.6° of heading with the 4 candidates of a single search)
SWEEP_FINAL_CANDIDATES = 2 * FINAL_CANDIDATES


def measured_label(flight: float, double_support: float) -> str:
    """A gait by the contacts MuJoCo recorded (the human definition, Alexander 1989): "run" if
    some steady steps had no foot down, "walk" if some had every foot down and none flew,
    "grounded" if neither (single support throughout), "-" if not measured."""
    if math.isnan(flight) or math.isnan(double_support):
        return "-"
    if flight > 0.0:
        return "run"
    return "walk" if double_support > 0.0 else "grounded"


def row_from(result: GaitSearchResult, validator: Validator | None = None) -> SweepRow:
    best = result.best
    label = flight_label(result.label, best.schedule)
    outcome = validator(result) if validator is not None and best.feasible else None
    return SweepRow(
        speed_m_s=result.speed_m_s, froude=result.froude,
        gait_label=label,
        best_template=result.best_template, period_s=best.schedule.period_s,
        mean_duty_factor=float(np.mean(best.schedule.duty_factor)), cost=best.cost,
        best_template_cost=result.best_template_cost,
        cost_of_transport=result.cost_of_transport, feasible=best.feasible,
        local_solves=result.cma.n_local_solves, elapsed_s=result.elapsed_s,
        family=gait_family(label), search_cost=result.search_cost,
        search_feasible=result.search_feasible,
        tipping_amplification=result.tipping_amplification,
        sim_passed=None if outcome is None else outcome.passed,
        sim_speed_m_s=math.nan if outcome is None else outcome.speed_m_s,
        flight_fraction=flight_fraction(best.schedule),
        airborne_knots=airborne_knots(best.schedule, result.planner.n_knots),
        n_knots=result.planner.n_knots,
        sim_flight_fraction=math.nan if outcome is None else outcome.flight_fraction,
        sim_double_support_fraction=(math.nan if outcome is None
                                     else outcome.double_support_fraction),
        sim_attitude_gain=math.nan if outcome is None else outcome.attitude_gain,
    )


def sweep_speeds(
    robot: Robot,
    speeds_m_s: Sequence[float],
    *,
    n_knots: int = 30,
    options: PlannerOptions | None = None,
    symmetric: bool = True,
    max_generations: int = DEFAULT_GENERATIONS,
    popsize: int | None = None,
    seed: int = 0,
    executor: str = "serial",
    workers: int | None = None,
    search_knots: int = DEFAULT_SEARCH_KNOTS,
    tipping_weight: float = DEFAULT_TIPPING_WEIGHT,
    acceptance: Callable[[], GaitAcceptance] | None = None,
    final_acceptance: Callable[[], GaitAcceptance] | None = None,
    validator: Validator | None = None,
    on_row: Callable[[SweepRow], None] | None = None,
    progress: Callable[[SearchLogRow], None] | None = None,
    final_candidates: int = SWEEP_FINAL_CANDIDATES,
    final_half_cycle: bool = FINAL_HALF_CYCLE,
    search_half_cycle: bool = SEARCH_HALF_CYCLE,
    final_templates: str = DEFAULT_FINAL_TEMPLATES,
) -> tuple[SweepRow, ...]:
    """Search the best gait at each speed; one final planner (one NLP build) serves every speed.
    `final_candidates` timings per speed are re-solved for `final_acceptance`, cheapest first,
    on the first half of a symmetric timing's knots if `final_half_cycle`
    (`search_gait(final_half_cycle=)`); `search_half_cycle` and `final_templates` are
    `search_gait`'s."""
    options = options or PlannerOptions()
    planner = GaitPlanner(robot, n_knots, final_options(options, final_half_cycle))
    rows = []
    for speed in speeds_m_s:
        result = search_gait(robot, float(speed), n_knots=n_knots, options=options,
                             symmetric=symmetric, max_generations=max_generations,
                             popsize=popsize, seed=seed, executor=executor, workers=workers,
                             search_knots=search_knots, tipping_weight=tipping_weight,
                             acceptance=acceptance, final_acceptance=final_acceptance,
                             planner=planner, progress=progress,
                             final_candidates=final_candidates,
                             final_half_cycle=final_half_cycle,
                             search_half_cycle=search_half_cycle,
                             final_templates=final_templates)
        row = row_from(result, validator)
        rows.append(row)
        if on_row is not None:
            on_row(row)
    return tuple(rows)


_FIELDS = list(SweepRow.__dataclass_fields__)


def to_csv(rows: Sequence[SweepRow]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(_FIELDS)
    for r in rows:
        writer.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in
                         (getattr(r, f) for f in _FIELDS)])
    return buf.getvalue()


def to_markdown(rows: Sequence[SweepRow]) -> str:
    head = ("| speed [m/s] | Froude | gait | duty | flight | period [s] | search cost | best "
            "template (cost) | final cost | tipping | CoT | sim | MuJoCo: flight / double "
            "support | solves |")
    lines = [head, "|" + "---|" * 14]
    for r in rows:
        sim = "-" if r.sim_passed is None else \
            f"{'pass' if r.sim_passed else 'FAIL'} {r.sim_speed_m_s:.3f} m/s" + (
                f", closed loop G {r.sim_attitude_gain:g}" if r.sim_attitude_gain > 0 else "")
        measured = "-" if r.sim_gait == "-" else (
            f"{r.sim_gait}: {100 * r.sim_flight_fraction:.1f} % / "
            f"{100 * r.sim_double_support_fraction:.1f} %")
        knots = f" ({r.airborne_knots}/{r.n_knots} knots)" if r.n_knots else ""
        lines.append(
            f"| {r.speed_m_s:.3f} | {r.froude:.3f} | {r.gait_label} | {r.mean_duty_factor:.2f} | "
            f"{r.flight_fraction:.2f}{knots} | {r.period_s:.3f} | "
            f"{r.search_cost:.4g}{'' if r.search_feasible else ' †'} | "
            f"{r.best_template} "
            f"({r.best_template_cost:.4g}) | {r.cost:.4g} | {r.tipping_amplification:.3g} | "
            f"{r.cost_of_transport:.3f} | {sim} | {measured} | {r.local_solves} |"
        )
    if not all(r.search_feasible for r in rows):
        lines.append("\n† no sample was feasible and accepted at the search resolution; the row "
                     "shows the cheapest plan that solved, re-solved (and judged) at full "
                     "resolution.")
    return "\n".join(lines) + "\n"


#: Froude number of the human walk–run transition (Alexander 1989; Thorstensson & Roberthson
#: 1987): the plot names it, at the speed it would be on this robot's legs
HUMAN_WALK_RUN_FROUDE = 0.5


def plot(rows: Sequence[SweepRow], path: str | Path, title: str) -> None:
    """Duty factor, cost of transport and gait label vs speed and Froude number (PNG); with
    simulated rows, a third panel of the planned flight share beside MuJoCo's measured flight
    and double-support shares."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    speeds = np.array([r.speed_m_s for r in rows])
    froude = np.array([r.froude for r in rows])
    measured = any(not math.isnan(r.sim_flight_fraction) for r in rows)
    fig, axes = plt.subplots(3 if measured else 2, 1, figsize=(7, 8.5 if measured else 6),
                             sharex=True)
    labels = sorted({r.gait_label for r in rows})
    colours = {lab: plt.get_cmap("tab10")(i) for i, lab in enumerate(labels)}
    for ax, key, ylabel in ((axes[0], "mean_duty_factor", "duty factor"),
                            (axes[1], "cost_of_transport", "cost of transport")):
        values = np.array([getattr(r, key) for r in rows])
        ax.plot(speeds, values, "-", color="0.6", zorder=1)
        for r, v in zip(rows, values, strict=True):
            # a cross: the gait fell or missed a criterion in MuJoCo
            ax.scatter([r.speed_m_s], [v], color=colours[r.gait_label], s=60, zorder=2,
                       label=r.gait_label, marker="X" if r.sim_passed is False else "o")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].axhline(0.5, color="0.3", lw=0.8, ls="--")
    handles, names = axes[0].get_legend_handles_labels()
    unique = dict(zip(names, handles, strict=True))
    axes[0].legend(unique.values(), unique.keys(), title="gait (planned)")
    if measured:
        ax = axes[2]
        for key, name, style in (("flight_fraction", "flight, planned", "o--"),
                                 ("sim_flight_fraction", "flight, MuJoCo", "s-"),
                                 ("sim_double_support_fraction", "double support, MuJoCo", "^-")):
            ax.plot(speeds, [100 * getattr(r, key) for r in rows], style, label=name)
        ax.set_ylabel("share of the cycle [%]")
        ax.legend()
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("speed [m/s]")
    k = float(np.max(froude / np.maximum(speeds, 1e-9) ** 2))  # Fr = k·v², k = 1/(g·L)
    top = axes[0].secondary_xaxis(
        "top", functions=(lambda v: k * np.square(v), lambda f: np.sqrt(np.abs(f) / k)))
    human_m_s = math.sqrt(HUMAN_WALK_RUN_FROUDE / k) if k > 0 else math.nan
    top.set_xlabel(f"Froude number v²/(g·L)  (human walk–run transition ≈ "
                   f"{HUMAN_WALK_RUN_FROUDE:g}: {human_m_s:.2f} m/s on these legs)")
    fig.suptitle(title)
    fig.tight_layout()
    try:
        with atomic_path(path) as tmp:  # temp + rename; a failed write is an OutputWriteError
            fig.savefig(tmp, dpi=110)
    finally:
        plt.close(fig)


def write_sweep(rows: Sequence[SweepRow], out_dir: str | Path, robot: Robot) -> dict[str, Path]:
    """sweep.csv, sweep.md and sweep.png in `out_dir` (each written atomically)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"csv": out / "sweep.csv", "md": out / "sweep.md", "png": out / "sweep.png"}
    atomic_write_text(paths["csv"], to_csv(rows))
    atomic_write_text(paths["md"], f"# {robot.name}: best gait vs speed\n\n" + to_markdown(rows))
    plot(rows, paths["png"], f"{robot.name}: gait from speed (basin-CMA; × = fails in MuJoCo)")
    return paths


"""What `gaitsmith design` writes beside the robot folder's files: a markdown report, the
trade-off figure (design cost against leg length, one marker per servo choice) and every sample
as CSV — and the atomic folder they are all written into."""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from planner.design.body import BodyDesign, DesignError, DesignSpace, describe
from planner.design.search import DesignResult, DesignSample
from robots import Robot
from robots.files import atomic_write_text

REPORT_MD = "design_report.md"
TRADEOFF_PNG = "design_tradeoff.png"
SAMPLES_CSV = "design_samples.csv"


@contextmanager
def atomic_folder(folder: Path) -> Iterator[Path]:
    """Yield a fresh temp folder beside `folder`; when the block succeeds it becomes `folder`
    (one rename), else it is removed: nothing partial is ever left at `folder`. `folder` must
    not exist or be empty."""
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise DesignError(f"{folder}: exists and is not an empty folder; choose a new -o folder")
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", suffix=".tmp", dir=folder.parent))
    try:
        yield tmp
        if folder.exists():
            folder.rmdir()
        os.replace(tmp, folder)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


@dataclass(frozen=True)
class Verdict:
    """A MuJoCo validation as the report shows it (None: not simulated)."""

    passed: bool | None
    reasons: tuple[str, ...] = ()

    def text(self) -> str:
        if self.passed is None:
            return "; ".join(self.reasons) if self.reasons else "not simulated (pass --simulate)"
        return ("PASS" if self.passed else "FAIL") + (
            f" ({'; '.join(self.reasons)})" if self.reasons else "")


def _servo_summary(space: DesignSpace, design: BodyDesign) -> str:
    return ", ".join(f"{g.name}:{n}" for g, n in zip(space.servo_groups, design.servos,
                                                       strict=True))


def samples_csv(result: DesignResult) -> str:
    """One row per sample (the original first)."""
    space = result.space
    head = ["sample", *[f"scale_{g.name}" for g in space.link_groups],
            *[f"servo_{g.name}" for g in space.servo_groups], "leg_length_m", "mass_kg",
            "feasible", "design_cost", "planner_cost", "effort", "peak_torque_over_stall",
            "violation", "iterations", "solve_time_s", "binding"]
    rows = [",".join(head)]
    for i, s in enumerate((result.original, *result.samples)):
        cells: list[object] = ["original" if i == 0 else i, *[f"{v:.4f}" for v in s.design.scales],
                               *s.design.servos, f"{s.leg_length_m:.4f}", f"{s.mass_kg:.4f}",
                               s.feasible, f"{s.cost:.6g}", f"{s.planner_cost:.6g}",
                               f"{s.effort:.6g}", f"{s.peak_torque_ratio:.4g}",
                               f"{s.violation:.3g}", s.iterations, f"{s.solve_time_s:.2f}",
                               s.binding[0][0] if s.binding else ""]
        rows.append(",".join(str(c) for c in cells))
    return "\n".join(rows) + "\n"


def tradeoff_png(result: DesignResult, chosen: DesignSample | None, path: Path) -> None:
    """Design cost against leg length (relative to the original), one marker per servo choice;
    infeasible samples as grey crosses along the top."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    space, ref = result.space, result.original.leg_length_m
    fig, ax = plt.subplots(figsize=(8, 5))
    feasible = [s for s in result.samples if s.feasible and math.isfinite(s.cost)]
    by_servo: dict[str, list[DesignSample]] = {}
    for s in feasible:
        by_servo.setdefault(_servo_summary(space, s.design), []).append(s)
    markers = "osD^v<>phX*"
    for k, (label, group) in enumerate(sorted(by_servo.items())):
        group.sort(key=lambda s: s.leg_length_m)
        ax.plot([s.leg_length_m / ref for s in group], [s.cost for s in group],
                markers[k % len(markers)], ls="", alpha=0.8, label=label)
    costs = [s.cost for s in feasible] + ([result.original.cost] if result.original.feasible
                                          else [])
    top = max(costs) * 1.1 if costs else 1.0
    bad = [s for s in result.samples if not s.feasible and math.isfinite(s.leg_length_m)]
    if bad:
        ax.plot([s.leg_length_m / ref for s in bad], [top] * len(bad), "x", color="0.6",
                label="infeasible (plotted at the top)")
    if result.original.feasible:
        ax.plot([1.0], [result.original.cost], "*", ms=16, color="k", label="original")
    if chosen is not None:
        ax.plot([chosen.leg_length_m / ref], [chosen.cost], "o", ms=18, mfc="none", mew=2,
                color="crimson", label="chosen")
    ax.set_xlabel(f"leg length / {result.robot.name}'s ({ref:.3f} m)")
    ax.set_ylabel("design cost J = planner cost + w_m·m/m₀")
    ax.set_title(f"{result.robot.name} at {result.speed_m_s:g} m/s ({result.gait}, "
                 f"N={result.n_knots}): {len(result.samples)} bodies")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def why(result: DesignResult, chosen: DesignSample) -> list[str]:
    """Which links and servos changed and what each part of the cost did."""
    space, orig = result.space, result.original
    lines: list[str] = []
    for g, s in zip(space.link_groups, chosen.design.scales, strict=True):
        if abs(s - 1.0) >= 0.02:
            lines.append(f"{g.name}: {'longer' if s > 1 else 'shorter'} ×{s:.3f} "
                         f"({g.length_m:.3f} → {g.length_m * s:.3f} m)")
    for sg, n, o in zip(space.servo_groups, chosen.design.servos, orig.design.servos,
                        strict=True):
        if n != o:
            new, old = space.model(n), space.model(o)
            lines.append(f"{sg.name}: {o} → {n} (stall {old.stall_torque_nm:.3g} → "
                         f"{new.stall_torque_nm:.3g} N·m, {old.mass_kg * 1e3:.0f} → "
                         f"{new.mass_kg * 1e3:.0f} g each)")
    if not lines:
        lines.append("no link or servo changed by more than 2 %: the original body is (near) "
                     "the best the search found")
    if orig.feasible:
        lines.append(f"effort Σ(τ/τ_stall)² {orig.effort:.4g} → {chosen.effort:.4g}, other "
                     f"planner terms {orig.planner_cost - orig.effort:.4g} → "
                     f"{chosen.planner_cost - chosen.effort:.4g}, mass term "
                     f"{orig.cost - orig.planner_cost:.4g} → "
                     f"{chosen.cost - chosen.planner_cost:.4g}; peak |τ|/τ_stall "
                     f"{orig.peak_torque_ratio:.3f} → {chosen.peak_torque_ratio:.3f}")
    else:
        lines.append(f"the original body has no feasible gait at {result.speed_m_s:g} m/s "
                     f"({orig.message}); this one does (peak |τ|/τ_stall "
                     f"{chosen.peak_torque_ratio:.3f})")
    return lines


def _row(label: str, a: str, b: str) -> str:
    return f"| {label} | {a} | {b} |"


def report_md(result: DesignResult, chosen: DesignSample, body: Robot, command: str,
              verdicts: tuple[Verdict, Verdict], notes: Sequence[str] = ()) -> str:
    """The markdown report: the chosen body beside the original, why, the search, the figure."""
    space, orig, robot = result.space, result.original, result.robot
    lines = [f"# Body design: {robot.name} at {result.speed_m_s:g} m/s → {body.name}", "",
             f"`{command}`", "",
             f"Objective J = planner cost (W&P eqs 13-16, effort Σ(τ/τ_stall)²) + "
             f"{result.mass_weight:g}·m/m₀ (m₀ = {robot.mass_kg:.3f} kg), each body projected by "
             f"the spacetime solve of the `{result.gait}` template at {result.speed_m_s:g} m/s, "
             f"N = {result.n_knots}. {len(result.samples)} bodies in {len(result.history)} "
             f"generations, {result.elapsed_s:.0f} s.", "",
             "## The chosen body beside the original", "",
             f"| | {robot.name} | {body.name} |", "|---|---|---|",
             _row("leg length [m]", f"{orig.leg_length_m:.4f}", f"{chosen.leg_length_m:.4f}"),
             _row("mass [kg]", f"{orig.mass_kg:.4f}", f"{chosen.mass_kg:.4f}")]
    for lg, s in zip(space.link_groups, chosen.design.scales, strict=True):
        lines.append(_row(f"{lg.name} [m]", f"{lg.length_m:.4f}",
                          f"{lg.length_m * s:.4f} (×{s:.3f})"))
    for sg, o, n in zip(space.servo_groups, orig.design.servos, chosen.design.servos,
                        strict=True):
        mo, mn = space.model(o), space.model(n)
        lines.append(_row(f"servo {sg.name} ({len(sg.joints)} joints)",
                          f"{o} ({mo.stall_torque_nm:.3g} N·m, {mo.mass_kg * 1e3:.0f} g)",
                          f"{n} ({mn.stall_torque_nm:.3g} N·m, {mn.mass_kg * 1e3:.0f} g)"))

    def num(s: DesignSample, v: float) -> str:
        return f"{v:.5g}" if s.feasible else "infeasible"
    lines += [
        _row("planner cost", num(orig, orig.planner_cost), num(chosen, chosen.planner_cost)),
        _row("effort Σ(τ/τ_stall)²", num(orig, orig.effort), num(chosen, chosen.effort)),
        _row("design cost J", num(orig, orig.cost), num(chosen, chosen.cost)),
        _row("peak τ/τ_stall", num(orig, orig.peak_torque_ratio),
             num(chosen, chosen.peak_torque_ratio)),
        _row("MuJoCo", verdicts[0].text().replace("|", "\\|"),
             verdicts[1].text().replace("|", "\\|")),
        "", "## Why", "", *[f"- {line}" for line in why(result, chosen)],
        *[f"- {line}" for line in notes], "",
        "## Search", "", "| generation | samples | feasible | best J | best body | elapsed [s] |",
        "|---|---|---|---|---|---|"]
    for r in result.history:
        lines.append(f"| {r.generation} | {r.n_samples} | {r.n_feasible} | {r.best_cost:.5g} | "
                     f"{r.best} | {r.elapsed_s:.0f} |")
    limits = result.limits()
    if limits:
        lines += ["", "Most binding limit of the infeasible samples: " + ", ".join(
            f"{name} ({n})" for name, n in limits) + "."]
    lines += ["", "## Trade-off", "", f"![design cost against leg length]({TRADEOFF_PNG})", "",
              f"Every sample: `{SAMPLES_CSV}`. The folder is a robot folder: "
              f"`gaitsmith robots check {body.name}` (run in its parent folder) checks it stands; "
              "swapped servos need their `zero_offset_ticks` calibrated before hardware."]
    return "\n".join(lines) + "\n"


def write_report(folder: Path, result: DesignResult, chosen: DesignSample, body: Robot,
                 command: str, verdicts: tuple[Verdict, Verdict], notes: Sequence[str] = ()
                 ) -> None:
    """The report (`notes`: more lines for its "Why" list), the samples and the figure."""
    atomic_write_text(folder / REPORT_MD,
                      report_md(result, chosen, body, command, verdicts, notes))
    atomic_write_text(folder / SAMPLES_CSV, samples_csv(result))
    tradeoff_png(result, chosen, folder / TRADEOFF_PNG)


def design_note(result: DesignResult, chosen: DesignSample, command: str) -> str:
    """The header comment of the designed robot.toml."""
    return (f"written by `{command}`\n"
            f"body designed from {result.robot.name} for {result.speed_m_s:g} m/s "
            f"({result.gait}): {describe(result.space, chosen.design)}\n"
            "masses/inertias in robot.xml rescaled at constant density, servo masses from the "
            "catalogue (planner/design/body.py)\n")


__all__: Sequence[str] = ("REPORT_MD", "SAMPLES_CSV", "TRADEOFF_PNG", "Verdict", "atomic_folder",
                          "design_note", "report_md", "samples_csv", "tradeoff_png", "why",
                          "write_report")

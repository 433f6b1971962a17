"""`gaitsmith design ROBOT --speed V [--vary LINKS] [--servos MODEL,…] [--generations G]
[--workers N] [--ray] -o DIR [--simulate]`.

Designs the body for a gait (Wampler & Popović 2009 §3.6, `planner.design`): basin-CMA over the
leg-segment lengths (constant density, servo masses from the catalogue) and a servo model per
joint group, each body projected by the spacetime solve of the default template at V. The
original robot is solved at V in the same run. DIR becomes a robot folder (robot.xml +
robot.toml, servos replaced) with the best body's gait, the original's gait, a markdown report,
the trade-off figure and every sample as CSV — written to a temp folder and renamed at the end,
so nothing partial is left. `--simulate` validates both gaits in MuJoCo and stands the new body
(`planner` never imports `sim`: this command wires them).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import typer
from rich.table import Table

import robots
import robots.gait as gait_io
from gaitsmith.console import console
from gaitsmith.errors import OptionError
from gaitsmith.options import (
    check_cycles,
    check_friction,
    check_integer,
    check_knots,
    check_number,
    check_output_dir,
    check_speed,
)
from planner.design.body import SCALE_BOUNDS, describe, design_space, write_design
from planner.design.report import Verdict, atomic_folder, design_note, why, write_report
from planner.design.search import (
    DEFAULT_GENERATIONS,
    DEFAULT_KNOTS,
    DEFAULT_MASS_WEIGHT,
    DesignResult,
    DesignSample,
    GenerationRow,
    design_body,
    plan_body,
    servos_alone,
)
from planner.errors import InfeasibleGaitError
from planner.nlp.config import PlannerOptions
from robots import Gait, Robot

MAX_GENERATIONS = 1000
MAX_POPSIZE = 1000
MAX_WORKERS = 1024
MAX_MASS_WEIGHT = 1e3
#: Feasible bodies tried, best first, until one walks in MuJoCo (with --simulate).
FINAL_CANDIDATES = 3
DESIGN_GAIT = "gait.json"
ORIGINAL_GAIT = "original_gait.json"


def _names(option: str, text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [t.strip() for t in text.split(",")]
    if not all(names):
        raise OptionError(f"{option} must be a comma-separated list of names, got {text!r}")
    return names


def _check_output(output: Path) -> None:
    check_output_dir("--output", output)
    if output.exists() and any(output.iterdir()):
        raise OptionError(f"--output {output}: exists and is not empty; choose a new folder "
                          "(design writes a whole robot folder)")


def design_command(
    robot: str = typer.Argument(..., help="built-in name or a robot folder"),
    speed: float = typer.Option(..., "--speed", help="speed the body is designed for [m/s]"),
    output: Path = typer.Option(..., "--output", "-o", help="robot folder to write (new or empty)"),
    vary: str | None = typer.Option(
        None, "--vary", help="comma-separated link names (a leg body's name or part of it, e.g. "
        "thigh,shank), one length scale each; default: every leg segment, mirrored legs sharing"),
    servos: str | None = typer.Option(
        None, "--servos", help="comma-separated servo models every joint group may take "
        "(default: its own model and its catalogue neighbours of the same vendor and bus)"),
    generations: int = typer.Option(DEFAULT_GENERATIONS, "--generations",
                                    help="basin-CMA generations"),
    popsize: int | None = typer.Option(None, "--popsize",
                                       help="bodies per generation (default 4 + 3·ln n)"),
    workers: int = typer.Option(1, "--workers",
                                help="parallel workers (1: this process; >1: a process pool)"),
    ray: bool = typer.Option(False, "--ray", help="run the workers as Ray actors"),
    knots: int = typer.Option(DEFAULT_KNOTS, "--knots", help="knots per gait cycle"),
    mass_weight: float = typer.Option(
        DEFAULT_MASS_WEIGHT, "--mass-weight", help="weight w_m of the mass term w_m·m/m₀"),
    seed: int = typer.Option(0, "--seed", help="random seed of the search"),
    mu: float = typer.Option(0.5, "--mu", help="friction coefficient of the contact cone"),
    simulate: bool = typer.Option(
        False, "--simulate",
        help="validate the original's and the design's gaits in MuJoCo and stand the new body"),
    cycles: int = typer.Option(12, "--cycles", help="cycles to simulate (--simulate)"),
    sim_accept: bool = typer.Option(
        False, "--sim-accept/--no-sim-accept",
        help="rank bodies that do not stand or whose gait does not walk in MuJoCo as infeasible "
        "(a stand check and a short rollout per body: slower)"),
) -> None:
    """Design leg lengths and servos for a speed (W&P 2009 §3.6) and write the robot folder."""
    check_speed("--speed", speed, allow_zero=False)
    check_integer("--generations", generations, 1, MAX_GENERATIONS)
    check_integer("--popsize", popsize, 2, MAX_POPSIZE)
    check_integer("--workers", workers, 1, MAX_WORKERS)
    check_knots("--knots", knots)
    check_number("--mass-weight", mass_weight, 0.0, MAX_MASS_WEIGHT)
    check_friction("--mu", mu)
    if simulate:
        check_cycles("--cycles", cycles)
    vary_names, servo_names = _names("--vary", vary), _names("--servos", servos)
    _check_output(output)
    source = robots.load(robot)
    space = design_space(source, vary_names, servo_names)
    command = _command_line(robot, speed, output, vary, servos, generations, popsize, workers,
                            ray, knots, mass_weight, seed, mu, simulate, cycles)
    if sim_accept:
        command = command.replace(" -o ", " --sim-accept -o ")
    console.print(
        f"designing [bold]{source.name}[/] ({source.mass_kg:.3f} kg, leg "
        f"{source.leg_length_m:.3f} m) for {speed:g} m/s: {len(space.link_groups)} length "
        f"scales in [{SCALE_BOUNDS[0]:g}, {SCALE_BOUNDS[1]:g}], {len(space.servo_groups)} servo "
        f"groups, N={knots}")
    for sg in space.servo_groups:
        console.print(f"  servo group {sg.name} ({len(sg.joints)} joints): "
                      f"{', '.join(sg.candidates)}")

    def on_original(s: DesignSample) -> None:
        state = (f"J = {s.cost:.5g} (planner {s.planner_cost:.5g}), peak τ/τ_stall "
                 f"{s.peak_torque_ratio:.3f}" if s.feasible else f"[red]infeasible[/]: {s.message}")
        console.print(f"original {source.name}: {state}")

    def on_generation(row: GenerationRow) -> None:
        best = f"{row.best_cost:.5g}" if math.isfinite(row.best_cost) else "none feasible"
        console.print(f"  generation {row.generation}: {row.n_feasible}/{row.n_samples} feasible, "
                      f"best J {best} ({row.elapsed_s:.0f} s): {row.best}")

    executor = "ray" if ray else ("process" if workers > 1 else "serial")
    result = design_body(source, speed, space, n_knots=knots, options=PlannerOptions(mu=mu),
                         mass_weight=mass_weight, generations=generations, popsize=popsize,
                         seed=seed, executor=executor, workers=workers, progress=on_generation,
                         on_original=on_original,
                         acceptance=BodyAcceptance() if sim_accept else None)
    candidates = result.best_feasible(FINAL_CANDIDATES)
    if not candidates:
        limits = ", ".join(f"{name} in {n}" for name, n in result.limits())
        raise InfeasibleGaitError(
            f"no body of {len(result.samples)} reaches {speed:g} m/s on the {result.gait} "
            f"template; the limit that stops them: {limits}; nothing written "
            "(try more --generations, other --servos or a lower --speed)")
    passed = _finish(result, candidates, output, command, simulate, cycles)
    if not passed:
        raise typer.Exit(1)


@dataclass(frozen=True)
class _BodyVerdict:
    passed: bool
    badness: float
    reasons: tuple[str, ...]


def _stand_and_walk(body: Robot, gait: Gait) -> _BodyVerdict:
    """MuJoCo acceptance of a designed body: it stands on its servos, and its gait walks
    (`sim.acceptance.GaitCheck`: the search criteria, a short rollout)."""
    from sim.acceptance import GaitCheck  # lazy: MuJoCo only with --sim-accept
    from sim.stand_check import check_stand

    stand = check_stand(body)
    if not stand.stands:
        return _BodyVerdict(False, float(1 + len(stand.reasons)),
                            ("does not stand: " + "; ".join(stand.reasons),))
    walk = GaitCheck(body)(gait)
    return _BodyVerdict(walk.passed, walk.badness, walk.reasons)


@dataclass(frozen=True)
class BodyAcceptance:
    """Picklable factory of the MuJoCo body check (one per executor worker)."""

    def __call__(self) -> Callable[[Robot, Gait], _BodyVerdict]:
        return _stand_and_walk


def _verdict(gait: Gait | None) -> Verdict:
    if gait is None or gait.validation is None:
        return Verdict(None)
    v = gait.validation
    return Verdict(bool(v.get("passed")), tuple(str(r) for r in v.get("reasons", [])))


def _finish(result: DesignResult, candidates: list[DesignSample], output: Path, command: str,
            simulate: bool, cycles: int) -> bool:
    """Write the folder for the first candidate whose gait solves (and, with --simulate, walks
    and stands); True if it did."""
    source, space = result.robot, result.space
    original_gait = (result.original_planner.to_gait(result.original_plan, result.gait)
                     if result.original.feasible else None)
    if simulate and original_gait is not None:
        from sim.validate import validate_and_annotate  # lazy: MuJoCo only on request

        with console.status(f"validating {source.name}'s gait in MuJoCo ({cycles} cycles)…"):
            original_gait = validate_and_annotate(original_gait, source, cycles)
    notes: list[str] = []
    with atomic_folder(output) as tmp:
        chosen: tuple[DesignSample, Robot, Gait, bool] | None = None
        for rank, cand in enumerate(candidates, 1):
            body = write_design(source, space, cand.design, tmp, output.name,
                                design_note(result, cand, command))
            planner, plan = plan_body(body, result.gait, result.speed_m_s, result.n_knots,
                                      result.original_planner.options, cand.warm_start)
            if not plan.feasible:
                console.print(f"[yellow]{describe(space, cand.design)}: no feasible gait when "
                              f"re-solved ({plan.message}); next candidate[/]")
                notes.append(f"candidate {rank} (J {cand.cost:.5g}) did not re-solve feasibly: "
                             f"{plan.message}")
                continue
            gait = planner.to_gait(plan, result.gait, extra_metadata={"design": {
                "source_robot": source.name, "source_fingerprint": source.fingerprint,
                "speed_m_s": result.speed_m_s, "design_cost": cand.cost,
                "mass_weight": result.mass_weight, "body": describe(space, cand.design)}})
            ok = True
            if simulate:
                gait, ok = _simulate(gait, body, cycles)
                if not ok:
                    notes.append(f"candidate {rank} (J {cand.cost:.5g}, "
                                 f"{describe(space, cand.design)}) failed in MuJoCo: "
                                 f"{_verdict(gait).text()}")
            if chosen is None or (ok and not chosen[3]):
                chosen = (cand, body, gait, ok)
            if ok:
                break
        if chosen is None:
            raise InfeasibleGaitError(
                f"none of the {len(candidates)} best bodies re-solved feasibly at "
                f"{result.speed_m_s:g} m/s; nothing written")
        cand, body, gait, ok = chosen
        body = write_design(source, space, cand.design, tmp, output.name,
                            design_note(result, cand, command))
        alone = servos_alone(result, cand)
        if alone is not None:
            notes.append(_servo_share(result, cand, alone))
        gait = dataclasses.replace(gait, robot_dir=str(output.resolve()), robot_dir_relative=None)
        gait_io.save(gait, tmp / DESIGN_GAIT)
        if original_gait is not None:
            gait_io.save(original_gait, tmp / ORIGINAL_GAIT)
        before = (_verdict(original_gait) if original_gait is not None
                  else Verdict(None, ("no feasible gait to simulate",)))
        write_report(tmp, result, cand, body, command, (before, _verdict(gait)), notes)
        console.print(_table(result, cand, body, before, gait))
        console.print("why: " + "\n     ".join([*why(result, cand), *notes]))
    extra = f"{ORIGINAL_GAIT}, " if original_gait is not None else ""
    console.print(f"wrote [bold]{output}[/] (robot.xml, robot.toml, {DESIGN_GAIT}, {extra}"
                  "design_report.md, design_tradeoff.png, design_samples.csv)")
    return ok


def _servo_share(result: DesignResult, cand: DesignSample, alone: DesignSample) -> str:
    """What the servos alone buy (original lengths) and what the lengths add on top."""
    servos = ", ".join(dict.fromkeys(cand.design.servos))
    if not alone.feasible:
        return (f"the chosen servos ({servos}) on the original link lengths have no feasible "
                f"gait ({alone.message}): the lengths are what makes it work")
    start = (f"J {result.original.cost:.5g} → " if result.original.feasible
             else "the original is infeasible; ")
    return (f"the chosen servos alone ({servos}, original lengths): {start}{alone.cost:.5g} "
            f"(peak τ/τ_stall {alone.peak_torque_ratio:.3f}); the lengths then take it to "
            f"{cand.cost:.5g}")


def _simulate(gait: Gait, body: Robot, cycles: int) -> tuple[Gait, bool]:
    """`gait` validated on `body` in MuJoCo, and whether it walks and `body` stands."""
    from sim.stand_check import check_stand  # lazy: MuJoCo only on request
    from sim.validate import validate_and_annotate

    with console.status(f"validating the design's gait in MuJoCo ({cycles} cycles)…"):
        validated = validate_and_annotate(gait, body, cycles)
        stand = check_stand(body)
    v = _verdict(validated)
    console.print(f"design {body.name}: gait {v.text()}; "
                  f"{'stands' if stand.stands else 'does not stand: ' + '; '.join(stand.reasons)}")
    return validated, bool(v.passed) and stand.stands


def _table(result: DesignResult, cand: DesignSample, body: Robot, before: Verdict,
           gait: Gait) -> Table:
    orig = result.original
    table = Table(title=f"{result.robot.name} beside {body.name} at {result.speed_m_s:g} m/s")
    for col in ("", result.robot.name, body.name):
        table.add_column(col, justify="left" if not col else "right")

    def num(s: DesignSample, v: float, fmt: str = ".5g") -> str:
        return format(v, fmt) if s.feasible else "infeasible"

    table.add_row("leg length [m]", f"{orig.leg_length_m:.4f}", f"{cand.leg_length_m:.4f}")
    table.add_row("mass [kg]", f"{orig.mass_kg:.4f}", f"{cand.mass_kg:.4f}")
    for g, s in zip(result.space.link_groups, cand.design.scales, strict=True):
        table.add_row(f"{g.name} [m]", f"{g.length_m:.4f}", f"{g.length_m * s:.4f}")
    for sg, o, n in zip(result.space.servo_groups, orig.design.servos, cand.design.servos,
                        strict=True):
        table.add_row(f"servo {sg.name}", o, n)
    table.add_row("planner cost", num(orig, orig.planner_cost), num(cand, cand.planner_cost))
    table.add_row("design cost J", num(orig, orig.cost), num(cand, cand.cost))
    table.add_row("peak τ/τ_stall", num(orig, orig.peak_torque_ratio, ".3f"),
                  num(cand, cand.peak_torque_ratio, ".3f"))
    table.add_row("MuJoCo", before.text(), _verdict(gait).text())
    return table


def _command_line(robot: str, speed: float, output: Path, vary: str | None, servos: str | None,
                  generations: int, popsize: int | None, workers: int, ray: bool, knots: int,
                  mass_weight: float, seed: int, mu: float, simulate: bool, cycles: int) -> str:
    parts = [f"gaitsmith design {robot} --speed {speed:g}"]
    if vary:
        parts.append(f"--vary {vary}")
    if servos:
        parts.append(f"--servos {servos}")
    parts.append(f"--generations {generations}")
    if popsize is not None:
        parts.append(f"--popsize {popsize}")
    parts.append(f"--workers {workers}" + (" --ray" if ray else ""))
    parts.append(f"--knots {knots} --mass-weight {mass_weight:g} --seed {seed} --mu {mu:g}")
    if simulate:
        parts.append(f"--simulate --cycles {cycles}")
    parts.append(f"-o {output}")
    return " ".join(parts)


def register(app: typer.Typer) -> None:
    app.command("design")(design_command)

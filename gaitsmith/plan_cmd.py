"""`gaitsmith plan ROBOT --gait trot --vx 0.25 -o trot.json`: one spacetime solve → gait file.

`--vx` (alias `--speed`), `--vy` and `--yaw-rate` command a body-frame velocity: the cycle is
periodic up to the planar motion they define (`planner.nlp.command`), so the same templates turn,
side-step and walk backwards.

`--search` runs basin-CMA over the contact timings (starting from the templates) and writes the
best gait plus a search log next to it; `--simulate` validates the gait in MuJoCo and writes the
verdict into the file's `validation` block.

This module holds the command and its template path; where each option goes and what both paths
build from them (checks, `PlannerOptions`, gait-file metadata): `gaitsmith.plan_options`; the
`--search` path: `gaitsmith.plan_search`; `--simulate` and the written file:
`gaitsmith.plan_output`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import typer
from rich.table import Table

import robots
from gaitsmith.attitude_options import (
    attitude_gain_option,
    attitude_settings,
    check_attitude_judged,
    resolved_gain,
)
from gaitsmith.console import console
from gaitsmith.errors import OptionError
from gaitsmith.gait_choice import (
    check_gait_fits,
    commanded_gait,
    default_gait,
    default_speed_note,
    in_place_choice,
)
from gaitsmith.options import check_output_file, check_supply_v, check_yaw_rate
from gaitsmith.plan_options import (
    DEFAULT_MU,
    check_command,
    check_nlp_options,
    check_options,
    gait_metadata,
    planner_options,
    refuse_with_search,
    search_final_half_cycle,
    search_planner_options,
    standing,
    template_half_cycle,
)
from gaitsmith.plan_output import DEFAULT_CYCLES, STAND_S, simulated_cycles, write_gait
from gaitsmith.plan_search import SearchSettings, plan_search, user_seed
from gaitsmith.search_options import (
    executor_option,
    final_choice_option,
    final_swing_wrench_option,
    final_templates_option,
    search_half_cycle_option,
    search_knots_option,
    search_swing_wrench_option,
    sim_accept_option,
    tipping_weight_option,
    workers_option,
)
from gaitsmith.stance_options import StanceShaped, stance_shaped
from planner.errors import InfeasibleGaitError, PlannerConfigError
from planner.nlp.config import (
    DEFAULT_FROUDE,
    DEFAULT_INACTIVE_ROWS,
    DEFAULT_NLP_HESSIAN,
    INACTIVE_ROWS,
    PlannerOptions,
    default_speed_m_s,
)
from planner.nlp.spacetime import GaitPlanner, PlanResult
from planner.search.defaults import DEFAULT_GENERATIONS
from planner.templates import TEMPLATES, default_gait_for
from planner.user_schedule import command_schedule
from robots.servo_params import ServoSetting
from robots.voltage import robot_at_voltage, voltage_margin

if TYPE_CHECKING:
    from planner.servo_limited import ServoLimitedTiming
    from sim.attitude_loop import AttitudeSettings

_write = write_gait  # its name here before it moved to gaitsmith.plan_output (tests use it)


def plan(
    robot: str = typer.Argument(
        ..., help="built-in robot name or a folder with robot.xml + robot.toml"
    ),
    gait: str | None = typer.Option(
        None, "--gait", "-g",
        help=f"gait template: {', '.join(TEMPLATES)} (default: the robot's walking-pace "
        "template, e.g. trot on 4 legs, tripod on 6; with --search: all templates)",
    ),
    speed: float | None = typer.Option(
        None, "--vx", "--speed", help="forward speed [m/s] (body frame; negative: backwards; "
        "0: stand, or step in place with --gait/--duty/--phases; default: Froude number "
        f"{DEFAULT_FROUDE} for the robot's leg length, v = √(Fr·g·L))"
    ),
    vy: float = typer.Option(0.0, "--vy", help="lateral speed [m/s] (body frame, left +)"),
    yaw_rate: float = typer.Option(
        0.0, "--yaw-rate", help="yaw rate [rad/s] (left turn +; at most 0.5·√(g/L))"
    ),
    output: Path = typer.Option(..., "--output", "-o", help="gait file to write (JSON)"),
    knots: int = typer.Option(30, "--knots", help="knots per cycle (N)"),
    period: float | None = typer.Option(
        None, "--period", help="cycle period [s] (default: template)"
    ),
    duty: str | None = typer.Option(
        None, "--duty", help="duty factor: one value, or one per leg in robot.toml order "
        "(default: template; 0.6 with --phases)"),
    phases: str | None = typer.Option(
        None, "--phases", help="touchdown phase per leg in robot.toml order, e.g. 0,0.5,0.25,0.75 "
        "(replaces the template)"),
    schedule_file: Path | None = typer.Option(
        None, "--schedule", help="JSON/TOML file: touchdown_phase and duty_factor per leg name "
        "(replaces the template)"),
    mu: float = typer.Option(DEFAULT_MU, "--mu",
                             help="friction coefficient of the contact cone"),
    solver: str = typer.Option(
        "knot", "--solver", help="IPOPT+MUMPS derivative path: knot (default: one knot's "
        "Jacobian and Hessian, cached; fast build; uses compiled ones if cached), expanded (whole "
        "NLP in SX; slow build) or compiled (knot, with J and H compiled to C once per robot: "
        "minutes the first time, faster solves after)"),
    nlp_hessian: str = typer.Option(
        DEFAULT_NLP_HESSIAN, "--nlp-hessian", help="IPOPT's Lagrangian Hessian with --solver "
        "knot or compiled (`PlannerOptions.nlp_hessian`): ad (CasADi's AD of the whole NLP) or "
        "assembled (one knot Hessian per knot weighted by its multipliers, "
        "`planner.nlp.assembled_hessian`); the same Hessian to rounding, not the same bits "
        "(docs/results/planner_speed.md, sessions 29-30)"),
    inactive_rows: str = typer.Option(
        DEFAULT_INACTIVE_ROWS, "--inactive-rows", help="the equality rows the contact schedule "
        "switches off (0 = 0; `PlannerOptions.inactive_rows`): "
        + " | ".join(INACTIVE_ROWS) + "; the same feasible set. With --search only the final "
        "re-solves use it, the coarse solves keep rows (docs/results/planner_speed_ipopt.md)"),
    background_compile: bool = typer.Option(
        True, "--background-compile/--no-background-compile", help="with --solver knot and a "
        "C compiler: if the robot's knot derivatives are not compiled yet, compile them in a "
        "detached background process (nice 10, about a minute of CPU) so later commands plan "
        "faster (`gaitsmith cache` shows it; $GAITSMITH_BACKGROUND_COMPILE=0 turns it off "
        "everywhere)"),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="show IPOPT's iteration log live"),
    knife_edge: bool = typer.Option(
        False, "--knife-edge", help="with --simulate: also re-plan at ±1% speed and N±4 and "
        "simulate them and the plan at 5 and 10 ms servo latency; says whether the pass is "
        "robust or on a knife edge (minutes)"),
    mirror: bool = typer.Option(
        False, "--mirror", help="the second half of the cycle is the first half mirrored "
        "left-right (straight gaits of symmetric bodies on half-cycle symmetric schedules: "
        "biped walk/run, trot, pace, tripod; N even)"),
    half_cycle: bool | None = typer.Option(
        None, "--half-cycle/--full-cycle",
        help="solve a straight gait on a half-cycle mirror-symmetric schedule (trot, pace, "
        "tripod, biped walk; N even) on the first half of its knots, the second half its "
        "mirror image: about half the time per solve, the same optimum where the full solve "
        "stays symmetric; anything else (a turn, an asymmetric schedule, a body with no mirror "
        "image) is solved in full. Default: half-cycle for the planned gait, the templates "
        "--search re-solves and the searched candidates it re-solves (a candidate whose "
        "half-cycle plan fails the MuJoCo check narrowly is re-solved on all knots); given, it "
        "sets both (--search-half-cycle: the search's coarse solves)"),
    force_rate: float | None = typer.Option(
        None, "--force-rate", help="bound each foot's normal-force rate to this many body "
        "weights per √(L/g) (`PlannerOptions.normal_force_rate_weights_per_t0`): the load "
        "builds over several knots after touchdown and fades before lift-off; 5 keeps "
        "humanoid20's template walk up (docs/results/zoo_gaits.md, session 24); 0: no "
        "bound; default: none, or 10 on a compliant stance (`planner.compliant_stance`)"),
    bounce_weight: float | None = typer.Option(
        None, "--bounce-weight", help="weight of the body's vertical and sideways speed in the "
        "objective (`CostWeights.bounce_s2_m2`, W&P eq 15; default 10, K × 10 on a compliant "
        "stance, `planner.compliant_stance`): higher keeps the body height flatter, so less "
        "load at each touchdown (docs/results/zoo_gaits.md, session 25)"),
    entry_cycles: int | None = typer.Option(
        None, "--entry-cycles", help="start the gait with at least this many cycles of entry "
        "blend (written into the gait file, so the player and --simulate both use it; "
        "`robots.ramp`); default 1, or ⌈1/(1 − m·g·h/kp)⌉ on a compliant stance "
        "(`planner.compliant_stance`)"),
    rotor_reserve: float | None = typer.Option(
        None, "--rotor-reserve", help="keep the servo envelope also for the knot torque with "
        "the rotor's share (armature × joint acceleration) taken 1 + RHO times "
        "(`PlannerOptions.rotor_reserve`): a reserve for heavy servo rotors; 0.1-0.15 took "
        "spotmicro's walk with the identified STS3215 rotor from 84 % to 78-79 % peak torque "
        "(docs/results/heavy_rotor.md)"),
    swing_clearance: float | None = typer.Option(
        None, "--swing-clearance", help="swing clearance [m]: each swing foot's bottom stays "
        "above h·sin(π·swing progress) (`PlannerOptions.swing_clearance_m`; default 0.14 × "
        "the leg length)"),
    line_capture_margin: float | None = typer.Option(
        None, "--line-capture-margin", help="on two-foot support the capture point lies at "
        "least this many leg lengths on the side of the support line where the next swing "
        "foot lands (`PlannerOptions.line_capture_margin_leg_lengths`, "
        "`planner.nlp.line_capture`): the open-loop body falls toward the landing foot; 0.16 "
        "took knee8's duty-0.6 walk at T 1.35 s from 0.155 to 0.180 m/s "
        "(docs/results/heavy_rotor.md §7)"),
    cop_sole_fraction: float | None = typer.Option(
        None, "--cop-sole-fraction", help="flat feet: plan each stance wrench in the cone of "
        "the sole shrunk to this fraction of its half length and width, a centre-of-pressure "
        "and torsional-friction margin (`PlannerOptions.cop_sole_fraction`, "
        "`planner.nlp.contact_margin`; default 1, the whole sole): 0.5 took the built-in "
        "biped's 0.222 m/s turning walks from a 0.05-0.08 rad/s yaw-rate overshoot to "
        "0.007-0.025 (docs/results/attitude_feedback.md, Session 30 (branch yaw))"),
    search: bool = typer.Option(
        False, "--search", help="search period, touchdown phases and duty factors by basin-CMA"
    ),
    generations: int = typer.Option(DEFAULT_GENERATIONS, "--generations",
                                    help="basin-CMA generations (--search)"),
    popsize: int | None = typer.Option(None, "--popsize", help="basin-CMA λ (--search)"),
    seed: int = typer.Option(0, "--seed", help="random seed of the search"),
    symmetric: bool = typer.Option(
        True, "--symmetric/--no-symmetric",
        help="right legs half a period after the left ones (walk/trot/pace); "
        "--no-symmetric also reaches bound/gallop",
    ),
    executor: str = executor_option(),
    workers: int | None = workers_option(),
    address: str | None = typer.Option(None, "--address", help="Ray cluster address"),
    search_knots: int = search_knots_option(),
    tipping_weight: float = tipping_weight_option(),
    sim_accept: bool = sim_accept_option(),
    search_swing_wrench: str = search_swing_wrench_option(),
    final_swing_wrench: str = final_swing_wrench_option(),
    final_choice: str = final_choice_option(),
    search_half_cycle: bool = search_half_cycle_option(),
    final_templates: str = final_templates_option(),
    simulate: bool = typer.Option(
        False, "--simulate", help="validate in MuJoCo and write the verdict into the gait file"
    ),
    cycles: int | None = typer.Option(
        None, "--cycles", help=f"cycles to simulate (--simulate; default {DEFAULT_CYCLES}, a "
        f"stand: {STAND_S:g} s of cycles)"),
    supply_v: float | None = typer.Option(
        None, "--supply-v",
        help="servo supply voltage [V]: plan within the torque–speed envelope at this voltage "
        "(∝ V/V_nominal; default: the servos' nominal voltage)",
    ),
    servo_params_path: Path | None = typer.Option(
        None, "--servo-params",
        help="identified servos (servo_params.toml of `gaitsmith identify`): the servo goals "
        "use each joint's fitted gain, strength and latency; --simulate simulates them",
    ),
    attitude_gain: float | None = attitude_gain_option(),
) -> None:
    """Plan one efficient cyclic gait (W&P 2009 spacetime optimisation) and write the gait file."""
    # where each option goes (template path, --search, refused with --search): OPTION_ROUTES
    given = dict(locals())  # the parsed options by parameter name
    settings = SearchSettings(generations, popsize, seed, symmetric, executor, workers,
                              address, search_knots, tipping_weight, sim_accept,
                              search_swing_wrench, final_choice, search_half_cycle,
                              final_templates, search_final_half_cycle(half_cycle),
                              final_swing_wrench)
    check_options(speed, knots, period, duty, mu, search, settings, simulate, cycles)
    check_command(speed, vy, yaw_rate)
    refuse_with_search(search, given)  # --vy, --yaw-rate, --knife-edge, --mirror, ...
    check_attitude_judged(attitude_gain, simulate or (search and sim_accept),
                          "--simulate (or --search with its MuJoCo acceptance, --sim-accept)")
    if knife_edge and (not simulate or vy or yaw_rate):
        raise OptionError("--knife-edge: needs --simulate, a straight command (no --vy, "
                          "--yaw-rate) and no --search")
    check_nlp_options(force_rate, bounce_weight, entry_cycles, rotor_reserve, swing_clearance,
                      solver, mirror, knots, line_capture_margin, nlp_hessian,
                      cop_sole_fraction, inactive_rows)
    check_output_file("--output", output)
    if not background_compile:  # this process and the search's workers (they inherit it)
        from planner.nlp.background_compile import ENV_SWITCH

        os.environ[ENV_SWITCH] = "0"
    bot = robots.load(robot)
    if speed is None:
        speed = default_speed_m_s(bot.leg_length_m)
        console.print(default_speed_note(bot, speed))
    check_yaw_rate("--yaw-rate", yaw_rate, bot)
    if cop_sole_fraction is not None and not any(leg.is_flat for leg in bot.legs):
        raise OptionError(f"--cop-sole-fraction: {bot.name} has point feet, no sole to shrink; "
                          "drop the option (it applies to flat feet only)")
    check_supply_v("--supply-v", supply_v, bot)
    bot = robot_at_voltage(bot, supply_v)
    servo_settings = None
    if servo_params_path is not None:
        from robots import servo_params

        servo_settings = servo_params.load(servo_params_path).for_robot(bot)
    # a stepping gait: the stance-compliance rule fills the options the user left out
    stand = standing(speed, vy, yaw_rate, duty, phases, schedule_file)
    shaped = (stance_shaped(bot, servo_settings, force_rate, bounce_weight, entry_cycles)
              if search or not stand
              else StanceShaped(force_rate, bounce_weight, entry_cycles, {}))
    options = planner_options(mu, solver, shaped, rotor_reserve, swing_clearance,
                              verbose=verbose, servo_settings=servo_settings, mirror=mirror,
                              half_cycle=template_half_cycle(half_cycle),
                              line_capture_margin=line_capture_margin,
                              nlp_hessian=nlp_hessian, cop_sole_fraction=cop_sole_fraction,
                              inactive_rows=inactive_rows)
    meta = gait_metadata(supply_v, servo_params_path, shaped)
    if search:
        if (gait is None and not stand and not vy and not yaw_rate
                and all(v is None for v in (period, duty, phases, schedule_file))):
            options, seed_schedule = servo_limited_search_seed(bot, speed, options)
        else:
            gait, seed_schedule = user_seed(bot, gait, period, duty, phases, schedule_file)
        plan_search(bot, gait, speed, output, knots, settings, simulate, cycles, supply_v,
                    search_planner_options(options), shaped.entry or 1, seed_schedule, meta,
                    attitude_gain)
        return
    custom = phases is not None or schedule_file is not None
    if gait is None and (custom or stand):
        # --phases/--schedule replace the template (as explicit a choice as --gait); a zero
        # command with no stepping schedule plans the stand
        gait = default_gait(bot, standing=stand)
    choice = commanded_gait(bot, gait, vy, yaw_rate, options)
    gait, options = choice.gait, choice.options
    limited = (servo_limited(bot, gait, speed, options)
               if choice.reason == "default" and not custom and period is None and duty is None
               else None)
    if limited is not None:
        duty, period, options = _servo_limited_timing(limited, options)
    if not custom:
        check_gait_fits(bot, gait)
    if choice.duty_factor is not None and duty is None:
        duty = f"{choice.duty_factor:g}"
        period = period if period is not None else choice.period_s
        console.print(f"commanded gait: {choice.reason}")
    schedule, gait = command_schedule(bot, gait, phases=phases, duty=duty,
                                      schedule_file=schedule_file, period_s=period)
    if mirror:
        _check_mirror(bot, schedule, knots, vy, yaw_rate)
    in_place = in_place_choice(bot, schedule, speed, vy, yaw_rate, options)
    if in_place is not None:
        options = in_place
        dx, dy = in_place.mean_footprint_offset_m
        shift = (f" shifted ({dx * 1000:+.1f}, {dy * 1000:+.1f}) mm under the centre of mass"
                 if (dx, dy) != (0.0, 0.0) else "")
        console.print(
            f"stepping in place: each foot's cycle mean within "
            f"{in_place.mean_footprint_leg_lengths:g} L of its stance position{shift}, swing "
            f"clearance {in_place.swing_clearance_for(bot.leg_length_m) * 1000:.1f} mm")
    _note_swing_slack(bot, schedule, speed, options)
    command = f"{speed:.3f} m/s" + (
        f", vy {vy:+.3f} m/s, yaw rate {yaw_rate:+.3f} rad/s" if vy or yaw_rate else "")
    console.print(
        f"planning [bold]{gait}[/] for [bold]{bot.name}[/] at {command}, period "
        f"{schedule.period_s:.3f} s, duty {schedule.duty_factor[0]:.2f}, N={knots}, µ={mu}"
    )
    with console.status("building the NLP (CasADi)…"):
        planner = GaitPlanner(bot, n_knots=knots, options=options)
    console.print(f"NLP built in {planner.build_time_s:.1f} s ({planner.layout.size} variables)")
    if verbose:
        result = planner.solve(schedule, speed, vy_m_s=vy, yaw_rate_rad_s=yaw_rate)
    else:
        with console.status("solving (IPOPT)…"):
            result = planner.solve(schedule, speed, vy_m_s=vy, yaw_rate_rad_s=yaw_rate)
        _print_progress(result)
    _print_summary(planner, result)
    if supply_v is not None and result.feasible:
        console.print(voltage_margin(bot, result.joint_torques_nm, supply_v).summary())
    if not result.feasible:
        # what to do: the limits above say what binds; the search (straight gaits only) tries
        # other contact timings than the template's
        retry = ("a smaller --speed, --vy or --yaw-rate, or another --gait" if vy or yaw_rate
                 else "a lower --speed, another --gait, or --search (other contact timings)")
        raise InfeasibleGaitError(
            f"{bot.name} {gait} at {command}: {result.message}; no gait file written; "
            f"try {retry}",
            result.binding,
        )
    gait_obj = planner.to_gait(result, gait, extra_metadata=meta)
    attitude = attitude_settings(resolved_gain(attitude_gain, bot, gait_obj) if simulate else None)
    write_gait(gait_obj, bot, output, simulate, cycles, servo_settings, attitude)
    if knife_edge:
        _knife_edge(gait_obj, bot, schedule, gait, speed, knots, options, cycles, servo_settings,
                    meta, attitude)


def servo_limited(bot: robots.Robot, gait: str, speed: float,
                  options: PlannerOptions) -> ServoLimitedTiming | None:
    """The servo-limited timing of the default template (`planner.servo_limited`): only on a
    robot whose template swing is faster than its servos can swing (slack < 1)."""
    from planner.servo_limited import servo_limited_timing

    return servo_limited_timing(bot, gait, speed, options)


def servo_limited_search_seed(bot: robots.Robot, speed: float, options: PlannerOptions
                              ) -> tuple[PlannerOptions, robots.ContactSchedule | None]:
    """What `plan BOT --speed V --search` with no gait or timing flag starts from: on a body
    whose default template swings faster than its servos (`servo_limited`, e.g. knee8) the
    rule's options and its timing as a seed beside the templates; elsewhere `options` and no
    seed. Shared with the search benchmarks, so they search as the command does."""
    limited = servo_limited(bot, default_gait_for(bot), speed, options)
    if limited is None:
        return options, None
    duty, period, options = _servo_limited_timing(limited, options)
    return options, user_seed(bot, None, period, duty, None, None)[1]


def _servo_limited_timing(limited: ServoLimitedTiming,
                          options: PlannerOptions) -> tuple[str, float, PlannerOptions]:
    """Say the rule's timing and return it as --duty, --period and the options it sets."""
    console.print(f"servo-limited timing: {limited.summary()} (docs/results/heavy_rotor.md §9)")
    return f"{limited.duty_factor:g}", limited.period_s, limited.options(options)


def _note_swing_slack(bot: robots.Robot, schedule: robots.ContactSchedule, speed: float,
                      options: PlannerOptions) -> None:
    """Say so when the schedule's swing is faster than the servos' fastest swing of its stride
    (`planner.swing_slack`: slack < 1; knee8's default walk with its heavy rotors: 0.61). An
    estimate (quad12's trot passes at 0.4 m/s with 0.99): the plan is made as asked; the note
    says why it may be infeasible or on its servo envelope, and which knobs give the swing
    time."""
    from planner.swing_slack import swing_slack

    slack = swing_slack(bot, schedule, speed, options)
    if slack.ratio >= 1.0:
        return
    console.print(
        f"[yellow]swing slack {slack.ratio:.2f} < 1 on {slack.joint}: the swing ("
        f"{slack.excursion_rad:.2f} rad in {slack.swing_s * 1000:.0f} ms) is faster than the "
        f"servo envelope's fastest swing of that stride ({slack.fastest_swing_s * 1000:.0f} ms), "
        "so expect no feasible gait or a plan on its envelope; a lower --duty or a longer "
        "--period gives the swing more time (docs/results/heavy_rotor.md)[/]")


def _knife_edge(gait_obj: robots.Gait, bot: robots.Robot, schedule: robots.ContactSchedule,
                label: str, speed: float, knots: int, options: PlannerOptions,
                cycles: int | None, servo_settings: tuple[ServoSetting, ...] | None,
                meta: dict[str, Any] | None, attitude: AttitudeSettings | None = None) -> None:
    """--knife-edge: `planner.robust_plan.replans` judged by `sim.robustness.knife_edge_check`,
    every run simulated with the same identified servos (`--servo-params`) and attitude
    feedback (`--attitude-gain`) as --simulate and
    written with the nominal file's metadata (`meta`: entry cycles, stance-compliance record)."""
    from planner.robust_plan import replans
    from sim.robustness import knife_edge_check

    with console.status("knife-edge check: re-planning at ±1 % speed and N±4…"):
        variants = replans(bot, schedule, label, speed, knots, options, extra_metadata=meta)
    n_cycles, _ = simulated_cycles(gait_obj, cycles)
    with console.status("knife-edge check: simulating the variants…") as status:
        check = knife_edge_check(
            gait_obj, bot, [(v.label, v.gait) for v in variants], n_cycles,
            servo_settings=servo_settings,
            attitude=attitude,
            progress=lambda done, total: status.update(
                f"knife-edge check: simulated {done} of {total} runs…"),
        )
    colour = "green" if check.robust else "yellow" if check.nominal_passed else "red"
    console.print(f"knife-edge check: [bold {colour}]{check.summary()}[/]")


def _check_mirror(bot: robots.Robot, schedule: robots.ContactSchedule, knots: int, vy: float,
                  yaw_rate: float) -> None:
    """--mirror's conditions, before the NLP is built (`planner.nlp.mirror`)."""
    from planner.nlp.mirror import check_mirror, joint_mirror

    try:
        joint_mirror(bot)
        check_mirror(bot, schedule, knots, vy, yaw_rate)
    except PlannerConfigError as exc:
        raise OptionError(str(exc)) from None


def _print_progress(result: PlanResult) -> None:
    log = result.stats.get("iterations", {})
    obj, inf_pr = log.get("obj", []), log.get("inf_pr", [])
    step = max(1, len(obj) // 10)
    for i in range(0, len(obj), step):
        console.print(
            f"  iter {i:4d}  objective {obj[i]:.6g}  constraint violation {inf_pr[i]:.2e}"
        )


def _print_summary(planner: GaitPlanner, result: PlanResult) -> None:
    head = Table(title="solve", show_header=False)
    head.add_row("status", result.status + ("" if result.feasible else "  [red](infeasible)[/]"))
    head.add_row("iterations", str(result.iterations))
    fallback = result.stats.get("half_cycle_fallback")
    if fallback:
        head.add_row("half-cycle solve", (
            f"dropped: its plan broke the full cycle's rows by {fallback['max_violation']:.1e} "
            f"(the body's dynamics are not left–right symmetric); solved on all knots"))
    asymmetry = result.stats.get("half_cycle_asymmetry")
    if asymmetry:
        head.add_row("half-cycle solve", (
            f"not used: the {asymmetry['rows']} rows are not left–right mirror images (defect "
            f"{asymmetry['defect']:.1e}; the body's masses, inertias or servo limits are not "
            "symmetric though its joints are); solved on all knots"))
    head.add_row("solve time [s]", f"{result.solve_time_s:.3f}")
    head.add_row("objective", f"{result.cost:.6g}")
    weights = planner.options.weights.as_dict()
    for name, value in result.cost_terms.items():
        head.add_row(
            f"  {name}", f"{value:.4g} × w {weights[name]:g} = {weights[name] * value:.4g}"
        )
    head.add_row("max violation", f"{result.max_violation:.2e}")
    head.add_row("active limits", ", ".join(f"{n} {v:.2g}" for n, v in result.binding[:4]) or "-")
    console.print(head)
    table = Table(title="servo load (peak over the cycle)")
    for col in ("joint", "|τ|/stall", "|q̇|/ω₀"):
        table.add_column(col)
    for j, joint in enumerate(planner.robot.joints):
        tau = float(np.max(np.abs(result.joint_torques_nm[:, j]))) / joint.servo.stall_torque_nm
        qd = (
            float(np.max(np.abs(result.joint_speeds_rad_s[:, j]))) / joint.servo.no_load_speed_rad_s
        )
        table.add_row(joint.name, f"{tau:.2f}", f"{qd:.2f}")
    console.print(table)


def register(app: typer.Typer) -> None:
    app.command("plan")(plan)

"""Where each `gaitsmith plan` option goes, and what both paths build from them.

`OPTION_ROUTES` is the one table of the options: what the template path and the `--search`
path do with each, and which ones `--search` refuses (`refuse_with_search`, one loop, one-line
errors). `planner_options` builds the `PlannerOptions` of both paths and `gait_metadata` the gait
file's planner metadata of both paths, so a new NLP option or metadata entry is added once.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from gaitsmith.errors import OptionError
from gaitsmith.options import (
    MAX_PERIOD_S,
    check_cycles,
    check_friction,
    check_integer,
    check_knots,
    check_number,
    check_speed,
    check_velocity,
)
from gaitsmith.plan_search import SearchSettings
from gaitsmith.search_options import (
    check_final_choice,
    check_final_templates,
    check_search_options,
    check_swing_wrench,
)
from gaitsmith.stance_options import STANCE_COMPLIANCE_KEY, StanceShaped
from planner.nlp.config import (
    COP_SOLE_FRACTION,
    DEFAULT_HALF_CYCLE_SOLVE,
    DEFAULT_INACTIVE_ROWS,
    DEFAULT_NLP_HESSIAN,
    DERIVATIVE_PATHS,
    INACTIVE_ROWS,
    NLP_HESSIANS,
    PlannerOptions,
)
from planner.search.defaults import FINAL_HALF_CYCLE
from robots.gait import ENTRY_CYCLES_KEY, MAX_ENTRY_CYCLES
from robots.servo_params import ServoSetting

DEFAULT_MU = 0.5  # --mu: the contact cone's friction coefficient
MAX_FORCE_RATE = 100.0  # --force-rate: body weights per √(L/g); 3-10 are the useful values
MAX_COST_WEIGHT = 1e6  # --bounce-weight: the objective's default weights are 1e-5-10

# what a path does with an option ("" in `OptionRoute`: the path does not use it)
COMMAND = "commanded velocity"
SCHEDULE = "contact schedule"
SEED = "a seed schedule beside the templates"
NLP = "PlannerOptions"
NLP_META = "PlannerOptions via the stance rule; gait-file metadata"
SEARCH = "the search's settings"
VALIDATION = "--simulate's validation"
ACCEPTANCE = "--simulate's validation and the search's MuJoCo acceptance"
BACKGROUND = "$GAITSMITH_BACKGROUND_COMPILE of this command and its workers"

FORWARD_ONLY = ("--search plans forward gaits only: drop --vy/--yaw-rate, or plan a template "
                "without --search")


@dataclass(frozen=True)
class OptionRoute:
    """One option of `gaitsmith plan`: its flag, `plan`'s parameter, what the template path
    and `--search` do with it, and the one-line error with which `--search` refuses it when
    given (a value other than off, 0 or unset)."""

    flag: str
    param: str
    template: str
    search: str
    refused_with_search: str | None = None


OPTION_ROUTES: tuple[OptionRoute, ...] = (
    OptionRoute("--gait", "gait", "the template", "the base of the seed schedule"),
    OptionRoute("--vx", "speed", COMMAND, COMMAND),
    OptionRoute("--vy", "vy", COMMAND, "", FORWARD_ONLY),
    OptionRoute("--yaw-rate", "yaw_rate", COMMAND, "", FORWARD_ONLY),
    OptionRoute("--output", "output", "the gait file", "the gait file and its search log"),
    OptionRoute("--knots", "knots", "knots of the NLP", "knots of the final NLP"),
    OptionRoute("--period", "period", SCHEDULE, SEED),
    OptionRoute("--duty", "duty", SCHEDULE, SEED),
    OptionRoute("--phases", "phases", SCHEDULE, SEED),
    OptionRoute("--schedule", "schedule_file", SCHEDULE, SEED),
    OptionRoute("--mu", "mu", NLP, NLP),
    OptionRoute("--solver", "solver", NLP, NLP),
    OptionRoute("--nlp-hessian", "nlp_hessian", NLP, NLP),
    OptionRoute("--inactive-rows", "inactive_rows", NLP + "; gait-file metadata",
                "PlannerOptions of the final re-solves (the coarse solves keep rows); "
                "gait-file metadata"),
    OptionRoute("--background-compile", "background_compile", BACKGROUND, BACKGROUND),
    OptionRoute("--verbose", "verbose", "PlannerOptions.print_level", ""),
    OptionRoute("--knife-edge", "knife_edge", "re-plans and simulations after --simulate", "",
                "--knife-edge: needs --simulate, a straight command (no --vy, --yaw-rate) and "
                "no --search"),
    OptionRoute("--half-cycle", "half_cycle", NLP + " (default: half-cycle)",
                NLP + " of the final re-solves (default: half-cycle, a narrow MuJoCo failure "
                "re-solved full); gait-file metadata"),
    OptionRoute("--mirror", "mirror", NLP, "",
                "--mirror: not with --search yet; plan the chosen gait with --mirror"),
    OptionRoute("--force-rate", "force_rate", NLP_META, NLP_META),
    OptionRoute("--bounce-weight", "bounce_weight", NLP_META, NLP_META),
    OptionRoute("--entry-cycles", "entry_cycles", "gait-file metadata",
                "gait-file metadata; the search's MuJoCo acceptance"),
    OptionRoute("--rotor-reserve", "rotor_reserve", NLP, NLP),
    OptionRoute("--swing-clearance", "swing_clearance", NLP, NLP),
    OptionRoute("--line-capture-margin", "line_capture_margin", NLP, NLP),
    OptionRoute("--cop-sole-fraction", "cop_sole_fraction", NLP, NLP),
    OptionRoute("--search", "search", "", "switches to the search"),
    OptionRoute("--generations", "generations", "", SEARCH),
    OptionRoute("--popsize", "popsize", "", SEARCH),
    OptionRoute("--seed", "seed", "", SEARCH),
    OptionRoute("--symmetric", "symmetric", "", SEARCH),
    OptionRoute("--executor", "executor", "", SEARCH),
    OptionRoute("--workers", "workers", "", SEARCH),
    OptionRoute("--address", "address", "", SEARCH),
    OptionRoute("--search-knots", "search_knots", "", SEARCH),
    OptionRoute("--tipping-weight", "tipping_weight", "", SEARCH),
    OptionRoute("--sim-accept", "sim_accept", "", SEARCH),
    OptionRoute("--search-swing-wrench", "search_swing_wrench", "", SEARCH),
    OptionRoute("--final-swing-wrench", "final_swing_wrench", "", SEARCH + "; gait-file metadata"),
    OptionRoute("--final-choice", "final_choice", "", SEARCH + "; gait-file metadata"),
    OptionRoute("--search-half-cycle", "search_half_cycle", "", SEARCH + "; gait-file metadata"),
    OptionRoute("--final-templates", "final_templates", "", SEARCH + "; gait-file metadata"),
    OptionRoute("--simulate", "simulate", VALIDATION, VALIDATION),
    OptionRoute("--cycles", "cycles", VALIDATION, ACCEPTANCE),
    OptionRoute("--supply-v", "supply_v", "the servo envelope; gait-file metadata",
                "the servo envelope; gait-file metadata"),
    OptionRoute("--servo-params", "servo_params_path",
                "PlannerOptions.servo_settings, the stance rule, --simulate; gait-file metadata",
                "", "--servo-params: not with --search yet; plan the chosen gait without "
                "--search to use the identified servos"),
    OptionRoute("--attitude-gain", "attitude_gain", "--simulate and --knife-edge closed loop; "
                "the validation's conditions",
                ACCEPTANCE + " closed loop (every gait, instead of the rule per gait); the "
                "validation's conditions"),
)


def refuse_with_search(search: bool, given: Mapping[str, Any]) -> None:
    """With `--search`: the first option in `OPTION_ROUTES` it refuses that is given (`given`:
    `plan`'s parameters by name), as a one-line `OptionError`."""
    if not search:
        return
    for route in OPTION_ROUTES:
        if route.refused_with_search is not None and given[route.param]:
            raise OptionError(route.refused_with_search)


def check_options(speed: float | None, knots: int, period: float | None, duty: str | None,
                  mu: float, search: bool, st: SearchSettings, simulate: bool,
                  cycles: int | None) -> None:
    """Every option in range before the robot is loaded and the NLP built (one-line errors)."""
    if search and speed is not None:  # the search needs CoT and Froude > 0
        check_speed("--vx/--speed", speed, allow_zero=False)
    check_knots("--knots", knots)
    check_number("--period", period, 0.0, MAX_PERIOD_S, lo_open=True, unit="s")
    if duty is not None and "," not in duty:  # a list is checked per leg once the robot is loaded
        try:
            single: float | None = float(duty)
        except ValueError:
            single = None  # not a number: planner.user_schedule names it
        check_number("--duty", single, 0.0, 1.0, lo_open=True, hi_open=True)
    check_friction("--mu", mu)
    if search:
        check_search_options(st.executor, st.generations, st.popsize, st.workers,
                             st.search_knots, st.tipping_weight)
        check_swing_wrench("--search-swing-wrench", st.search_swing_wrench)
        check_swing_wrench("--final-swing-wrench", st.final_swing_wrench)
        check_final_choice(st.final_choice)
        check_final_templates(st.final_templates)
    if cycles is not None and (simulate or (search and st.sim_accept)):
        check_cycles("--cycles", cycles)


def check_command(vx: float | None, vy: float, yaw_rate: float) -> None:
    """--vx/--vy finite and bounded (any sign), --yaw-rate finite (its bound needs the robot)."""
    if vx is not None:
        check_velocity("--vx/--speed", vx)
    check_velocity("--vy", vy)
    check_number("--yaw-rate", yaw_rate, -1e3, 1e3, unit="rad/s")


def check_nlp_options(force_rate: float | None, bounce_weight: float | None,
                      entry_cycles: int | None, rotor_reserve: float | None,
                      swing_clearance: float | None, solver: str, mirror: bool,
                      knots: int, line_capture_margin: float | None = None,
                      nlp_hessian: str = DEFAULT_NLP_HESSIAN,
                      cop_sole_fraction: float | None = None,
                      inactive_rows: str = DEFAULT_INACTIVE_ROWS) -> None:
    """The NLP-shaping options (each None unless given) in the ranges the planner accepts."""
    check_number("--force-rate", force_rate, 0.0, MAX_FORCE_RATE,
                 unit="body weights per √(L/g)")  # 0: no rows (overrides the stance rule)
    check_number("--bounce-weight", bounce_weight, 0.0, MAX_COST_WEIGHT)
    check_integer("--entry-cycles", entry_cycles, 1, MAX_ENTRY_CYCLES)
    check_number("--rotor-reserve", rotor_reserve, 0.0, 2.0, lo_open=True)
    check_number("--swing-clearance", swing_clearance, 0.0, 1.0, lo_open=True, hi_open=True,
                 unit="m")
    check_number("--line-capture-margin", line_capture_margin, 0.0, 1.0, hi_open=True,
                 unit="leg lengths")
    check_number("--cop-sole-fraction", cop_sole_fraction, 0.0, 1.0, lo_open=True)
    if mirror and knots % 2:
        raise OptionError(f"--mirror needs an even --knots (half a cycle on knots), got {knots}")
    if solver not in DERIVATIVE_PATHS:
        raise OptionError(f"--solver {solver!r}: use one of {', '.join(DERIVATIVE_PATHS)}")
    if nlp_hessian not in NLP_HESSIANS:
        raise OptionError(f"--nlp-hessian {nlp_hessian!r}: use one of {', '.join(NLP_HESSIANS)}")
    if inactive_rows not in INACTIVE_ROWS:
        raise OptionError(f"--inactive-rows {inactive_rows!r}: use one of "
                          f"{', '.join(repr(v) for v in INACTIVE_ROWS)}")


def standing(vx: float, vy: float, yaw_rate: float, duty: str | None, phases: str | None,
             schedule_file: Path | None) -> bool:
    """A zero command with no stepping schedule asked for: plan the `stand` template."""
    stepping = duty is not None or phases is not None or schedule_file is not None
    return vx == 0.0 and vy == 0.0 and yaw_rate == 0.0 and not stepping


def planner_options(mu: float, solver: str, shaped: StanceShaped, rotor_reserve: float | None,
                    swing_clearance: float | None, *, verbose: bool = False,
                    servo_settings: tuple[ServoSetting, ...] | None = None,
                    mirror: bool = False,
                    half_cycle: bool = DEFAULT_HALF_CYCLE_SOLVE,
                    line_capture_margin: float | None = None,
                    nlp_hessian: str = DEFAULT_NLP_HESSIAN,
                    cop_sole_fraction: float | None = None,
                    inactive_rows: str = DEFAULT_INACTIVE_ROWS) -> PlannerOptions:
    """The `PlannerOptions` of the command line (both paths; `search_planner_options` drops
    what `--search` does not take)."""
    return PlannerOptions(mu=mu, print_level=5 if verbose else 0, servo_settings=servo_settings,
                          derivatives=solver, half_cycle_mirror=mirror,
                          half_cycle_solve=half_cycle,
                          normal_force_rate_weights_per_t0=shaped.rate_bound,
                          weights=shaped.weights, rotor_reserve=rotor_reserve,
                          swing_clearance_m=swing_clearance,
                          line_capture_margin_leg_lengths=line_capture_margin,
                          nlp_hessian=nlp_hessian, inactive_rows=inactive_rows,
                          cop_sole_fraction=(COP_SOLE_FRACTION if cop_sole_fraction is None
                                             else cop_sole_fraction))


def template_half_cycle(given: bool | None) -> bool:
    """`PlannerOptions.half_cycle_solve` of the template path: `--half-cycle/--full-cycle` as
    given, else `DEFAULT_HALF_CYCLE_SOLVE` (on)."""
    return DEFAULT_HALF_CYCLE_SOLVE if given is None else given


def search_final_half_cycle(given: bool | None) -> bool:
    """`search_gait(final_half_cycle=)` of `--search`: `--half-cycle/--full-cycle` as given,
    else `planner.search.defaults.FINAL_HALF_CYCLE` (on since session 40, with a candidate that
    fails the final check narrowly re-solved on all knots, `FINAL_RETRY_FULL`; the coarse solves
    have their own `--search-half-cycle`)."""
    return FINAL_HALF_CYCLE if given is None else given


def search_planner_options(options: PlannerOptions) -> PlannerOptions:
    """`options` without the template path's own: IPOPT's live log (the search solves many
    NLPs in workers), identified servos and --mirror (both refused with --search)."""
    return replace(options, print_level=0, servo_settings=None, half_cycle_mirror=False)


def gait_metadata(supply_v: float | None, servo_params_path: Path | None,
                  shaped: StanceShaped) -> dict[str, Any] | None:
    """The gait file's planner metadata from the options (both paths; None: nothing to add):
    the supply voltage, the identified servos' file, the stance-compliance record and the entry
    cycles beyond the one every gait has."""
    meta: dict[str, Any] = {}
    if supply_v is not None:
        meta["supply_v"] = supply_v
    if servo_params_path is not None:
        meta["servo_params"] = str(servo_params_path)
    if shaped.metadata:
        meta[STANCE_COMPLIANCE_KEY] = shaped.metadata
    if shaped.entry is not None and shaped.entry > 1:
        meta[ENTRY_CYCLES_KEY] = shaped.entry
    return meta or None

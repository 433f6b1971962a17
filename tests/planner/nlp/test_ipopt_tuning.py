"""IPOPT's tuned options and warm start (`planner.nlp.spacetime.ipopt_options`, issue #16).

The tuning changes how a warm start is pushed off its bounds, so it must reach the optimum the
session-21 options reach, and a warm start after a changed contact pattern must not take more
iterations than a cold start of the same schedule (docs/results/planner_speed_ipopt.md).
"""

from __future__ import annotations

import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.spacetime import GaitPlanner, ipopt_options
from planner.templates import make_schedule

N_KNOTS = 16
SAME_COST_RTOL = 1e-4


def _changed_trot(robot: robots.Robot) -> tuple[robots.ContactSchedule, robots.ContactSchedule]:
    """quad12's trot and a perturbed one (phases, duty, period) whose contact pattern differs
    at N_KNOTS knots: the warm-start situation of basin-CMA's inner loop."""
    base = make_schedule(robot, "trot")
    phases = tuple((p + d) % 1.0 for p, d in zip(base.touchdown_phase, (0.03, -0.02, 0.02, -0.03),
                                                 strict=True))
    duty = tuple(min(0.95, d + 0.03) for d in base.duty_factor)
    changed = robots.ContactSchedule(base.period_s * 1.03, base.feet, phases, duty)
    return base, changed


def test_tunings_differ_only_in_the_warm_start() -> None:
    tuned, before = PlannerOptions(), PlannerOptions(ipopt_tuning="session21")
    assert ipopt_options(tuned, warm=False) == ipopt_options(before, warm=False)
    assert ipopt_options(before, warm=True) == ipopt_options(before, warm=False)
    warm, old = ipopt_options(tuned, warm=True), ipopt_options(before, warm=True)
    pushes = ("warm_start_bound_push", "warm_start_slack_bound_push", "warm_start_mult_bound_push")
    assert all(warm[k] > old[k] for k in pushes)
    with pytest.raises(PlannerConfigError, match="ipopt_tuning"):
        PlannerOptions(ipopt_tuning="fast")


@pytest.mark.slow
def test_tuned_warm_start_reaches_the_same_optimum_in_fewer_iterations_than_cold() -> None:
    robot = robots.load("quad12")
    base, changed = _changed_trot(robot)
    assert (base.contact_matrix(N_KNOTS) != changed.contact_matrix(N_KNOTS)).any()
    # measured with the swing wrench by rows (docs/results/planner_speed_ipopt.md): cold 20
    # iterations, tuned warm 18, session-21 warm 24; costs within 1e-5 relative. With "bounds"
    # (the default since session 42) this cold solve takes 13 and the tuned warm one 15
    # (planner_speed_coldstart.md, session 42)
    tuned = GaitPlanner(robot, N_KNOTS, PlannerOptions(swing_wrench="rows"))
    before = GaitPlanner(robot, N_KNOTS, PlannerOptions(ipopt_tuning="session21",
                                                        swing_wrench="rows"))
    start = tuned.solve(base, 0.25, warm_start=False)
    assert start.feasible, start.message
    cold = tuned.solve(changed, 0.25, warm_start=False)
    old_cold = before.solve(changed, 0.25, warm_start=False)
    warm = tuned.solve(changed, 0.25, warm_start=start.warm_start)
    old_warm = before.solve(changed, 0.25, warm_start=start.warm_start)
    assert cold.feasible and warm.feasible and old_warm.feasible
    assert warm.optimal, warm.message
    # cold solves use the same options under both tunings
    assert cold.iterations == old_cold.iterations and cold.cost == pytest.approx(old_cold.cost,
                                                                                 rel=1e-9)
    for other in (cold, old_warm):
        assert warm.cost <= other.cost * (1 + SAME_COST_RTOL), (warm.cost, other.cost)
    assert warm.iterations <= cold.iterations, (warm.iterations, cold.iterations)
    assert warm.iterations < old_warm.iterations, (warm.iterations, old_warm.iterations)


def test_ipopt_extra_sets_options_on_cold_and_warm_solves_alike() -> None:
    plain = PlannerOptions()
    extra = PlannerOptions(ipopt_extra=(("alpha_for_y", "dual-and-full"),
                                        ("first_hessian_perturbation", 1e-6)))
    for warm in (False, True):
        got, want = ipopt_options(extra, warm), ipopt_options(plain, warm)
        assert got.pop("alpha_for_y") == "dual-and-full"
        assert got.pop("first_hessian_perturbation") == 1e-6
        assert got == want  # nothing else moved
    # an option the tuning sets is replaced, not duplicated
    assert ipopt_options(PlannerOptions(ipopt_extra=(("mu_init", 0.1),)), False)["mu_init"] == 0.1


@pytest.mark.parametrize("extra", [
    (("tol", 1e-4),),  # `PlannerOptions.tol`'s
    (("warm_start_init_point", "no"),),  # the planner's plumbing
    (("max_iter", 10),),
    (("alpha_for_y", "full"), ("alpha_for_y", "primal")),  # twice
    (("mu_init", float("nan")),),
    (("honor_original_bounds", True),),  # a bool is not an IPOPT value
    [("mu_init", 0.1)],  # not a tuple
    (("mu_init",),),
])
def test_ipopt_extra_refuses_what_it_must_not_set(extra: object) -> None:
    with pytest.raises(PlannerConfigError, match="ipopt_extra"):
        PlannerOptions(ipopt_extra=extra)  # type: ignore[arg-type]


def test_ipopt_extra_warm_only_names_reach_warm_solves_only() -> None:
    options = PlannerOptions(ipopt_extra=(("warm:corrector_type", "affine"),
                                          ("alpha_for_y", "primal-and-full")))
    cold, warm = ipopt_options(options, False), ipopt_options(options, True)
    assert "corrector_type" not in cold and warm["corrector_type"] == "affine"
    assert cold["alpha_for_y"] == warm["alpha_for_y"] == "primal-and-full"
    assert not any(k.startswith("warm:") for k in (*cold, *warm))
    with pytest.raises(PlannerConfigError, match="ipopt_extra"):  # one option set twice
        PlannerOptions(ipopt_extra=(("warm:mu_init", 0.1), ("mu_init", 0.1)))
    with pytest.raises(PlannerConfigError, match="ipopt_extra"):
        PlannerOptions(ipopt_extra=(("warm:max_iter", 3),))


@pytest.mark.parametrize(("name", "default", "ipopts", "max_moved"), [
    # refinement only when IPOPT's residual test asks; the bar: 1 of 35 schedules moved by 1
    ("min_refinement_steps", 0, 1, 1),
    # no residual check at all; the bar: 3 of 36 converged schedules moved by 1–2
    ("fast_step_computation", "yes", "no", 2),
])
def test_linear_solve_defaults_keep_the_iterations_and_the_optimum(
    name: str, default: int | str, ipopts: int | str, max_moved: int
) -> None:
    """The planner's defaults for IPOPT's linear solves (`spacetime.MIN_REFINEMENT_STEPS`,
    `spacetime.FAST_STEP_COMPUTATION`) against IPOPT's own: the same optimum in as many
    iterations (± `max_moved`) on a cold and a warm solve (docs/results/planner_speed_rows.md,
    sessions 44 and 45)."""
    robot = robots.load("quad12")
    base, changed = _changed_trot(robot)
    assert ipopt_options(PlannerOptions(), False)[name] == default
    assert ipopt_options(PlannerOptions(), True)[name] == default
    results = {}
    for value in (default, ipopts):
        options = PlannerOptions(ipopt_extra=((name, value),))
        assert ipopt_options(options, False)[name] == value
        planner = GaitPlanner(robot, N_KNOTS, options, background_compile=False)
        cold = planner.solve(base, 0.25, warm_start=False)
        results[value] = (cold, planner.solve(changed, 0.25))
    for ours, theirs in zip(results[default], results[ipopts], strict=True):
        assert ours.feasible and theirs.feasible
        assert abs(ours.iterations - theirs.iterations) <= max_moved
        assert ours.cost == pytest.approx(theirs.cost, rel=SAME_COST_RTOL / 10)

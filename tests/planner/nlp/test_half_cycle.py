"""The half-cycle solve (`planner.nlp.half_cycle`, `PlannerOptions.half_cycle_solve`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import pytest

import robots
from planner.nlp import half_cycle as hc
from planner.nlp.config import PlannerOptions
from planner.nlp.metadata import planner_metadata
from planner.nlp.spacetime import GaitPlanner
from planner.nlp.variables import initial_guess, parameter_vector
from planner.templates import make_schedule, mirror_permutation
from tests.planner.robot_factory import quad12_with_torso_inertial

SPEED_M_S = 0.25
ZOO = Path(__file__).resolve().parents[2] / "zoo"


@pytest.fixture(scope="module")
def quad12_pair() -> tuple[GaitPlanner, GaitPlanner]:
    robot = robots.load("quad12")
    options = PlannerOptions(max_iter=60, half_cycle_solve=False)  # the full NLP, asked for
    return (GaitPlanner(robot, 12, options),
            GaitPlanner(robot, 12, dataclasses.replace(options, half_cycle_solve=True)))


def test_the_mirror_map_reproduces_a_symmetric_start_and_flags_an_asymmetric_one() -> None:
    robot = robots.load("quad12")
    planner = GaitPlanner(robot, 12, PlannerOptions())
    mirror = hc.robot_variable_mirror(robot, planner.layout, planner.model.flat_feet)
    assert mirror is not None and mirror.n_reduced * 2 == planner.layout.size
    x0 = initial_guess(planner.layout, planner.model, make_schedule(robot, "trot"))
    assert mirror.on_subspace(x0)
    assert not mirror.on_subspace(initial_guess(planner.layout, planner.model,
                                                make_schedule(robot, "bound")))
    lbx, ubx = planner._lbx, planner._ubx
    assert mirror.bounds_mirrored(lbx, ubx)
    skewed = ubx.copy()
    skewed[planner.layout.indices("q")[-1, 0]] += 0.1  # a joint bound at the last knot only
    assert not mirror.bounds_mirrored(lbx, skewed)
    # E is an involution's half: expanding the first half of E·x̃ gives E·x̃ again
    x = mirror.expand(np.random.default_rng(0).standard_normal(mirror.n_reduced))
    assert np.array_equal(mirror.expand(x[mirror.half]), x)


@pytest.mark.parametrize("gait", ["trot", "pace"])
def test_a_symmetric_schedule_takes_the_full_solves_iterates(
        quad12_pair: tuple[GaitPlanner, GaitPlanner], gait: str) -> None:
    full, half = quad12_pair
    schedule = make_schedule(full.robot, gait)
    a = full.solve(schedule, SPEED_M_S, warm_start=False)
    b = half.solve(schedule, SPEED_M_S, warm_start=False)
    assert a.stats["half_cycle"] is False and b.stats["half_cycle"] is True
    assert a.feasible and b.feasible
    assert b.iterations == a.iterations
    assert abs(b.cost - a.cost) <= 1e-9 * abs(a.cost)
    assert np.abs(b.warm_start.x - a.warm_start.x).max() <= 1e-6
    # the reduced result is judged on every row of the full NLP
    assert b.max_violation <= 1e-6


def test_one_solve_asks_for_the_other_path_than_its_options(
        quad12_pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """`solve(half_cycle=)` overrides `PlannerOptions.half_cycle_solve` for that solve (the
    search's final phase solves its templates as the template path does, its candidates full):
    the same plans as the planner built with the other option, bit for bit."""
    full, half = quad12_pair
    schedule = make_schedule(full.robot, "trot")
    a = full.solve(schedule, SPEED_M_S, warm_start=False, half_cycle=True)
    b = half.solve(schedule, SPEED_M_S, warm_start=False)
    assert a.stats["half_cycle"] is True and a.cost == b.cost
    assert np.array_equal(a.warm_start.x, b.warm_start.x)
    c = half.solve(schedule, SPEED_M_S, warm_start=False, half_cycle=False)
    d = full.solve(schedule, SPEED_M_S, warm_start=False)
    assert c.stats["half_cycle"] is False and c.cost == d.cost
    assert np.array_equal(c.warm_start.x, d.warm_start.x)


def test_what_is_not_symmetric_is_solved_on_the_full_nlp(
        quad12_pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    _, half = quad12_pair
    robot = half.robot
    bound = half.solve(make_schedule(robot, "bound"), SPEED_M_S, warm_start=False)
    assert bound.stats["half_cycle"] is False
    turn = half.solve(make_schedule(robot, "trot"), SPEED_M_S, warm_start=False,
                      yaw_rate_rad_s=0.2)
    assert turn.stats["half_cycle"] is False
    trot = half.solve(make_schedule(robot, "trot"), SPEED_M_S, warm_start=False)
    assert trot.stats["half_cycle"] is True
    # a warm start off the subspace (the turning plan) → the full NLP
    warm = half.solve(make_schedule(robot, "trot"), SPEED_M_S, warm_start=turn.warm_start)
    assert warm.stats["half_cycle"] is False


def test_a_whole_cycle_row_is_dropped_kept_or_halved_by_its_mirror_image(
        quad12_pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    _, half = quad12_pair
    half.solve(make_schedule(half.robot, "trot"), SPEED_M_S, warm_start=False)
    nlp = half._half_cycle
    assert isinstance(nlp, hc.HalfCycleNLP)
    drift = dict(half._slices)["drift"]
    kept = [int(r) for r in nlp.rows.keep if drift.start <= r < drift.stop]
    # the forward drift (its own image) stays with weight ½; the sideways one vanishes
    assert kept == [drift.start]
    assert nlp.rows.weight[list(nlp.rows.keep).index(drift.start)] == 0.5
    per_knot = nlp.rows.keep.size - 1
    assert per_knot * 2 == drift.start  # half of every per-knot row


def _reduced_trot(half: GaitPlanner) -> tuple[robots.ContactSchedule, hc.HalfCycleNLP]:
    """The trot and the reduced NLP a half-cycle solve of it built."""
    schedule = make_schedule(half.robot, "trot")
    half.solve(schedule, SPEED_M_S, warm_start=False)
    nlp = half._half_cycle
    assert isinstance(nlp, hc.HalfCycleNLP)
    return schedule, nlp


def test_the_reduced_derivatives_match_finite_differences(
        quad12_pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    _, half = quad12_pair
    schedule, nlp = _reduced_trot(half)
    m, rows = nlp.mirror, nlp.rows
    p = parameter_vector(schedule, half.n_knots, SPEED_M_S, half.swing_clearance_m)
    rng = np.random.default_rng(1)
    x = initial_guess(half.layout, half.model, schedule)[m.half] + 0.01 * rng.standard_normal(
        m.n_reduced)
    full = ca.Function("full", [half._nlp["x"], half._nlp["p"]], [half._nlp["f"], half._nlp["g"]])

    def reduced(xr: np.ndarray) -> tuple[float, np.ndarray]:
        f, g = full(m.expand(xr), p)
        return 0.5 * float(f), np.asarray(g).ravel()[rows.keep] * rows.weight

    g_r, jac = nlp.solver.get_function("nlp_jac_g")(x, p)
    jac = np.asarray(ca.densify(jac))
    assert np.allclose(np.asarray(g_r).ravel(), reduced(x)[1], atol=1e-12)
    lam = rng.standard_normal(rows.keep.size)
    hess = np.asarray(ca.densify(nlp.solver.get_function("nlp_hess_l")(x, p, 1.0, lam)))
    hess = np.triu(hess) + np.triu(hess, 1).T
    grad_f = ca.Function("gf", [half._nlp["x"], half._nlp["p"]],
                         [ca.gradient(half._nlp["f"], half._nlp["x"])])
    e = np.asarray(ca.densify(m.matrix()))

    def grad_lagrangian(xr: np.ndarray) -> np.ndarray:
        _, j = nlp.solver.get_function("nlp_jac_g")(xr, p)
        gf = 0.5 * e.T @ np.asarray(grad_f(m.expand(xr), p)).ravel()
        return gf + np.asarray(ca.densify(j)).T @ lam

    eps = 1e-6
    for col in rng.choice(m.n_reduced, 12, replace=False):
        d = np.zeros(m.n_reduced)
        d[col] = eps
        fd_jac = (reduced(x + d)[1] - reduced(x - d)[1]) / (2 * eps)
        assert np.abs(fd_jac - jac[:, col]).max() <= 1e-5 * max(1.0, np.abs(jac[:, col]).max())
        fd_hess = (grad_lagrangian(x + d) - grad_lagrangian(x - d)) / (2 * eps)
        assert np.abs(fd_hess - hess[:, col]).max() <= 1e-5 * max(1.0, np.abs(hess[:, col]).max())


def test_flat_feet_reach_the_full_optimum() -> None:
    robot = robots.load("biped")
    options = PlannerOptions(max_iter=100, half_cycle_solve=False)
    schedule = make_schedule(robot, "biped_walk")
    a = GaitPlanner(robot, 12, options).solve(schedule, 0.15, warm_start=False)
    b = GaitPlanner(robot, 12, dataclasses.replace(options, half_cycle_solve=True)).solve(
        schedule, 0.15, warm_start=False)
    assert a.stats["half_cycle"] is False and b.stats["half_cycle"] is True
    assert a.feasible and b.feasible
    assert abs(b.cost - a.cost) <= 1e-5 * abs(a.cost)


def test_a_body_without_mirror_images_has_no_half_cycle() -> None:
    robot = robots.load("quad12")
    assert mirror_permutation(robot) is not None
    layout = GaitPlanner(robot, 12, PlannerOptions()).layout
    odd = dataclasses.replace(layout, n_knots=13)
    assert hc.robot_variable_mirror(robot, odd, ()) is None


def test_ctrl_c_inside_a_half_cycle_solve_raises_keyboard_interrupt(
        quad12_pair: tuple[GaitPlanner, GaitPlanner], ctrl_c_during: Any) -> None:
    """As the full NLP's (tests/gaitsmith/test_plan_interrupt.py): an interrupted reduced solve
    is a KeyboardInterrupt, not an infeasible result."""
    import signal

    _, half = quad12_pair
    schedule = make_schedule(half.robot, "trot")
    half.solve(schedule, SPEED_M_S, warm_start=False)  # builds the reduced NLP
    nlp = half._half_cycle
    assert isinstance(nlp, hc.HalfCycleNLP)
    solver = nlp.solver

    class Interrupted:
        def __call__(self, **kwargs: Any) -> Any:
            return ctrl_c_during(solver, 0.02, **kwargs)

        def stats(self) -> Any:
            return solver.stats()

    nlp.solver = Interrupted()
    try:
        with pytest.raises(KeyboardInterrupt):
            half.solve(schedule, SPEED_M_S, warm_start=False)
    finally:
        nlp.solver = solver
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert half.solve(schedule, SPEED_M_S, warm_start=False).stats["half_cycle"] is True


def test_the_iteration_abort_stops_a_half_cycle_solve_on_the_full_solves_iterates(
        quad12_pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    from planner.nlp.iteration_abort import StallAbort

    full, half = quad12_pair
    schedule = make_schedule(half.robot, "trot")
    ref = full.solve(schedule, SPEED_M_S, warm_start=False).stats["iterations"]
    half.set_iteration_abort(StallAbort(after_iter=3, min_violation=0.0, window=1,
                                        fall_factor=0.0))
    try:
        stopped = half.solve(schedule, SPEED_M_S, warm_start=False)
        assert stopped.stats["half_cycle"] is True and half.last_solve_aborted
        assert stopped.status == "User_Requested_Stop" and stopped.iterations == 3
        log = stopped.stats["iterations"]
        # the same path to the linear solves' accuracy: with refinement on demand
        # (`spacetime.MIN_REFINEMENT_STEPS`) the two KKT systems' solves agree to ≈ 1e-7
        np.testing.assert_allclose(log["inf_pr"], ref["inf_pr"][:4], rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(log["obj"], ref["obj"][:4], rtol=1e-6)
    finally:
        half.set_iteration_abort(None)
    again = half.solve(schedule, SPEED_M_S, warm_start=False)
    assert again.stats["half_cycle"] is True and not half.last_solve_aborted
    assert again.iterations == len(ref["obj"]) - 1


def _called(function: ca.Function) -> list[str]:
    """The functions `function` calls, and those they call (MX functions, recursively)."""
    out = []
    for k in range(function.n_instructions()):
        if function.instruction_id(k) == ca.OP_CALL:
            called = function.instruction_MX(k).which_function()
            out.append(called.name())
            if called.is_a("MXFunction"):
                out += _called(called)
    return out


def test_the_reduced_nlp_evaluates_the_knots_its_rows_read_with_the_same_values(
        quad12_pair: tuple[GaitPlanner, GaitPlanner]) -> None:
    """f̃, g̃, J̃ and ∇²L̃ from the knots the kept rows read (the first half and knot N/2) equal
    those from the full NLP's J and H on all N knots (the construction without `knot_terms`)."""
    _, half = quad12_pair
    schedule, nlp = _reduced_trot(half)
    m, rows = nlp.mirror, nlp.rows
    args = (m, rows, half._nlp["x"], half._nlp["p"], half._nlp["f"], half._nlp["g"],
            half._jac_g, half._hess_l)
    built = {"all": hc.reduced_nlp(*args), "read": hc.reduced_nlp(*args, half._knot_terms, 12)}
    functions = {
        name: (ca.Function("fg", [e["x"], e["p"]], [e["f"], e["g"]]), d["jac_g"], d["hess_lag"])
        for name, (e, d) in built.items()
    }
    # 7 of 12 knots: the first half's rows read knots 0…5 and the stance no-slip rows knot 6
    # (the knot, its J and H; compiled ones are named gaitsmith_J_…, gaitsmith_H_…)
    def knot_maps(fn: ca.Function) -> list[str]:
        return [c for c in _called(fn) if "knot" in c or "gaitsmith_" in c]

    for fn in functions["read"]:
        assert knot_maps(fn) and all(c.startswith("map7_") for c in knot_maps(fn))
    assert knot_maps(functions["all"][2])
    assert all(c.startswith("map12_") for c in knot_maps(functions["all"][2]))
    p = parameter_vector(schedule, half.n_knots, SPEED_M_S, half.swing_clearance_m)
    rng = np.random.default_rng(2)
    x0 = initial_guess(half.layout, half.model, schedule)[m.half]
    for _ in range(2):
        x = x0 + 0.05 * rng.standard_normal(m.n_reduced)
        lam = rng.standard_normal(rows.keep.size)
        values = {}
        for name, (fg, jac, hess) in functions.items():
            values[name] = [*fg(x, p), *jac(x, p), hess(x, p, 0.7, lam)]
        for a, b in zip(values["all"], values["read"], strict=True):
            assert a.sparsity() == b.sparsity()
            np.testing.assert_allclose(np.asarray(b.nonzeros()), np.asarray(a.nonzeros()),
                                       rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("option", [{"nlp_jacobian": "ad"}, {"nlp_hessian": "ad"}])
def test_the_half_cycle_solve_with_casadis_own_derivatives(option: dict[str, Any]) -> None:
    """Without the assembled Jacobian (its rows over the whole cycle are then classified with
    CasADi's AD Jacobian) or Hessian the reduced NLP takes the full solve's iterates too."""
    robot = robots.load("quad12")
    options = dataclasses.replace(PlannerOptions(max_iter=60, half_cycle_solve=False), **option)
    schedule = make_schedule(robot, "trot")
    a = GaitPlanner(robot, 12, options).solve(schedule, SPEED_M_S, warm_start=False)
    b = GaitPlanner(robot, 12, dataclasses.replace(options, half_cycle_solve=True)).solve(
        schedule, SPEED_M_S, warm_start=False)
    assert a.stats["half_cycle"] is False and b.stats["half_cycle"] is True
    assert a.feasible and b.feasible
    assert b.iterations == a.iterations
    assert abs(b.cost - a.cost) <= 1e-9 * abs(a.cost)


def _tilted_torso_quad12(folder: Path) -> robots.Robot:
    """quad12 whose torso inertia has products the mirror image y → −y does not have (its
    principal axes turned 0.6 rad about x): joints and feet still mirror, the dynamics do not."""
    return robots.load(quad12_with_torso_inertial(folder, "tilted", inertia_turn_x_rad=0.6))


def _mirror_defect(planner: GaitPlanner, gait: str) -> hc.MirrorDefect:
    """`nlp_mirror_defect` of `planner`'s NLP at the probe `_build_half_cycle` uses."""
    robot = planner.robot
    mirror = hc.robot_variable_mirror(robot, planner.layout, planner.model.flat_feet)
    assert mirror is not None
    schedule = make_schedule(robot, gait)
    p = parameter_vector(schedule, planner.n_knots, SPEED_M_S, planner.swing_clearance_m)
    x0 = initial_guess(planner.layout, planner.model, schedule)
    f_and_g = ca.Function("f_and_g", [planner._nlp["x"], planner._nlp["p"]],
                          [planner._nlp["f"], planner._nlp["g"]])
    return hc.nlp_mirror_defect(f_and_g, mirror, hc.probe_point(x0, planner._lbx, planner._ubx),
                                p, planner._slices)


def test_the_full_mirror_map_is_an_involution_that_fixes_the_subspace() -> None:
    robot = robots.load("quad12")
    planner = GaitPlanner(robot, 12, PlannerOptions())
    mirror = hc.robot_variable_mirror(robot, planner.layout, planner.model.flat_feet)
    assert mirror is not None
    image, sign = hc.mirror_involution(mirror)
    assert np.array_equal(np.sort(image), np.arange(image.size))  # a permutation
    x = np.random.default_rng(1).standard_normal(image.size)
    assert np.array_equal(sign * (sign * x[image])[image], x)
    assert not np.array_equal(sign * x[image], x)
    on = mirror.expand(x[mirror.half])
    assert np.array_equal(sign * on[image], on)


@pytest.mark.parametrize(("name", "gait"), [
    ("quad12", "trot"), ("hex18", "tripod"), ("biped", "biped_walk"),
    (str(ZOO / "spotmicro"), "trot"), (str(ZOO / "phantomx18"), "tripod")])
def test_a_symmetric_body_s_nlp_is_its_own_mirror_image(name: str, gait: str) -> None:
    defect = _mirror_defect(GaitPlanner(robots.load(name), 12, PlannerOptions()), gait)
    assert defect.symmetric and defect.defect <= 1e-14


def test_a_tilted_inertia_makes_the_dynamics_rows_asymmetric(tmp_path: Path) -> None:
    robot = _tilted_torso_quad12(tmp_path / "tilted")
    defect = _mirror_defect(GaitPlanner(robot, 12, PlannerOptions()), "trot")
    assert defect.rows == "dynamics" and defect.defect > 10 * hc.MIRROR_DEFECT_TOL
    assert not defect.symmetric


def test_a_body_whose_nlp_does_not_mirror_is_solved_in_full_without_a_half_cycle_try(
        tmp_path: Path) -> None:
    """Joints and feet mirror, the torso's inertia does not: the probe finds it before any
    half-cycle solve is spent, the plan is the full planner's bit for bit, and the plan and the
    gait file say why the half-cycle solve was not used."""
    robot = _tilted_torso_quad12(tmp_path / "tilted")
    planner = GaitPlanner(robot, 12, PlannerOptions(max_iter=80))
    schedule = make_schedule(robot, "trot")
    result = planner.solve(schedule, SPEED_M_S, warm_start=False)
    assert result.feasible and result.stats["half_cycle"] is False
    assert "half_cycle_fallback" not in result.stats
    assert planner.half_cycle_asymmetry is not None
    assert result.stats["half_cycle_asymmetry"]["rows"] == "dynamics"
    full = GaitPlanner(robot, 12, PlannerOptions(max_iter=80, half_cycle_solve=False)).solve(
        schedule, SPEED_M_S, warm_start=False)
    assert result.cost == full.cost and np.array_equal(result.warm_start.x, full.warm_start.x)
    assert "half_cycle_asymmetry" not in full.stats  # never probed: no half-cycle solve asked
    solver = planner_metadata(planner, result)["solver"]
    assert solver["half_cycle_asymmetry"] == result.stats["half_cycle_asymmetry"]


def test_a_body_whose_dynamics_do_not_mirror_falls_back_to_the_full_nlp(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Joints and feet mirror, the torso's inertia does not, and the probe is blinded (an
    asymmetry it cannot see): the reduced NLP converges to a point the full NLP's dynamics rows
    reject. The solve falls back to the full NLP (a feasible plan, not "no feasible gait"),
    says so, and the planner solves it in full from then on."""
    monkeypatch.setattr(hc, "MIRROR_DEFECT_TOL", np.inf)
    robot = _tilted_torso_quad12(tmp_path / "tilted")
    planner = GaitPlanner(robot, 12, PlannerOptions(max_iter=80))
    schedule = make_schedule(robot, "trot")
    first = planner.solve(schedule, SPEED_M_S, warm_start=False)
    assert first.feasible and first.stats["half_cycle"] is False
    fallback = first.stats["half_cycle_fallback"]
    assert fallback["max_violation"] > 1e-4 and fallback["iterations"] > 0
    assert first.solve_time_s >= fallback["solve_time_s"]
    full = GaitPlanner(robot, 12, PlannerOptions(max_iter=80, half_cycle_solve=False)).solve(
        schedule, SPEED_M_S, warm_start=False)
    assert first.cost == full.cost and np.array_equal(first.warm_start.x, full.warm_start.x)
    solver = planner_metadata(planner, first)["solver"]
    assert solver["half_cycle"] is False
    assert solver["half_cycle_dropped_violation"] == fallback["max_violation"]
    again = planner.solve(schedule, SPEED_M_S, warm_start=False)
    assert again.stats["half_cycle"] is False and "half_cycle_fallback" not in again.stats
    assert "half_cycle_dropped_violation" not in planner_metadata(planner, again)["solver"]


def test_a_half_cycle_solve_builds_no_full_nlp_solver_and_plans_the_same() -> None:
    """The full NLP's assembled J, ∇²L and IPOPT instance are built at their first use
    (`GaitPlanner._solver`): a half-cycle solve needs none of them (its whole-cycle rows are
    classified with their own Jacobian), and plans bit for bit as a planner that built them
    first; a full solve later builds them and its time joins `build_time_s`."""
    robot = robots.load("quad12")
    schedule = make_schedule(robot, "trot")
    lazy = GaitPlanner(robot, 12, PlannerOptions(max_iter=60))
    eager = GaitPlanner(robot, 12, PlannerOptions(max_iter=60))
    assert lazy._solver_instance is None and lazy._jac_g_fn is None and lazy._hess_l_fn is None
    assert eager._solver is not None  # built now, before the half-cycle NLP
    a = lazy.solve(schedule, SPEED_M_S, warm_start=False)
    b = eager.solve(schedule, SPEED_M_S, warm_start=False)
    assert a.stats["half_cycle"] is True and b.stats["half_cycle"] is True
    assert lazy._solver_instance is None and lazy._jac_g_fn is None and lazy._hess_l_fn is None
    assert a.iterations == b.iterations and a.cost == b.cost
    assert np.array_equal(a.warm_start.x, b.warm_start.x)
    half_a, half_b = lazy._half_cycle, eager._half_cycle
    assert isinstance(half_a, hc.HalfCycleNLP) and isinstance(half_b, hc.HalfCycleNLP)
    assert np.array_equal(half_a.rows.keep, half_b.rows.keep)
    assert np.array_equal(half_a.rows.weight, half_b.rows.weight)
    built = lazy.build_time_s
    c = lazy.solve(schedule, SPEED_M_S, warm_start=False, half_cycle=False)
    d = eager.solve(schedule, SPEED_M_S, warm_start=False, half_cycle=False)
    assert lazy._solver_instance is not None and lazy.build_time_s > built
    assert c.iterations == d.iterations and c.cost == d.cost
    assert np.array_equal(c.warm_start.x, d.warm_start.x)

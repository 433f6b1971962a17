"""PlannerOptions.rotor_reserve: the torque–speed envelope also holds for τ + ρ·I_a·q̈ (the
knot torque with the servo rotor's share taken 1 + ρ times), docs/results/heavy_rotor.md."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import robots
from planner.errors import PlannerConfigError
from planner.nlp.config import PlannerOptions
from planner.nlp.constraints import KnotQuantities, _rotor_reserve_groups, group_labels
from planner.nlp.model import RobotModel
from planner.nlp.spacetime import GaitPlanner
from planner.templates import make_schedule
from tests.planner.nlp.jacobian_pair import assembled_matches_ad, constraint_rows


def test_option_validated() -> None:
    assert PlannerOptions(rotor_reserve=0.15).rotor_reserve == 0.15
    for bad in (-0.1, 2.5, math.inf, math.nan):
        with pytest.raises(PlannerConfigError, match="rotor_reserve"):
            PlannerOptions(rotor_reserve=bad)


def _quantities(nj: int, n: int, rng: np.random.Generator) -> tuple[KnotQuantities, np.ndarray,
                                                                    np.ndarray, np.ndarray]:
    tau, qd, qdd = (rng.normal(size=(nj, n)) for _ in range(3))
    kq = KnotQuantities(None, ca.DM(tau), None, None, None, ca.DM(qd), ca.DM(qdd), None, None)
    return kq, tau, qd, qdd


def test_rows_are_the_envelope_of_the_torque_with_the_rotor_share_grown() -> None:
    """Four faces ±τ'/(m·τ_stall) ± q̇/ω₀ ≤ 1 with τ' = τ + ρ·I_a·q̈, per joint and knot."""
    robot = robots.load("quad12")
    model, n, rho = RobotModel(robot), 5, 0.3
    nj = model.n_joints
    kq, tau, qd, qdd = _quantities(nj, n, np.random.default_rng(1))
    stall = np.array([j.servo.stall_torque_nm for j in robot.joints])
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in robot.joints])
    qd_n = qd / omega0[:, None]
    options = PlannerOptions(rotor_reserve=rho, compact_rows=())
    (group,) = _rotor_reserve_groups(model, kq, n, options, ca.DM(stall), ca.DM(qd_n))
    assert group.name == "rotor reserve"
    arm = np.asarray(model.armature[6:])
    assert np.all(arm > 0)
    tau_n = (tau + rho * arm[:, None] * qdd) / (stall[:, None] * options.torque_margin)
    want = np.concatenate([(s * tau_n + v * qd_n).T.ravel()
                           for s, v in ((1, 1), (1, -1), (-1, 1), (-1, -1))])
    got = np.asarray(ca.DM(group.expr)).ravel()
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert np.all(group.ub == 1) and np.all(group.lb == -np.inf)
    assert len(group_labels(model, n)["rotor reserve"]) == got.size
    # the same diamond as two ranged rows (`PlannerOptions.compact_rows` "torque envelope")
    ranged = dataclasses.replace(options, compact_rows=("torque envelope",))
    (group,) = _rotor_reserve_groups(model, kq, n, ranged, ca.DM(stall), ca.DM(qd_n))
    np.testing.assert_allclose(np.asarray(ca.DM(group.expr)).ravel(), want[: 2 * nj * n],
                               rtol=1e-12)
    assert np.all(group.ub == 1) and np.all(group.lb == -1)


def test_no_rows_when_off_or_without_armature() -> None:
    robot = robots.load("quad12")
    model, n = RobotModel(robot), 4
    kq, _, qd, _ = _quantities(model.n_joints, n, np.random.default_rng(2))
    stall = ca.DM(np.ones(model.n_joints))
    assert PlannerOptions().rotor_reserve is None
    assert _rotor_reserve_groups(model, kq, n, PlannerOptions(), stall, ca.DM(qd)) == []
    model.armature[6:] = 0.0
    assert _rotor_reserve_groups(model, kq, n, PlannerOptions(rotor_reserve=0.2), stall,
                                 ca.DM(qd)) == []


def test_assembled_jacobian_with_the_rows_is_casadis_own() -> None:
    """The rows through `planner.nlp.assembled_jacobian`: CasADi's AD Jacobian to 1e-10, and
    the NLP has exactly 2·J·N more rows than without them (the diamond's two ranged rows per
    joint and knot, `PlannerOptions.compact_rows`' default)."""
    robot = robots.load("quad12")
    n = 8
    pair = assembled_matches_ad(robot, n, PlannerOptions(rotor_reserve=0.2),
                                make_schedule(robot, "walk"))
    assert pair.ad.shape[0] == constraint_rows(robot, n) + 2 * len(robot.joints) * n


@pytest.mark.parametrize(
    "extra", [["--rotor-reserve", "0"], ["--rotor-reserve", "2.5", "--search"],
              ["--swing-clearance", "0"], ["--swing-clearance", "1", "--search"]],
    ids=["zero", "search-too-big", "clearance-zero", "clearance-search-too-big"],
)
def test_plan_refuses_a_rotor_reserve_it_cannot_use(
    extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`gaitsmith plan --rotor-reserve RHO` (ρ in (0, 2]) and `--swing-clearance M` (metres in
    (0, 1)), with or without --search: anything else is refused before any work (one error
    line, exit 2, no gait file)."""
    from gaitsmith.cli import main

    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "--gait", "trot", "-o", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert extra[0] in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.slow
def test_a_planned_walk_meets_the_reserve_and_records_it() -> None:
    """A 12-knot quad12 walk with ρ = 0.3: every knot's τ + ρ·I_a·q̈ (NLP second differences of
    the planned angles) lies inside the envelope, and the gait file says which ρ it used."""
    bot = robots.load("quad12")
    options = PlannerOptions(rotor_reserve=0.3)
    planner = GaitPlanner(bot, 12, options)
    result = planner.solve(make_schedule(bot, "walk"), 0.1)
    assert result.feasible
    n = 12
    h = result.schedule.period_s / n
    q = result.joint_angles_rad
    qdd = (np.roll(q, -1, 0) - 2 * q + np.roll(q, 1, 0)) / h**2
    qd = (np.roll(q, -1, 0) - np.roll(q, 1, 0)) / (2 * h)
    arm = np.asarray(planner.model.armature[6:])
    stall = np.array([j.servo.stall_torque_nm for j in bot.joints]) * options.torque_margin
    omega0 = np.array([j.servo.no_load_speed_rad_s for j in bot.joints])
    tau = result.joint_torques_nm + 0.3 * arm * qdd
    assert np.all(np.abs(tau) / stall + np.abs(qd) / omega0 <= 1 + 1e-5)
    assert planner.to_gait(result, "walk").planner["rotor_reserve"] == 0.3

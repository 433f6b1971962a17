"""Objective of the spacetime NLP (TOWR-style "costs" module): W&P 2009 eqs 13-16.

Each term is a per-knot sum averaged over the N knots; `CostWeights` documents the weights.

`yaw_moment_mgl2` (ours, issue #14) is the flat soles' contact moment about the vertical, τ_z,
squared. An open-loop biped has nothing but sole friction to hold its heading: in single support
the stance sole must supply the yaw moment that the swinging leg's angular momentum about the
vertical asks for (τ_z = dH_z/dt of the whole body about the sole), and the contact wrench cone
(`planner.nlp.flat_foot`, Caron et al. 2015 eq. 16) only bounds it by µ(X+Y)f_z. The built-in
biped's 0.5 m/s run planned τ_z at up to 62 % of that bound; a gait that needs less of it has
margin left for what the model does not see. Point feet carry no moment: the term is 0 for them.
"""

from __future__ import annotations

from typing import Any

import casadi as ca

from planner.nlp.config import CostWeights
from planner.nlp.constraints import KnotQuantities
from planner.nlp.model import RobotModel
from planner.nlp.variables import Symbols


def cost_terms(model: RobotModel, sym: Symbols, kq: KnotQuantities, n_knots: int) -> dict[str, Any]:
    """Unweighted objective terms (MX scalars), keyed like `CostWeights` fields."""
    stall = ca.DM([j.servo.stall_torque_nm for j in model.robot.joints])
    tau_rel = kq.tau_nm / ca.repmat(stall, 1, n_knots)
    stance = ca.DM(list(model.robot.nominal_stance_rad))
    n = float(n_knots)
    return {
        # eq 13: servo effort Σ(τ/τ_stall)²
        "effort": ca.sumsqr(tau_rel) / n,
        # eq 14: joint speed Σ q̇²
        "joint_speed_s2": ca.sumsqr(kq.qd) / n,
        # eq 15: base velocity perpendicular to the gait velocity (lateral + vertical bounce)
        "bounce_s2_m2": ca.sumsqr(kq.base_d[1:3, :]) / n,
        # eq 16: ‖R − I‖² ≈ 2(roll² + pitch² + yaw²) for small angles (factor 2 in the weight)
        "orientation_rad2": ca.sumsqr(sym.base[3:6, :]) / n,
        "angular_velocity_s2": ca.sumsqr(kq.omega_world) / n,
        "joint_accel_s4": ca.sumsqr(kq.qdd) / n,
        # distance from the stance pose (CostWeights.posture_rad2)
        "posture_rad2": ca.sumsqr(sym.q - ca.repmat(stance, 1, n_knots)) / n,
        # flat soles' yaw moment τ_z² in (m·g·L)² (module docstring; CostWeights.yaw_moment_mgl2)
        "yaw_moment_mgl2": yaw_moment_term(sym, n_knots),
    }


def yaw_moment_term(sym: Symbols, n_knots: int) -> Any:
    """Σ τ_z² of the flat feet's moments (rows 3k+2 of `Symbols.moments`, world frame, units
    of m·g·L) averaged over the knots; a constant 0 without flat feet."""
    if sym.moments is None:
        return ca.MX(0)
    return ca.sumsqr(sym.moments[2::3, :]) / float(n_knots)


def weighted_objective(terms: dict[str, Any], weights: CostWeights) -> Any:
    w = weights.as_dict()
    return sum((w[name] * term for name, term in terms.items()), ca.MX(0))

"""Objective of the spacetime NLP (TOWR-style "costs" module): W&P 2009 eqs 13-16.

Each term is a per-knot sum averaged over the N knots; `CostWeights` documents the weights.
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
    }


def weighted_objective(terms: dict[str, Any], weights: CostWeights) -> Any:
    w = weights.as_dict()
    return sum((w[name] * term for name, term in terms.items()), ca.MX(0))

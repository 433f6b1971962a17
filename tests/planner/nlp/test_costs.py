"""The objective's yaw-moment term: Σ τ_z² of the flat soles' contact moments (issue #14)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, cast

import casadi as ca
import numpy as np
import pytest

from planner.errors import PlannerConfigError
from planner.nlp.config import CostWeights
from planner.nlp.costs import weighted_objective, yaw_moment_term
from planner.nlp.variables import Symbols


def _symbols(moments: Any) -> Symbols:
    return cast(Symbols, SimpleNamespace(moments=moments))


def test_yaw_moment_term_is_the_mean_square_of_the_soles_z_moments() -> None:
    n_knots = 5
    m = ca.MX.sym("m", 6, n_knots)  # two flat feet: (τx, τy, τz) per foot, per knot
    value = ca.Function("f", [m], [yaw_moment_term(_symbols(m), n_knots)])
    rng = np.random.default_rng(3)
    moments = rng.normal(size=(6, n_knots))
    expected = (np.sum(moments[2] ** 2) + np.sum(moments[5] ** 2)) / n_knots
    assert float(value(moments)) == pytest.approx(expected)
    moments[[0, 1, 3, 4]] = 0.0  # roll and pitch moments do not count
    assert float(value(moments)) == pytest.approx(expected)


def test_point_feet_add_no_yaw_moment_and_the_default_weight_is_zero() -> None:
    term = yaw_moment_term(_symbols(None), 7)
    assert float(ca.evalf(term)) == 0.0
    assert CostWeights().yaw_moment_mgl2 == 0.0
    assert "yaw_moment_mgl2" in CostWeights().as_dict()
    terms = {name: ca.MX(1.0) for name in CostWeights().as_dict()}
    with_yaw = CostWeights(yaw_moment_mgl2=5.0)
    assert float(ca.evalf(weighted_objective(terms, with_yaw))) == pytest.approx(
        sum(CostWeights().as_dict().values()) + 5.0)


def test_a_negative_yaw_moment_weight_is_refused() -> None:
    with pytest.raises(PlannerConfigError, match="yaw_moment_mgl2"):
        CostWeights(yaw_moment_mgl2=-1.0)

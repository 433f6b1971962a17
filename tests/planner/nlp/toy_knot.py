"""A small nonlinear 'knot' function and its MX-AD derivatives mapped over knots: the reference
the per-knot derivative tests (`test_solver_paths`, `test_solver_cache_compiled`) compare with."""

from __future__ import annotations

import casadi as ca


def toy_knot() -> ca.Function:
    """Two inputs, two outputs, products and trigonometry (compiles in well under a second)."""
    x, y = ca.SX.sym("x", 4), ca.SX.sym("y", 2)
    out = ca.vertcat(ca.sin(x[0] * x[1]) + y[0] * x[2] ** 3, ca.cos(x[3]) * y[1] * x[0])
    return ca.Function("knot", [x, y], [out, x[1] * y[0] ** 2], ["x", "y"], ["a", "b"])


def mapped_derivatives(knot: ca.Function, n: int) -> ca.Function:
    """Jacobian and Lagrangian Hessian of `knot` mapped over n columns, by MX AD."""
    x, y, lam = ca.MX.sym("X", 4, n), ca.MX.sym("Y", 2, n), ca.MX.sym("L", 3, n)
    a, b = knot.map(n)(x, y)
    v = ca.vertcat(ca.vec(x), ca.vec(y))
    lagrangian = ca.dot(ca.vec(lam[:2, :]), ca.vec(a)) + ca.dot(lam[2, :], b) + ca.sumsqr(a)
    return ca.Function(
        "derivs", [x, y, lam], [ca.jacobian(ca.vertcat(ca.vec(a), ca.vec(b)), v),
                                ca.hessian(lagrangian, v)[0]]
    )

"""benchmarks/kkt_fill_screen.py: the MUMPS log parser and the KKT variants, on a small chain."""

from __future__ import annotations

import numpy as np
import pytest

from tests.benchmarks import load_script

K = 6  # knots of the synthetic chain


@pytest.fixture(scope="module")
def screen():  # type: ignore[no-untyped-def]
    return load_script("kkt_fill_screen")


LOG = """
 RINFOG(1) Operations during elimination (estim)= 1.365D+04
 Elapsed time for factorization                     =      0.0002
 ------ (3) Operations in node elimination          = 1.392D+04
 INFOG  (9) Real space for factors                  =            2009
 INFOG (11) Maximum front size                      =              19
 INFOG (13) Number of delayed pivots                =               2
 Elapsed time in factorization driver               =      0.0004
 Elapsed time for factorization                     =      0.0003
 INFOG  (9) Real space for factors                  =            2010
 Elapsed time in factorization driver               =      0.0005
"""


def test_parse_mumps_log(screen) -> None:  # type: ignore[no-untyped-def]
    log = screen.parse_mumps_log(LOG)
    assert log.factorisations == 2
    assert log.fact_s == (0.0002, 0.0003)
    assert log.fact_driver_s == (0.0004, 0.0005)
    assert log.doubles == (2009, 2010)
    assert log.flops == (13920.0,)
    assert log.flops_est == (13650.0,)
    assert log.front_max == (19,)
    assert log.delayed == (2,)


def _chain(screen):  # type: ignore[no-untyped-def]
    """K knots × (q, tau, qd) of one joint; per knot a cyclic difference row (q_{k+1} − q_k),
    a "servo goal speed" row on q, tau, qd of k and k+1, a "servo goal limits" row on knot k's;
    one row over all knots (drift)."""
    var_knot = np.repeat(np.arange(K), 3)
    kind = np.tile(np.array(["q", "tau", "qd"]), K)
    rows, cols, vals, groups, rknot = [], [], [], [], []
    m = 0

    def var(k: int, v: int) -> int:
        return 3 * (k % K) + v

    for k in range(K):
        rows += [m, m]
        cols += [var(k + 1, 0), var(k, 0)]
        vals += [1.0, -1.0]
        groups.append("differences")
        rknot.append(k)
        m += 1
        for kk, sign in ((k, -1.0), (k + 1, 1.0)):
            rows += [m] * 3
            cols += [var(kk, 0), var(kk, 1), var(kk, 2)]
            vals += [sign, sign * 0.5, sign * 0.1]
        groups.append("servo goal speed")
        rknot.append(k)
        m += 1
        rows += [m] * 3
        cols += [var(k, 0), var(k, 1), var(k, 2)]
        vals += [1.0, 0.5, 0.1]
        groups.append("servo goal limits")
        rknot.append(k)
        m += 1
    rows += [m] * K
    cols += [var(k, 0) for k in range(K)]
    vals += [1.0 / K] * K
    groups.append("drift")
    rknot.append(-1)
    m += 1
    n = 3 * K
    return screen.KKTData(
        n=n, m=m, j_rows=np.asarray(rows), j_cols=np.asarray(cols), j_vals=np.asarray(vals),
        h_rows=np.arange(n), h_cols=np.arange(n), h_vals=np.ones(n), grad=np.zeros(n),
        x0=np.zeros(n), lbx=np.full(n, -np.inf), ubx=np.full(n, np.inf),
        lbg=np.r_[np.zeros(m - 1), -1.0], ubg=np.r_[np.zeros(m - 1), 1.0],
        row_group=np.asarray(groups), row_knot=np.asarray(rknot), var_knot=var_knot,
        n_knots=K, var_kind=kind, var_joint=np.zeros(n, dtype=int))


def _dense(d) -> np.ndarray:  # type: ignore[no-untyped-def]
    a = np.zeros((d.m, d.n))
    a[d.j_rows, d.j_cols] = d.j_vals
    return a


def test_all_knot_rows_and_drop(screen) -> None:  # type: ignore[no-untyped-def]
    d = _chain(screen)
    wide = screen.all_knot_rows(d)
    assert wide.sum() == 1 and d.row_group[wide][0] == "drift"
    dropped = screen.drop_rows(d, d.row_group == "servo goal speed")
    assert dropped.m == d.m - K
    assert "servo goal speed" not in dropped.row_group
    assert dropped.j_rows.max() == dropped.m - 1


def test_open_wrap_and_decoupled(screen) -> None:  # type: ignore[no-untyped-def]
    d = _chain(screen)
    opened = screen.open_wrap(d)
    kr = screen.home_knots(opened)
    for r, c in zip(opened.j_rows, opened.j_cols, strict=True):
        if not screen.all_knot_rows(opened)[r]:
            assert abs(int(opened.var_knot[c]) - int(kr[r])) <= 1
    # knot K−1's difference and speed rows lose their entries on knot 0 (1 + 3)
    assert d.j_rows.size - opened.j_rows.size == 4
    apart = screen.decoupled_knots(d)
    home = screen.home_knots(apart)
    for r, c in zip(apart.j_rows, apart.j_cols, strict=True):
        assert home[r] < 0 or apart.var_knot[c] == home[r] or screen.all_knot_rows(d)[r]


def test_running_sums_same_row(screen) -> None:  # type: ignore[no-untyped-def]
    d = _chain(screen)
    rs = screen.running_sums(d)
    assert rs.n == d.n + K - 1 and rs.m == d.m + K - 1
    # at any x, the accumulators set by their equalities give the drift row its value
    rng = np.random.default_rng(0)
    x = rng.normal(size=d.n)
    a = _dense(rs)
    s = np.zeros(K - 1)
    acc_rows = np.flatnonzero(rs.row_group == "drift (sum)")
    for i, r in enumerate(acc_rows):  # s_i = s_{i−1} + a_i·x_i
        s[i] = -(a[r, : d.n] @ x) + (s[i - 1] if i else 0.0)
    xs = np.r_[x, s]
    assert np.allclose(a[acc_rows] @ xs, 0.0)
    drift = int(np.flatnonzero(d.row_group == "drift")[0])
    assert np.isclose(a[drift] @ xs, _dense(d)[drift] @ x)
    # every row now reads at most two neighbouring knots
    sets = screen.row_knot_sets(rs)
    assert max(len(v) for v in sets) <= 3


def test_lifted_goals_same_rows(screen) -> None:  # type: ignore[no-untyped-def]
    d = _chain(screen)
    lg = screen.lifted_goals(d)
    assert lg.n == d.n + K and lg.m == d.m + K
    rng = np.random.default_rng(1)
    x = rng.normal(size=d.n)
    goals = np.array([x[3 * k] + 0.5 * x[3 * k + 1] + 0.1 * x[3 * k + 2] for k in range(K)])
    xl = np.r_[x, goals]
    a, al = _dense(d), _dense(lg)
    np.testing.assert_allclose(al[: d.m] @ xl, a @ x, atol=1e-12)
    np.testing.assert_allclose(al[d.m:] @ xl, 0.0, atol=1e-12)
    speed = np.flatnonzero(lg.row_group == "servo goal speed")
    assert all(np.count_nonzero(al[r]) == 2 for r in speed)  # g_k, g_{k+1}


def test_relabelled_and_proxy(screen) -> None:  # type: ignore[no-untyped-def]
    d = _chain(screen)
    r = screen.relabelled(d, 3)
    assert r.j_rows.size == d.j_rows.size and sorted(r.row_group) == sorted(d.row_group)
    run = screen.run_proxy(d, {"max_iter": 2, "print_level": 0, "mumps_print_level": 3,
                               "sb": "yes"})
    assert run.sizes["eq"] == d.m - 1 and run.sizes["ineq"] == 1
    assert run.log.factorisations >= 1 and run.log.doubles and run.log.doubles[0] > 0


def test_knot_major_is_a_relabelling(screen) -> None:  # type: ignore[no-untyped-def]
    d = _chain(screen)
    km = screen.knot_major(d)
    assert km.n == d.n and km.m == d.m and km.j_rows.size == d.j_rows.size
    np.testing.assert_array_equal(np.sort(km.j_vals), np.sort(d.j_vals))
    assert np.all(np.diff(km.var_knot) >= 0)  # variables by knot
    rows = km.row_knot[km.row_group != "drift"]
    assert np.all(np.diff(rows) >= 0) and km.row_group[-1] == "drift"  # all-knot rows last


def test_lifted_feet_same_rows(screen) -> None:  # type: ignore[no-untyped-def]
    """A no-slip row on knots k and k+1 reads two foot variables whose rows carry its entries."""
    d = _chain(screen)
    labels = np.asarray([f"foot a@knot {k}" if g == "differences" else ""
                         for g, k in zip(d.row_group, d.row_knot, strict=True)])
    groups = np.where(d.row_group == "differences", "stance no-slip", d.row_group)
    d = screen._replace(d, row_group=groups, row_label=labels)
    lf = screen.lifted_feet(d)
    assert lf.n == d.n + K and lf.m == d.m + K  # one foot variable per knot (same columns)
    rng = np.random.default_rng(2)
    x = rng.normal(size=d.n)
    a, al = _dense(d), _dense(lf)
    feet = np.array([-(al[r, : d.n] @ x) for r in range(d.m, lf.m)])  # P = its row's entries
    xl = np.r_[x, feet]
    np.testing.assert_allclose(al[: d.m] @ xl, a @ x, atol=1e-12)
    slip = np.flatnonzero(lf.row_group == "stance no-slip")
    assert all(np.count_nonzero(al[r]) == 2 for r in slip)

"""`planner.nlp.variables.Layout`: the one place that knows the decision vector's offsets."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from planner.errors import PlannerConfigError
from planner.nlp.variables import BLOCKS, Layout, force_indices, make_symbols

N, J, F, F_FLAT = 5, 3, 2, 1
LAYOUT = Layout(N, J, F, F_FLAT)
#: entries per knot of every block, written out (the module docstring's order)
WIDTHS = {"base": 6, "q": J, "forces": 3 * F, "vel": 6 + J, "acc": 6 + J, "tau": J,
          "goal_slope": J, "moments": 3 * F_FLAT, "goal": 0}


def test_blocks_tile_the_vector_in_order() -> None:
    start = 0
    for name in BLOCKS:
        sl = LAYOUT.block(name)
        assert (sl.start, sl.stop) == (start, start + N * WIDTHS[name]), name
        assert LAYOUT.indices(name).shape == (N, WIDTHS[name])
        start = sl.stop
    assert LAYOUT.size == start == N * sum(WIDTHS.values())
    assert (LAYOUT.n_base, LAYOUT.n_q, LAYOUT.n_f, LAYOUT.n_rates, LAYOUT.n_m) == (
        6 * N, J * N, 3 * F * N, (6 + J) * N, 3 * F_FLAT * N)
    no_flat = Layout(N, J, F)
    assert no_flat.block("moments") == slice(no_flat.size, no_flat.size)
    with pytest.raises(PlannerConfigError, match="block 'torque'"):
        LAYOUT.block("torque")


def test_symbols_read_the_layout_blocks() -> None:
    """Column k of every symbol matrix is knot k's row of the layout's block."""
    sym = make_symbols(LAYOUT)
    names = ("base", "q", "forces", "vel", "acc", "tau", "goal_slope", "moments")
    blocks = [getattr(sym, name) for name in names]
    values = ca.Function("blocks", [sym.x], blocks)(np.arange(LAYOUT.size, dtype=float))
    x = np.arange(LAYOUT.size, dtype=float)
    for name, value in zip(names, values, strict=True):
        np.testing.assert_array_equal(np.asarray(value).T, LAYOUT.view(x, name), err_msg=name)


def test_pack_view_and_unpack_round_trip() -> None:
    rng = np.random.default_rng(0)
    blocks = {name: rng.normal(size=(N, WIDTHS[name])) for name in BLOCKS}
    x = LAYOUT.pack(blocks["base"], blocks["q"], blocks["forces"].reshape(N, F, 3),
                    vel=blocks["vel"], acc=blocks["acc"], tau=blocks["tau"],
                    goal_slope=blocks["goal_slope"], moments=blocks["moments"],
                    goal=blocks["goal"])
    for name in BLOCKS:
        np.testing.assert_array_equal(LAYOUT.view(x, name), blocks[name])
    base, q, f = LAYOUT.unpack(x)
    np.testing.assert_array_equal(f, blocks["forces"].reshape(N, F, 3))
    np.testing.assert_array_equal(LAYOUT.unpack_moments(x).reshape(N, -1), blocks["moments"])
    np.testing.assert_array_equal(x[force_indices(LAYOUT, 2)], f[:, :, 2].ravel())
    LAYOUT.view(x, "tau")[1, 2] = 7.0  # a view: writing it writes x
    assert x[LAYOUT.block("tau").start + J + 2] == 7.0
    lean = LAYOUT.pack(base, q, f)
    assert not lean[LAYOUT.block("vel").start :].any()  # the lifted blocks default to zeros
    with pytest.raises(PlannerConfigError, match="block 'tau' has 4 entries, expected 15"):
        LAYOUT.pack(base, q, f, tau=np.zeros(4))


def test_lifted_goals_block_comes_last() -> None:
    """`PlannerOptions.servo_goal_form` "lifted": one goal per joint and knot after every other
    block, which stay where they were."""
    lifted = Layout(N, J, F, F_FLAT, lifted_goals=True)
    for name in BLOCKS[:-1]:
        assert lifted.block(name) == LAYOUT.block(name), name
    assert lifted.block("goal") == slice(LAYOUT.size, LAYOUT.size + J * N)
    assert lifted.size == LAYOUT.size + J * N
    labels = lifted.labels(("hip", "knee", "ankle"), flat_feet=(1,))
    assert labels[lifted.indices("goal")[4, 1]] == "servo goal knee@knot 4"
    sym = make_symbols(lifted)
    assert sym.goal is not None and sym.goal.shape == (J, N)
    assert make_symbols(LAYOUT).goal is None
    x = lifted.pack(np.zeros((N, 6)), np.zeros((N, J)), np.zeros((N, F, 3)),
                    goal=np.ones((N, J)))
    np.testing.assert_array_equal(lifted.view(x, "goal"), 1.0)


def test_labels_name_every_entry_where_it_sits() -> None:
    labels = LAYOUT.labels(("hip", "knee", "ankle"), flat_feet=(1,))
    assert len(labels) == LAYOUT.size
    assert labels[LAYOUT.indices("tau")[3, 1]] == "torque knee@knot 3"
    assert labels[LAYOUT.indices("vel")[2, 7]] == "d/dt knee@knot 2"
    assert labels[LAYOUT.indices("forces")[4, 5]] == "foot 1 fz@knot 4"
    assert labels[LAYOUT.indices("moments")[0, 2]] == "foot 1 mz@knot 0"
    with pytest.raises(PlannerConfigError, match="block 'q'"):
        LAYOUT.labels(("hip", "knee"))

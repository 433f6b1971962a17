"""`planner.nlp.variables.retimed_start`: a solved point mapped onto another period and contact
pattern (the search's warm starts)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import PlannerConfigError
from planner.nlp.variables import Layout, retimed_start

LAYOUT = Layout(4, 2, 2)


def _point() -> np.ndarray:
    return np.arange(1.0, LAYOUT.size + 1.0)


def _blocks(x: np.ndarray) -> dict[str, np.ndarray]:
    n = LAYOUT
    cuts = np.cumsum([n.n_base, n.n_q, n.n_f, n.n_rates, n.n_rates, n.n_q, n.n_q])
    names = ["base", "q", "f", "vel", "acc", "tau", "slope"]
    return dict(zip(names, np.split(x, cuts)[:7], strict=True))


def test_rates_scale_with_the_period_ratio_and_poses_stay() -> None:
    contact = np.ones((4, 2), dtype=bool)
    x = _point()
    out = _blocks(retimed_start(LAYOUT, x, 0.8, 0.4, contact, contact))
    ref = _blocks(x)
    for same in ("base", "q", "f", "tau"):
        np.testing.assert_array_equal(out[same], ref[same])
    np.testing.assert_allclose(out["vel"], 2.0 * ref["vel"])
    np.testing.assert_allclose(out["acc"], 4.0 * ref["acc"])
    np.testing.assert_allclose(out["slope"], 2.0 * ref["slope"])


def test_forces_follow_the_new_contact_pattern() -> None:
    was = np.array([[1, 1], [1, 0], [0, 1], [1, 1]], dtype=bool)
    new = np.array([[1, 0], [1, 1], [0, 1], [0, 0]], dtype=bool)
    x = _point()
    f = _blocks(retimed_start(LAYOUT, x, 1.0, 1.0, was, new))["f"].reshape(4, 2, 3)
    f0 = _blocks(x)["f"].reshape(4, 2, 3)
    np.testing.assert_array_equal(f[0, 0], f0[0, 0])  # stays in contact: kept
    assert not f[0, 1].any() and not f[3].any()  # swings now: zero
    np.testing.assert_array_equal(f[1, 0], f0[1, 0])
    # lands now: the cold start's share of the weight (two feet in contact at knot 1)
    assert f[1, 1, 2] == pytest.approx(0.5)
    np.testing.assert_array_equal(f[1, 1, :2], f0[1, 1, :2])


@pytest.mark.parametrize(("size", "periods", "shape", "match"), [
    (5, (1.0, 1.0), (4, 2), "variables"),
    (None, (0.0, 1.0), (4, 2), "periods"),
    (None, (1.0, 1.0), (3, 2), "contact matrix"),
])
def test_bad_input_is_refused(size: int | None, periods: tuple[float, float],
                              shape: tuple[int, int], match: str) -> None:
    x = np.zeros(size) if size is not None else _point()
    with pytest.raises(PlannerConfigError, match=match):
        retimed_start(LAYOUT, x, *periods, np.ones(shape, bool), np.ones((4, 2), bool))

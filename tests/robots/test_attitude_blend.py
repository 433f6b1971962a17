"""robots.attitude.blended_offsets: the law on a blend of library gaits at one phase (drive).

The gaits are the biped library of tests/hardware/play/fixtures/biped_walk_lib.json (three
0.222 m/s walks: yaw rate −0.6, 0, +0.6 rad/s; each with the plan's base roll/pitch), so the
references differ from gait to gait."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robots
from robots.attitude import (
    DEFAULT_MAX_OFFSET_RAD,
    AttitudeError,
    AttitudeLaw,
    blended_offsets,
    gait_offsets,
    planned_roll_pitch,
)
from robots.attitude_maps import attitude_map
from robots.library import load

LIBRARY = Path(__file__).parents[1] / "hardware" / "play" / "fixtures" / "biped_walk_lib.json"
TILT = np.array([0.03, -0.02])  # measured roll, pitch [rad]: inside the clip at gain 0.5


@pytest.fixture(scope="module")
def setup() -> tuple[object, list[robots.Gait]]:
    robot = robots.load("biped")
    lib = load(LIBRARY, robot)
    return attitude_map(robot), [e.gait for e in lib.entries]


def test_one_gait_at_weight_one_is_that_gaits_offsets(setup: tuple) -> None:
    amap, gaits = setup
    law = AttitudeLaw(0.5)
    for g in gaits:
        for phase in (0.0, 0.13, 0.5, 0.77):
            for blend in (0.3, 1.0):
                one = blended_offsets(law, amap, [g], [1.0], TILT, blend, phase)
                ref = gait_offsets(law, amap, g, TILT, blend, phase * g.period_s)
                np.testing.assert_allclose(one, ref, atol=1e-12)


def test_a_blend_weights_the_references_like_the_joints(setup: tuple) -> None:
    """The entries share one schedule, so the support weights are the same; the law is linear in
    the error below the clip: the blend's offsets are the weighted sum of each gait's."""
    amap, gaits = setup
    law = AttitudeLaw(0.5)
    a, b = gaits[0], gaits[2]
    assert np.max(np.abs(planned_roll_pitch(a, 0.1) - planned_roll_pitch(b, 0.1))) > 1e-3
    for phase in np.linspace(0.0, 0.95, 12):
        for w in (0.25, 0.6):
            mix = blended_offsets(law, amap, [a, b], [w, 1.0 - w], TILT, 1.0, phase)
            oa = blended_offsets(law, amap, [a], [1.0], TILT, 1.0, phase)
            ob = blended_offsets(law, amap, [b], [1.0], TILT, 1.0, phase)
            assert np.max(np.abs(mix)) < DEFAULT_MAX_OFFSET_RAD  # below the clip: linear
            np.testing.assert_allclose(mix, w * oa + (1.0 - w) * ob, atol=1e-12)


def test_a_gait_switch_moves_the_offsets_continuously_and_the_clip_holds(setup: tuple) -> None:
    """The weight moves from gait 0 to gait 2 over 2 s of 100 Hz ticks: the offsets change per
    tick no more than either gait's own do over the same phases (their support ramps), plus the
    little the weight's change adds — no step at the switch."""
    amap, gaits = setup
    law = AttitudeLaw(1.0)
    a, b = gaits[0], gaits[2]

    def largest_step(weight: object) -> float:
        offs = [blended_offsets(law, amap, [a, b], [1.0 - weight(k), weight(k)], TILT, 1.0,
                                (k * 0.01 / a.period_s) % 1.0) for k in range(201)]
        return float(np.max(np.abs(np.diff(offs, axis=0))))

    switch = largest_step(lambda k: k / 200)
    alone = max(largest_step(lambda k: 0.0), largest_step(lambda k: 1.0))
    assert alone > 0.0 and switch <= alone + 0.005, (switch, alone)
    big = blended_offsets(law, amap, gaits, [0.2, 0.3, 0.5], np.array([0.6, -0.5]), 1.0, 0.3)
    assert np.max(np.abs(big)) == pytest.approx(DEFAULT_MAX_OFFSET_RAD)  # clipped


def test_zero_blend_weight_gives_no_correction(setup: tuple) -> None:
    amap, gaits = setup
    off = blended_offsets(AttitudeLaw(1.0), amap, gaits[:2], [0.5, 0.5], TILT, 0.0, 0.4)
    assert not np.any(off)


@pytest.mark.parametrize("weights, match", [
    ([0.5], "2 gait"), ([0.7, 0.7], "sum to 1"), ([1.2, -0.2], "≥ 0"),
    ([np.nan, 1.0], "sum to 1"),
])
def test_bad_weights_are_refused(setup: tuple, weights: list[float], match: str) -> None:
    amap, gaits = setup
    with pytest.raises(AttitudeError, match=match):
        blended_offsets(AttitudeLaw(1.0), amap, gaits[:2], weights, TILT, 1.0, 0.0)

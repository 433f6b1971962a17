"""Gait templates: roles from geometry, phase relations, and the nearest-template classifier."""

from __future__ import annotations

import numpy as np
import pytest

import robots
from planner.errors import TemplateError
from planner.templates import gait_family, label_gait, leg_roles, make_schedule, templates_for


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


@pytest.fixture(scope="module")
def hexa() -> robots.Robot:
    return robots.load("hex18")


def _phase(s: robots.ContactSchedule, roles: dict[str, int], role: str) -> float:
    return s.touchdown_phase[roles[role]]


def _diff(a: float, b: float) -> float:
    return (a - b) % 1.0


def test_roles_from_geometry(quad: robots.Robot, hexa: robots.Robot) -> None:
    assert leg_roles(quad) == {"LF": 0, "RF": 1, "LH": 2, "RH": 3}
    assert leg_roles(hexa) == {"LF": 0, "LM": 1, "LH": 2, "RF": 3, "RM": 4, "RH": 5}


def test_quadruped_phase_relations(quad: robots.Robot) -> None:
    roles = leg_roles(quad)

    def ph(gait: str, role: str) -> float:
        return _phase(make_schedule(quad, gait), roles, role)

    assert (
        _diff(ph("trot", "LF"), ph("trot", "RH")) == 0
        and _diff(ph("trot", "LF"), ph("trot", "RF")) == 0.5
    )
    assert (
        _diff(ph("pace", "LF"), ph("pace", "LH")) == 0
        and _diff(ph("pace", "LF"), ph("pace", "RF")) == 0.5
    )
    assert (
        _diff(ph("bound", "LF"), ph("bound", "RF")) == 0
        and _diff(ph("bound", "LF"), ph("bound", "LH")) == 0.5
    )
    assert len({ph("pronk", r) for r in roles}) == 1
    walk = [ph("walk", r) for r in ("LH", "LF", "RH", "RF")]
    assert np.allclose(np.diff(walk), 0.25)
    assert (
        make_schedule(quad, "walk").duty_factor[0]
        > 0.5
        > make_schedule(quad, "gallop_rotary").duty_factor[0]
    )
    assert 0.4 <= make_schedule(quad, "trot").period_s <= 0.6


def test_hexapod_phase_relations(hexa: robots.Robot) -> None:
    roles = leg_roles(hexa)
    tri = make_schedule(hexa, "tripod")
    a = {_phase(tri, roles, r) for r in ("LF", "RM", "LH")}
    b = {_phase(tri, roles, r) for r in ("RF", "LM", "RH")}
    assert len(a) == 1 and len(b) == 1 and _diff(a.pop(), b.pop()) == 0.5
    wave = make_schedule(hexa, "wave")
    assert len(set(wave.touchdown_phase)) == 6
    assert 0.6 <= tri.period_s <= 1.0


def test_templates_round_trip_through_the_classifier(
    quad: robots.Robot, hexa: robots.Robot
) -> None:
    rng = np.random.default_rng(0)
    for bot in (quad, hexa):
        for gait in templates_for(bot):
            s = make_schedule(bot, gait)
            noisy = robots.ContactSchedule(
                s.period_s * 1.1,
                s.feet,
                tuple(
                    (p + 0.3 + 0.02 * rng.normal()) % 1.0 for p in s.touchdown_phase
                ),  # shifted + noise
                tuple(min(1.0, d + 0.02 * rng.normal()) for d in s.duty_factor),
            )
            assert label_gait(noisy, bot) == gait


def test_template_errors(quad: robots.Robot, hexa: robots.Robot) -> None:
    with pytest.raises(TemplateError):
        make_schedule(hexa, "trot")
    with pytest.raises(TemplateError):
        make_schedule(quad, "tripod")
    with pytest.raises(TemplateError):
        make_schedule(quad, "moonwalk")


def test_walk_sequences_and_gait_families(quad: robots.Robot) -> None:
    """Hildebrand's limb phase (LF touchdown after LH): 0.25 lateral, 0.75 diagonal sequence."""
    roles = leg_roles(quad)
    for gait, limb_phase in (("walk", 0.25), ("diagonal_walk", 0.75), ("trot", 0.5), ("pace", 0.0)):
        s = make_schedule(quad, gait)
        assert (_phase(s, roles, "LF") - _phase(s, roles, "LH")) % 1.0 == pytest.approx(limb_phase)
    assert gait_family("walk") == gait_family("diagonal_walk") == "walk"
    assert gait_family("gallop_rotary") == "gallop" and gait_family("trot") == "trot"
    assert gait_family("biped_run") == "run"

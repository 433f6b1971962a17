"""Gait templates → `ContactSchedule` for any robot, and `label_gait` (nearest template family).

Legs get their roles from geometry, never from names: the foot-site positions at the nominal
stance (from the MJCF) sort feet into left/right by y (MuJoCo's +y is the robot's left when +x is
forward) and front/middle/hind by x.

Timings (touchdown phase per role, duty factor) are the classic footfall patterns (Hildebrand's
gait diagrams), the walk/trot/gallop families of Torkos & van de Panne 1998 §3.3 ("the sequencing
and timing of the leg stance phases are controlled automatically in accordance with the desired
gait"), with the phase measured from the left hind touchdown. Hexapod tripod/ripple/wave are the
standard metachronal patterns. Default periods scale with the leg length as
``period = k·√(L/g)`` (dynamic similarity: equal Froude number across robot sizes).

Any other leg count or layout (`robot_templates`): feet are ordered by the azimuth of their
stance position around the base origin (atan2(y, x), counter-clockwise from behind) and get
``wave`` (one foot after the other in that order), ``ripple`` (every second foot: two waves half
a cycle apart, 5+ legs), ``alternating`` (every other foot together, even counts ≥ 4: the trot
of 4 legs, the tripod of 6; an odd count has no balanced split, so it is not offered), ``pronk``
and ``stand`` — so every robot has templates. Robots whose feet pair up left/right (2, 4, 6
legs) keep the named patterns above, and azimuth templates that duplicate one are dropped.
`default_gait_for` picks walk/trot/tripod for 2/4/6 legs, else ripple (wave for 3 legs); a
quadruped on hip-and-knee legs (no hip roll) walks instead of trotting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from planner.errors import TemplateError
from planner.nlp.sideways_locked import sideways_locked_feet
from planner.stance import stance_kinematics
from robots import ContactSchedule, Robot


@dataclass(frozen=True)
class Template:
    """A gait family: touchdown phase per geometric role, duty factor, period in √(L/g) units."""

    name: str
    n_legs: int
    phases: dict[str, float]
    duty_factor: float
    period_sqrt_l_g: float


_QUAD = ("LF", "RF", "LH", "RH")
_HEX = ("LF", "LM", "LH", "RF", "RM", "RH")
_BIPED = ("L", "R")

TEMPLATES: dict[str, Template] = {
    t.name: t
    for t in (
        # quadrupeds (phase of the left hind touchdown = 0)
        Template(
            "walk", 4, {"LH": 0.0, "LF": 0.25, "RH": 0.5, "RF": 0.75}, 0.75, 5.0
        ),  # lateral sequence
        Template(
            "diagonal_walk", 4, {"LH": 0.0, "RF": 0.25, "RH": 0.5, "LF": 0.75}, 0.75, 5.0
        ),  # diagonal sequence (Hildebrand 1976): each hind foot followed by the opposite fore
        Template(
            "trot", 4, {"LF": 0.0, "RH": 0.0, "RF": 0.5, "LH": 0.5}, 0.6, 3.5
        ),  # diagonal pairs
        Template(
            "pace", 4, {"LF": 0.0, "LH": 0.0, "RF": 0.5, "RH": 0.5}, 0.6, 3.5
        ),  # lateral pairs
        Template(
            "bound", 4, {"LF": 0.5, "RF": 0.5, "LH": 0.0, "RH": 0.0}, 0.4, 3.0
        ),  # fore/hind pairs
        Template("gallop_rotary", 4, {"LH": 0.0, "RH": 0.1, "RF": 0.5, "LF": 0.6}, 0.35, 3.0),
        Template("gallop_transverse", 4, {"LH": 0.0, "RH": 0.1, "LF": 0.5, "RF": 0.6}, 0.35, 3.0),
        Template("pronk", 4, {"LF": 0.0, "RF": 0.0, "LH": 0.0, "RH": 0.0}, 0.4, 3.0),
        # hexapods: alternating tripods; ripple (two 3-beat waves half a cycle apart); wave
        Template(
            "tripod",
            6,
            {"LF": 0.0, "RM": 0.0, "LH": 0.0, "RF": 0.5, "LM": 0.5, "RH": 0.5},
            0.6,
            6.5,
        ),
        Template(
            "ripple",
            6,
            {"LH": 0.0, "LM": 1 / 3, "LF": 2 / 3, "RH": 0.5, "RM": 5 / 6, "RF": 1 / 6},
            0.65,
            7.5,
        ),
        Template(
            "wave",
            6,
            {"LH": 0.0, "LM": 1 / 6, "LF": 2 / 6, "RH": 3 / 6, "RM": 4 / 6, "RF": 5 / 6},
            0.8,
            9.0,
        ),
        # bipeds: walking has double support (duty > 0.5), running a flight phase (duty < 0.5)
        Template("biped_walk", 2, {"L": 0.0, "R": 0.5}, 0.6, 4.0),
        Template("biped_run", 2, {"L": 0.0, "R": 0.5}, 0.35, 3.0),
    )
}


def stance_foot_positions_m(robot: Robot) -> np.ndarray:
    """F × 3 foot-site positions (base frame, base at the origin) at the nominal stance."""
    key = (str(robot.mjcf_path), robot.fingerprint)
    cached = _STANCE_CACHE.get(key)
    if cached is not None:
        return cached.copy()
    stance = stance_kinematics(robot)
    model, data = stance.model, stance.data
    sites = [
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site) for leg in robot.legs
    ]
    out = np.array(data.site_xpos[sites], dtype=float)
    _STANCE_CACHE[key] = out
    return out.copy()


_STANCE_CACHE: dict[tuple[str, str], np.ndarray] = {}


def leg_roles(robot: Robot) -> dict[str, int]:
    """Geometric role → foot index: L/R by y; F/H (and M for hexapods) by x within a side.

    Raises TemplateError for robots without left/right pairs (odd leg counts, feet on the
    midline, more than 6 legs); `templates_for` then offers the azimuth templates only.
    """
    pos = stance_foot_positions_m(robot)
    n = len(pos)
    if n % 2:
        raise TemplateError(f"{robot.name}: {n} legs cannot be split into left/right pairs")
    order = np.argsort(-pos[:, 1], kind="stable")
    left, right = order[: n // 2], order[n // 2 :]
    if np.min(pos[left, 1]) <= np.max(pos[right, 1]) - 1e-9 or np.min(pos[left, 1]) <= 1e-9 \
            or np.max(pos[right, 1]) >= -1e-9:
        raise TemplateError(
            f"{robot.name}: feet are not separated into a left and a right side by y"
        )
    names = {1: ("",), 2: ("F", "H"), 3: ("F", "M", "H")}.get(n // 2)
    if names is None:
        raise TemplateError(f"{robot.name}: no named templates for {n} legs (2, 4 or 6)")
    roles: dict[str, int] = {}
    for side, idx in (("L", left), ("R", right)):
        for name, i in zip(names, idx[np.argsort(-pos[idx, 0], kind="stable")], strict=True):
            roles[side + name] = int(i)
    return roles


#: Mirror-image feet match within this fraction of the leg length (MJCF rounding, not design).
MIRROR_TOL_LEG_LENGTHS = 0.02


def mirror_permutation(robot: Robot) -> tuple[int, ...] | None:
    """Foot f's mirror image under y → −y (the body's sagittal plane), or None if the stance
    feet are not mirror-symmetric. Feet on the midline are their own mirror image."""
    pos = stance_foot_positions_m(robot)
    tol = MIRROR_TOL_LEG_LENGTHS * robot.leg_length_m
    mirrored = pos * np.array([1.0, -1.0, 1.0])
    perm = []
    for f in range(len(pos)):
        d = np.linalg.norm(pos - mirrored[f], axis=1)
        g = int(np.argmin(d))
        if d[g] > tol:
            return None
        perm.append(g)
    if sorted(perm) != list(range(len(pos))):
        return None
    return tuple(perm)


def azimuth_order(robot: Robot) -> tuple[int, ...]:
    """Feet sorted by the azimuth of their stance position around the base origin,
    counter-clockwise seen from above, starting behind the robot (azimuth π)."""
    pos = stance_foot_positions_m(robot)
    az = np.arctan2(pos[:, 1], pos[:, 0])
    return tuple(int(i) for i in np.argsort((az - math.pi) % (2 * math.pi), kind="stable"))


@dataclass(frozen=True)
class RobotTemplate:
    """A template laid out on one robot's feet (in `robot.legs` order)."""

    name: str
    touchdown_phase: tuple[float, ...]
    duty_factor: float
    period_sqrt_l_g: float
    description: str


#: Templates for any leg count, from the azimuth order (W&P-style footfall families): the
#: duty factors keep about 1.2 (wave) and 2.1 (ripple) feet in swing on average.
GENERIC_TEMPLATES = ("alternating", "wave", "ripple", "pronk", "stand")


def _generic(robot: Robot) -> list[RobotTemplate]:
    n = len(robot.legs)
    order = azimuth_order(robot)
    rank = [0] * n
    for r, f in enumerate(order):
        rank[f] = r
    out = []
    if n >= 4 and n % 2 == 0:
        out.append(RobotTemplate(
            "alternating", tuple(0.5 * (rank[f] % 2) for f in range(n)), 0.6, 5.0,
            "every other foot around the body together (trot for 4 legs, tripod for 6)"))
    if n >= 3:
        out.append(RobotTemplate(
            "wave", tuple(round(rank[f] / n, 12) for f in range(n)), max(0.6, 1.0 - 1.2 / n), 9.0,
            "one foot after the other around the body (azimuth order)"))
    if n >= 5:
        out.append(RobotTemplate(
            "ripple", tuple(round((2 * rank[f] / n) % 1.0, 12) for f in range(n)),
            max(0.5, 1.0 - 2.1 / n), 7.5,
            "two waves half a cycle apart: every second foot around the body"))
    out.append(RobotTemplate("pronk", (0.0,) * n, 0.4, 3.0, "all feet together, with flight"))
    out.append(RobotTemplate("stand", (0.0,) * n, 1.0, 4.0, "all feet down (speed 0 only)"))
    return out


def robot_templates(robot: Robot) -> dict[str, RobotTemplate]:
    """Every template offered for `robot`: the named footfall patterns of `TEMPLATES` when its
    feet form left/right pairs of 2, 4 or 6 legs, then the azimuth templates of
    `GENERIC_TEMPLATES` that are not already there under another name (e.g. `alternating` is
    the trot of a quadruped and the tripod of a hexapod, so those robots do not list it)."""
    n = len(robot.legs)
    out: dict[str, RobotTemplate] = {}
    try:
        roles: dict[str, int] | None = leg_roles(robot)
    except TemplateError:
        roles = None
    if roles is not None:
        for name, t in TEMPLATES.items():
            if t.n_legs != n:
                continue
            phases = [0.0] * n
            for role, foot in roles.items():
                phases[foot] = t.phases[role] % 1.0
            out[name] = RobotTemplate(name, tuple(phases), t.duty_factor, t.period_sqrt_l_g,
                                      "named footfall pattern")
    mirror = mirror_permutation(robot)
    for g in _generic(robot):
        if g.name in out:
            continue
        ref = ContactSchedule(1.0, robot.foot_names, g.touchdown_phase, (g.duty_factor,) * n)
        if any(_distance_with_mirror(ref, t, mirror) < 0.05 for t in out.values()):
            continue
        out[g.name] = g
    return out


def _distance_with_mirror(
    schedule: ContactSchedule, t: RobotTemplate, mirror: tuple[int, ...] | None
) -> float:
    n = schedule.n_feet
    variants = [t.touchdown_phase]
    if mirror is not None:
        variants.append(tuple(t.touchdown_phase[mirror[f]] for f in range(n)))
    return min(
        schedule_distance(
            schedule, ContactSchedule(schedule.period_s, schedule.feet, v, (t.duty_factor,) * n)
        )
        for v in variants
    )


def templates_for(robot: Robot) -> list[str]:
    """Names of the templates offered for `robot` (never empty: pronk and stand fit any robot)."""
    return list(robot_templates(robot))


#: Preferred default gait by leg count; other counts take the first of `_FALLBACK` offered.
_DEFAULT_BY_LEGS = {2: "biped_walk", 4: "trot", 6: "tripod"}
_FALLBACK = ("ripple", "wave", "alternating", "pronk")


def hip_and_knee_quadruped(robot: Robot) -> bool:
    """Four legs, none of which can move its foot sideways (`planner.nlp.sideways_locked`)."""
    return len(robot.legs) == 4 and all(sideways_locked_feet(robot))


def default_gait_for(robot: Robot) -> str:
    """The default template: walk for 2 legs, trot for 4, tripod for 6 (when the feet form
    left/right pairs), else ripple (5+ legs) or wave (3 legs).

    A quadruped whose legs are all hip-and-knee legs (no hinge that moves a foot sideways,
    `planner.nlp.sideways_locked`) gets the walk instead of the trot. A trot stands on one
    diagonal for most of its stance, and without hip roll nothing in an open-loop gait holds
    the body's roll about that line. Measured on the two such robots in the zoo, in MuJoCo
    (docs/results/zoo_gaits.md §Session 24):
    - bittle8 (Fr 0.02): the converged template trot fails (15 % slow, feet down 55/40/49/73 %
      of the cycle against 60 % planned); walk and diagonal walk pass.
    - knee8: the trot never passed (it falls or turns 15–86°); the walk passed with a light
      rotor (armature 0.005 kg·m²) at 0.13 m/s.
    """
    offered = robot_templates(robot)
    if "walk" in offered and hip_and_knee_quadruped(robot):
        return "walk"
    preferred = _DEFAULT_BY_LEGS.get(len(robot.legs))
    if preferred in offered:
        return str(preferred)
    if len(robot.legs) % 2 == 0 and "alternating" in offered:
        return "alternating"
    return next(name for name in _FALLBACK if name in offered)


def default_period_s(robot: Robot, gait: str) -> float:
    return _template(robot, gait).period_sqrt_l_g * math.sqrt(robot.leg_length_m / 9.81)


def _template(robot: Robot, gait: str) -> RobotTemplate:
    offered = robot_templates(robot)
    t = offered.get(gait)
    if t is None:
        known = gait in TEMPLATES or gait in GENERIC_TEMPLATES
        what = "is not offered for" if known else "is not a gait template;"
        raise TemplateError(
            f"gait {gait!r} {what} {robot.name} ({len(robot.legs)} legs); "
            f"try one of: {', '.join(offered)}"
        )
    return t


def make_schedule(
    robot: Robot, gait: str, period_s: float | None = None, duty_factor: float | None = None
) -> ContactSchedule:
    """The template `gait` for this robot as a ContactSchedule (feet in `robot.legs` order)."""
    t = _template(robot, gait)
    duty = t.duty_factor if duty_factor is None else duty_factor
    period = default_period_s(robot, gait) if period_s is None else period_s
    return ContactSchedule(
        float(period), robot.foot_names, t.touchdown_phase, (float(duty),) * len(robot.legs)
    )


def gait_family(label: str) -> str:
    """The family of a template label: both walk sequences are walks, both gallops gallops."""
    if label.endswith("walk"):
        return "walk"
    if label.startswith("gallop"):
        return "gallop"
    return label.removeprefix("biped_")


def circular_difference(d: np.ndarray) -> np.ndarray:
    """Phase differences wrapped into [−0.5, 0.5)."""
    return (d + 0.5) % 1.0 - 0.5


def identical_schedules(a: ContactSchedule, b: ContactSchedule, tol: float = 1e-9) -> bool:
    """The same feet, period, touchdown phases (mod 1, no global shift) and duty factors."""
    phase = circular_difference(np.asarray(a.touchdown_phase) - np.asarray(b.touchdown_phase))
    return (tuple(a.feet) == tuple(b.feet) and abs(a.period_s - b.period_s) <= tol
            and bool(np.all(np.abs(phase) <= tol))
            and bool(np.allclose(a.duty_factor, b.duty_factor, rtol=0.0, atol=tol)))


def schedule_distance(schedule: ContactSchedule, template: ContactSchedule) -> float:
    """Distance between two schedules of the same feet: RMS circular phase difference after the
    best global phase shift, plus the mean absolute duty-factor difference."""
    a, b = np.asarray(schedule.touchdown_phase), np.asarray(template.touchdown_phase)
    best = min(float(np.sqrt(np.mean(circular_difference(a - b - s) ** 2)))
               for s in circular_difference(a - b))
    return best + float(
        np.mean(np.abs(np.asarray(schedule.duty_factor) - np.asarray(template.duty_factor)))
    )


def label_gait(schedule: ContactSchedule, robot: Robot) -> str:
    """The template family `schedule` is closest to (its mirror image counts as the same family)."""
    if tuple(schedule.feet) != robot.foot_names:
        raise TemplateError("schedule feet do not match the robot's legs")
    mirror = mirror_permutation(robot)
    best, best_d = "", math.inf
    for name, t in robot_templates(robot).items():
        d = _distance_with_mirror(schedule, t, mirror)
        if d < best_d - 1e-12:
            best, best_d = name, d
    return best

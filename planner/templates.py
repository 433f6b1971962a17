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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from planner.errors import TemplateError
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
    model = robot.mj_model()
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0:7] = (0, 0, 0, 1, 0, 0, 0)
    for j in robot.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        data.qpos[model.jnt_qposadr[jid]] = j.stance_rad
    mujoco.mj_kinematics(model, data)
    sites = [
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site) for leg in robot.legs
    ]
    return np.array(data.site_xpos[sites], dtype=float)


def leg_roles(robot: Robot) -> dict[str, int]:
    """Geometric role → foot index: L/R by y; F/H (and M for hexapods) by x within a side."""
    pos = stance_foot_positions_m(robot)
    n = len(pos)
    if n % 2:
        raise TemplateError(f"{robot.name}: {n} legs cannot be split into left/right pairs")
    order = np.argsort(-pos[:, 1], kind="stable")
    left, right = order[: n // 2], order[n // 2 :]
    if np.min(pos[left, 1]) <= np.max(pos[right, 1]) - 1e-9:
        raise TemplateError(
            f"{robot.name}: feet are not separated into a left and a right side by y"
        )
    names = {1: ("",), 2: ("F", "H"), 3: ("F", "M", "H")}.get(n // 2)
    if names is None:
        raise TemplateError(f"{robot.name}: no templates for {n} legs (2, 4 or 6 supported)")
    roles: dict[str, int] = {}
    for side, idx in (("L", left), ("R", right)):
        for name, i in zip(names, idx[np.argsort(-pos[idx, 0], kind="stable")], strict=True):
            roles[side + name] = int(i)
    return roles


def templates_for(robot: Robot) -> tuple[str, ...]:
    return tuple(name for name, t in TEMPLATES.items() if t.n_legs == len(robot.legs))


def default_period_s(robot: Robot, gait: str) -> float:
    return TEMPLATES[gait].period_sqrt_l_g * math.sqrt(robot.leg_length_m / 9.81)


def make_schedule(
    robot: Robot, gait: str, period_s: float | None = None, duty_factor: float | None = None
) -> ContactSchedule:
    """The template `gait` for this robot as a ContactSchedule (feet in `robot.legs` order)."""
    template = TEMPLATES.get(gait)
    if template is None:
        raise TemplateError(f"unknown gait {gait!r}; known: {', '.join(TEMPLATES)}")
    if template.n_legs != len(robot.legs):
        raise TemplateError(
            f"gait {gait!r} needs {template.n_legs} legs, {robot.name} has {len(robot.legs)}; "
            f"try one of: {', '.join(templates_for(robot))}"
        )
    roles = leg_roles(robot)
    phases = [0.0] * len(robot.legs)
    for role, foot in roles.items():
        phases[foot] = template.phases[role] % 1.0
    duty = template.duty_factor if duty_factor is None else duty_factor
    period = default_period_s(robot, gait) if period_s is None else period_s
    return ContactSchedule(
        float(period), robot.foot_names, tuple(phases), (float(duty),) * len(robot.legs)
    )


def gait_family(label: str) -> str:
    """The family of a template label: both walk sequences are walks, both gallops gallops."""
    if label.endswith("walk"):
        return "walk"
    if label.startswith("gallop"):
        return "gallop"
    return label.removeprefix("biped_")


def _circular(d: np.ndarray) -> np.ndarray:
    return (d + 0.5) % 1.0 - 0.5


def schedule_distance(schedule: ContactSchedule, template: ContactSchedule) -> float:
    """Distance between two schedules of the same feet: RMS circular phase difference after the
    best global phase shift, plus the mean absolute duty-factor difference."""
    a, b = np.asarray(schedule.touchdown_phase), np.asarray(template.touchdown_phase)
    best = min(float(np.sqrt(np.mean(_circular(a - b - s) ** 2))) for s in _circular(a - b))
    return best + float(
        np.mean(np.abs(np.asarray(schedule.duty_factor) - np.asarray(template.duty_factor)))
    )


def label_gait(schedule: ContactSchedule, robot: Robot) -> str:
    """The template family `schedule` is closest to (its mirror image counts as the same family)."""
    if tuple(schedule.feet) != robot.foot_names:
        raise TemplateError("schedule feet do not match the robot's legs")
    roles = leg_roles(robot)
    mirror = {role: roles[("R" if role[0] == "L" else "L") + role[1:]] for role in roles}
    best, best_d = "", math.inf
    for name in templates_for(robot):
        t = TEMPLATES[name]
        for mapping in (roles, mirror):
            phases = [0.0] * len(robot.legs)
            for role, foot in mapping.items():
                phases[foot] = t.phases[role] % 1.0
            ref = ContactSchedule(
                schedule.period_s, schedule.feet, tuple(phases), (t.duty_factor,) * len(robot.legs)
            )
            d = schedule_distance(schedule, ref)
            if d < best_d - 1e-12:
                best, best_d = name, d
    return best

"""The commented robot.toml `robots init` writes (plain text: comments are the point)."""

from __future__ import annotations

import json
import math
import textwrap
from dataclasses import dataclass


@dataclass(frozen=True)
class JointEntry:
    name: str
    servo: str
    bus_id: int
    zero_offset_ticks: int
    stance_rad: float
    hold: bool
    limits_rad: tuple[float, float] | None  # narrower than the MJCF range (servo reach)
    comment: str


@dataclass(frozen=True)
class LegEntry:
    name: str
    foot_site: str
    joints: tuple[str, ...]
    #: the box geom whose bottom face is the sole (the leg is then declared `foot = "flat"`),
    #: "" for a point foot
    sole_geom: str = ""


def _deg(rad: float) -> str:
    return f"{math.degrees(rad) + 0.0:.2f}".replace("-0.00", "0.00")


def robot_toml(
    *,
    name: str,
    description: str,
    source: str,
    foot_radius_m: float,
    bus_baud: int,
    joints: list[JointEntry],
    legs: list[LegEntry],
    notes: list[str],
) -> str:
    out = [
        f"# robot.toml written by `gaitsmith robots init` from {source}.",
        "# Joint limits come from robot.xml (`range`); `limits_deg` here may only narrow them.",
        "# Before playing on hardware, check every `direction` and `zero_offset_ticks` against the",
        "# build (direction +1: the servo's positive turn is the MJCF axis' positive turn).",
        "#",
        "# What init decided:",
        *[
            line
            for n in notes
            for line in textwrap.wrap(
                n, 96, initial_indent="#   - ", subsequent_indent="#     ", break_on_hyphens=False
            )
        ],
        "",
        "[robot]",
        f"name = {json.dumps(name)}",
        f"description = {json.dumps(description)}",
        f"foot_radius_m = {foot_radius_m:.4f}",
        f"bus_baud = {bus_baud}",
    ]
    leg_of = {j: leg.name for leg in legs for j in leg.joints}
    current = None
    for j in joints:
        group = f"leg {leg_of[j.name]}" if j.name in leg_of else "held joints (not in a leg)"
        if group != current:
            out += ["", f"# --- {group}"]
            current = group
        out += ["", f"[joints.{j.name}]"]
        if j.comment:
            out.append(f"# {j.comment}")
        if j.hold:
            out.append('role = "hold"  # not in a leg: the servo holds stance_deg')
        out += [
            f"servo = {json.dumps(j.servo)}",
            f"bus_id = {j.bus_id}",
            "direction = 1",
            f"zero_offset_ticks = {j.zero_offset_ticks}",
            f"stance_deg = {_deg(j.stance_rad)}",
        ]
        if j.limits_rad is not None:
            out.append(f"limits_deg = [{_deg(j.limits_rad[0])}, {_deg(j.limits_rad[1])}]")
    for leg in legs:
        out += [
            "",
            f"[legs.{leg.name}]",
            f"foot_site = {json.dumps(leg.foot_site)}",
            f"joints = {json.dumps(list(leg.joints))}",
        ]
        if leg.sole_geom:
            out.append(f'foot = "flat"  # the sole is the bottom face of box geom {leg.sole_geom}')
    return "\n".join(out) + "\n"

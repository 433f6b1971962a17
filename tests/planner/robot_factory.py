# ruff: noqa: E501  (MJCF text blocks)
"""Robots nobody on the project built, generated as MJCF + robot.toml folders for the tests.

- `star_robot`: N radial "spider" legs (hip yaw, hip pitch, knee) spaced evenly in azimuth
  around a round body; N = 5 has no left/right pairs and no mirror plane through x.
- `small_quadruped`: a 0.23 kg hobby quadruped with 7.5 cm legs (hip roll, hip pitch, knee) on
  XL330-M288 servos, a third of quad12's size.

Run as a script to write both into a folder (for trying them on the command line)::

    python -m tests.planner.robot_factory /tmp/robots
"""

from __future__ import annotations

import math
import sys
from pathlib import Path


def _rod_inertia(mass_kg: float, length_m: float, radius_m: float) -> str:
    """diaginertia of a rod along z (the values only need to be plausible and positive)."""
    across = mass_kg * (3 * radius_m**2 + length_m**2) / 12 + 1e-8
    along = 0.5 * mass_kg * radius_m**2 + 1e-8
    return f"{across:.6g} {across:.6g} {along:.6g}"


def _header(name: str, armature: float = 0.002, damping: float = 0.02) -> str:
    return f"""<mujoco model="{name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.002" integrator="implicitfast"/>
  <default>
    <joint damping="{damping}" armature="{armature}"/>
    <geom contype="0" conaffinity="0"/>
    <default class="collide">
      <geom contype="1" conaffinity="0" condim="3" friction="0.9 0.005 0.0001"/>
    </default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.05" contype="1" conaffinity="1" condim="3"/>
"""


def _joint_toml(name: str, servo: str, bus_id: int, stance_deg: float) -> str:
    return (
        f"[joints.{name}]\nservo = \"{servo}\"\nbus_id = {bus_id}\ndirection = 1\n"
        f"zero_offset_ticks = 2048\nstance_deg = {stance_deg:.3f}\n\n"
    )


def star_robot(
    folder: Path,
    n_legs: int = 5,
    *,
    servo: str = "STS3215_7V4",
    body_radius_m: float = 0.08,
    body_mass_kg: float = 0.6,
    coxa_m: float = 0.03,
    thigh_m: float = 0.08,
    shank_m: float = 0.10,
    foot_radius_m: float = 0.012,
    first_azimuth_rad: float = 0.0,
    name: str | None = None,
) -> Path:
    """N spider legs at azimuths first + 2πi/N; joints yaw (z), pitch and knee (tangential)."""
    name = name or f"star{n_legs}"
    folder.mkdir(parents=True, exist_ok=True)
    link_kg = 0.055 if servo == "STS3215_7V4" else 0.02
    xml = [_header(name)]
    height = shank_m + foot_radius_m + 0.02
    xml.append(f'    <body name="body" pos="0 0 {height:.4f}">\n      <freejoint name="root"/>\n')
    xml.append(
        f'      <inertial pos="0 0 0" mass="{body_mass_kg}" '
        f'diaginertia="{_rod_inertia(body_mass_kg, 0.03, body_radius_m)}"/>\n'
        f'      <geom name="body" class="collide" type="cylinder" size="{body_radius_m} 0.015"/>\n'
    )
    toml = [f'[robot]\nname = "{name}"\ndescription = "{n_legs}-leg star (test robot)"\n'
            f"foot_radius_m = {foot_radius_m}\n\n"]
    legs = []
    bus = 1
    for i in range(n_legs):
        az = first_azimuth_rad + 2 * math.pi * i / n_legs
        leg = f"l{i}"
        x, y = body_radius_m * math.cos(az), body_radius_m * math.sin(az)
        xml.append(f"""      <body name="{leg}_hip" pos="{x:.5f} {y:.5f} 0" euler="0 0 {az:.6f}">
        <joint name="{leg}_yaw" axis="0 0 1" range="-0.8 0.8"/>
        <inertial pos="{coxa_m / 2} 0 0" mass="{link_kg}" diaginertia="{_rod_inertia(link_kg, coxa_m, 0.015)}"/>
        <body name="{leg}_thigh" pos="{coxa_m} 0 0">
          <joint name="{leg}_pitch" axis="0 1 0" range="-1.0 1.0"/>
          <inertial pos="{thigh_m / 2} 0 0" mass="{link_kg}" diaginertia="{_rod_inertia(link_kg, thigh_m, 0.015)}"/>
          <geom type="capsule" fromto="0 0 0 {thigh_m} 0 0" size="0.01"/>
          <body name="{leg}_shank" pos="{thigh_m} 0 0">
            <joint name="{leg}_knee" axis="0 1 0" range="-1.0 1.2"/>
            <inertial pos="0 0 {-shank_m / 2}" mass="{0.3 * link_kg}" diaginertia="{_rod_inertia(0.3 * link_kg, shank_m, 0.008)}"/>
            <geom type="capsule" fromto="0 0 0 0 0 {-shank_m}" size="0.006"/>
            <geom name="{leg}_foot" class="collide" type="sphere" pos="0 0 {-shank_m}" size="{foot_radius_m}"/>
            <site name="{leg}_foot" pos="0 0 {-shank_m}"/>
          </body>
        </body>
      </body>
""")
        for joint in ("yaw", "pitch", "knee"):
            toml.append(_joint_toml(f"{leg}_{joint}", servo, bus, 0.0))
            bus += 1
        legs.append(
            f'[legs.{leg}]\nfoot_site = "{leg}_foot"\n'
            f'joints = ["{leg}_yaw", "{leg}_pitch", "{leg}_knee"]\n\n'
        )
    xml.append("    </body>\n  </worldbody>\n</mujoco>\n")
    (folder / "robot.xml").write_text("".join(xml))
    (folder / "robot.toml").write_text("".join(toml + legs))
    return folder


def small_quadruped(
    folder: Path,
    *,
    servo: str = "XL330_M288",
    body_mass_kg: float = 0.01,
    thigh_m: float = 0.045,
    shank_m: float = 0.05,
    hip_pitch_deg: float = 37.0,
    foot_radius_m: float = 0.006,
    name: str = "mini4",
    head: bool = False,
) -> Path:
    """A 0.23 kg quadruped, legs 7.5 cm from hip to foot at stance, 18 g servos in every link;
    `head`: plus a head servo in no leg (robot.toml ``role = "hold"``)."""
    folder.mkdir(parents=True, exist_ok=True)
    servo_kg = 0.018
    knee_deg = -2 * hip_pitch_deg
    pitch = math.radians(hip_pitch_deg)
    height = (thigh_m + shank_m) * math.cos(pitch) + foot_radius_m
    xml = [_header(name, armature=0.0005, damping=0.005)]
    xml.append(f'    <body name="body" pos="0 0 {height:.4f}">\n      <freejoint name="root"/>\n')
    xml.append(
        f'      <inertial pos="0 0 0" mass="{body_mass_kg + 4 * servo_kg}" '
        f'diaginertia="2e-5 8e-5 9e-5"/>\n'
        f'      <geom name="body" class="collide" type="box" size="0.06 0.03 0.012"/>\n'
    )
    toml = [f'[robot]\nname = "{name}"\ndescription = "0.23 kg hobby quadruped (test robot)"\n'
            f"foot_radius_m = {foot_radius_m}\n\n"]
    legs = []
    bus = 1
    for leg, sx, sy in (("fl", 1, 1), ("fr", 1, -1), ("hl", -1, 1), ("hr", -1, -1)):
        xml.append(f"""      <body name="{leg}_hip" pos="{0.055 * sx} {0.03 * sy} 0">
        <joint name="{leg}_roll" axis="1 0 0" range="-0.5 0.5"/>
        <inertial pos="0 {0.01 * sy} 0" mass="{servo_kg}" diaginertia="2e-6 2e-6 2e-6"/>
        <body name="{leg}_thigh" pos="0 {0.02 * sy} 0">
          <joint name="{leg}_pitch" axis="0 1 0" range="-1.0 1.6"/>
          <inertial pos="0 0 {-thigh_m / 2}" mass="{servo_kg}" diaginertia="{_rod_inertia(servo_kg, thigh_m, 0.01)}"/>
          <geom type="capsule" fromto="0 0 0 0 0 {-thigh_m}" size="0.008"/>
          <body name="{leg}_shank" pos="0 0 {-thigh_m}">
            <joint name="{leg}_knee" axis="0 1 0" range="-2.4 -0.1"/>
            <inertial pos="0 0 {-shank_m / 2}" mass="0.002" diaginertia="{_rod_inertia(0.002, shank_m, 0.004)}"/>
            <geom type="capsule" fromto="0 0 0 0 0 {-shank_m}" size="0.004"/>
            <geom name="{leg}_foot" class="collide" type="sphere" pos="0 0 {-shank_m}" size="{foot_radius_m}"/>
            <site name="{leg}_foot" pos="0 0 {-shank_m}"/>
          </body>
        </body>
      </body>
""")
        for joint, stance in (("roll", 0.0), ("pitch", hip_pitch_deg), ("knee", knee_deg)):
            toml.append(_joint_toml(f"{leg}_{joint}", servo, bus, stance))
            bus += 1
        legs.append(
            f'[legs.{leg}]\nfoot_site = "{leg}_foot"\n'
            f'joints = ["{leg}_roll", "{leg}_pitch", "{leg}_knee"]\n\n'
        )
    if head:
        xml.append(f"""      <body name="head" pos="0.065 0 0.012">
        <joint name="head_pan" axis="0 0 1" range="-1 1"/>
        <inertial pos="0.01 0 0" mass="{servo_kg}" diaginertia="2e-6 2e-6 2e-6"/>
      </body>
""")
        toml.append(_joint_toml("head_pan", servo, bus, 0.0).replace(
            "stance_deg", 'role = "hold"\nstance_deg'))
    xml.append("    </body>\n  </worldbody>\n</mujoco>\n")
    (folder / "robot.xml").write_text("".join(xml))
    (folder / "robot.toml").write_text("".join(toml + legs))
    return folder


def quad12_with_torso_inertial(folder: Path, name: str, com_shift_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
                               inertia_turn_x_rad: float = 0.0) -> Path:
    """The built-in quad12 with its torso's inertial written out, its centre of mass moved by
    `com_shift_m` and its principal axes turned `inertia_turn_x_rad` about x: joints and feet
    still mirror, the dynamics do not (unless both are 0). Written to `folder` as `name`."""
    import mujoco
    import numpy as np

    import robots

    builtin = Path(robots.__file__).parent / "quad12"
    spec = mujoco.MjSpec.from_file(str(builtin / "robot.xml"))
    spec.compile()
    spec = mujoco.MjSpec.from_string(spec.to_xml())
    model = spec.compile()
    torso = spec.worldbody.first_body()
    c, s = math.cos(inertia_turn_x_rad), math.sin(inertia_turn_x_rad)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    tensor = turn @ np.diag(model.body_inertia[torso.id]) @ turn.T
    torso.explicitinertial = True
    torso.mass = float(model.body_mass[torso.id])
    torso.ipos = model.body_ipos[torso.id] + np.asarray(com_shift_m, dtype=float)
    torso.inertia, torso.iquat = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
    torso.fullinertia = tensor[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]
    folder.mkdir(parents=True)
    (folder / "robot.xml").write_text(spec.to_xml())
    toml = (builtin / "robot.toml").read_text().replace('name = "quad12"', f'name = "{name}"', 1)
    (folder / "robot.toml").write_text(toml)
    return folder


if __name__ == "__main__":  # pragma: no cover - convenience for the command line
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "robots_out")
    print(star_robot(out / "star5"))
    print(star_robot(out / "star3", 3, name="star3"))
    print(small_quadruped(out / "mini4"))

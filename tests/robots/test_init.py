"""`robots init`: URDF/MJCF → robot folder (legs, foot sites, stance, servo map, questions)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mujoco
import pytest

import robots
from robots.scaffold import Questions, ScaffoldError, init_robot
from sim.stand_check import check_stand
from tests.zoo.fixtures import SPOT_URDF, ZOO

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def _toml(folder: Path) -> dict:
    return tomllib.loads((folder / "robot.toml").read_text())


def test_regenerating_the_zoo_spotmicro_gives_the_committed_folder(tmp_path: Path) -> None:
    out = tmp_path / "spot"
    init_robot(SPOT_URDF, out, servo="STS3215_12V")
    committed = ZOO / "spotmicro"
    assert (out / "robot.xml").read_text() == (committed / "robot.xml").read_text()
    new, old = _toml(out), _toml(committed)
    assert new["robot"] == old["robot"] and new["legs"] == old["legs"]
    assert new["joints"].keys() == old["joints"].keys()
    for name, table in new["joints"].items():
        ref = old["joints"][name]
        assert math.isclose(table.pop("stance_deg"), ref.pop("stance_deg"), abs_tol=0.05), name
        assert table == ref


def test_spotmicro_legs_names_feet_and_bus_ids(tmp_path: Path) -> None:
    result = init_robot(SPOT_URDF, tmp_path / "s", servo="STS3215_12V", name="myspot")
    r = robots.load(tmp_path / "s")
    assert r.name == "myspot" and result.name == "myspot"
    assert r.foot_names == ("front_left", "front_right", "rear_left", "rear_right")
    assert r.legs[0].joints == ("fl_hip_roll", "fl_hip_pitch", "fl_knee")
    assert [j.bus_id for j in r.joints] == list(range(1, 13))
    assert r.joint_names[:3] == r.legs[0].joints
    assert r.foot_radius_m == pytest.approx(0.015)
    # limits from the URDF, stance inside them, feet on the ground with the body level
    knee = r.joint("fl_knee")
    assert (knee.lower_rad, knee.upper_rad) == pytest.approx((-2.5, -0.25))
    assert knee.lower_rad < knee.stance_rad < knee.upper_rad
    model = r.mj_model()
    data = mujoco.MjData(model)
    data.qpos[2] = r.stance_base_height_m
    data.qpos[3] = 1.0
    for j in r.joints:
        data.qpos[
            model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)]
        ] = j.stance_rad
    mujoco.mj_kinematics(model, data)
    for leg in r.legs:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)
        assert data.site_xpos[sid][2] == pytest.approx(r.foot_radius_m, abs=1e-3)
    # the URDF's fixed head link was merged into the body: mass kept (2.31 kg of links + head)
    assert r.mass_kg == pytest.approx(1.25 + 0.05 + 4 * (0.09 + 0.13 + 0.045))
    text = (tmp_path / "s" / "robot.toml").read_text()
    assert "What init decided" in text and "calibrate" in text
    # the URDF's effort limits (2.9 N·m) would cap the servo model: dropped, and said so
    assert any("effort limits of 12 joints" in n for n in result.notes)
    assert "actuatorfrcrange" not in (tmp_path / "s" / "robot.xml").read_text()


@pytest.mark.parametrize(
    ("name", "servo", "legs"),
    [
        ("bittle8", "XL330_M288", 4),
        ("humanoid20", "XL430_W250", 2),
        ("star5", "STS3215_7V4", 5),
        ("phantomx18", "AX_12A", 6),
    ],
)
def test_init_on_every_zoo_mjcf_gives_a_robot_that_stands(
    tmp_path: Path, name: str, servo: str, legs: int
) -> None:
    result = init_robot(ZOO / name / "robot.xml", tmp_path / name, servo=servo)
    r = robots.load(tmp_path / name)
    assert len(r.legs) == legs == len(result.legs)
    report = check_stand(r)
    assert report.stands, report.reasons
    assert report.worst.load_fraction < 0.5


def test_leg_names_by_position(tmp_path: Path) -> None:
    star = init_robot(ZOO / "star5" / "robot.xml", tmp_path / "star", servo="STS3215_7V4")
    assert [leg for leg, _ in star.legs] == ["leg_000", "leg_072", "leg_144", "leg_216", "leg_288"]
    hexa = init_robot(ZOO / "phantomx18" / "robot.xml", tmp_path / "hex", servo="AX_12A")
    assert [leg for leg, _ in hexa.legs] == [
        "front_left",
        "front_right",
        "middle_left",
        "middle_right",
        "rear_left",
        "rear_right",
    ]
    # the MJCF's own foot sites keep their names; init's get a suffix
    r = robots.load(tmp_path / "hex")
    assert all(leg.foot_site.endswith("_foot") for leg in r.legs)


def test_joints_outside_the_legs_are_held(tmp_path: Path) -> None:
    result = init_robot(ZOO / "humanoid20" / "robot.xml", tmp_path / "h", servo="XL430_W250")
    assert set(result.held) == {
        "neck_pan",
        "neck_tilt",
        *(f"{s}_{j}" for s in "lr" for j in ("shoulder_pitch", "shoulder_roll", "elbow")),
    }
    r = robots.load(tmp_path / "h")
    assert set(r.hold_joint_names) == set(result.held)
    joints = _toml(tmp_path / "h")["joints"]
    assert joints["l_elbow"]["role"] == "hold" and "role" not in joints["l_knee"]
    assert [leg for leg, _ in result.legs] == ["left", "right"]
    assert any("held" in n for n in result.notes)
    assert any("flat feet" in n for n in result.notes)


def test_box_soles_are_declared_flat_feet(tmp_path: Path) -> None:
    """A model whose feet are box soles gets `foot = "flat"` (before: point feet on the soles)."""
    init_robot(ZOO / "humanoid20" / "robot.xml", tmp_path / "h", servo="XL430_W250")
    legs = _toml(tmp_path / "h")["legs"]
    assert [table.get("foot") for table in legs.values()] == ["flat", "flat"]
    r = robots.load(tmp_path / "h")
    assert all(leg.is_flat for leg in r.legs)
    assert [leg.sole_geom for leg in r.legs] == ["l_sole", "r_sole"]
    assert [leg.sole_half_extents_m for leg in r.legs] == [(0.05, 0.03), (0.05, 0.03)]


def test_unnamed_box_feet_from_a_urdf_are_declared_flat(tmp_path: Path) -> None:
    text = SPOT_URDF.read_text().replace(
        '<geometry><sphere radius="0.015"/></geometry>',
        '<geometry><box size="0.04 0.03 0.01"/></geometry>',
    )
    (tmp_path / "boxspot.urdf").write_text(text)
    result = init_robot(tmp_path / "boxspot.urdf", tmp_path / "robot", servo="STS3215_12V")
    assert any('foot = "flat"' in n for n in result.notes)
    r = robots.load(tmp_path / "robot")
    assert len(r.legs) == 4 and all(leg.is_flat and leg.sole_geom for leg in r.legs)
    assert all(leg.sole_half_extents_m == pytest.approx((0.02, 0.015)) for leg in r.legs)


def test_without_a_servo_it_stops_and_says_pass_servo(tmp_path: Path) -> None:
    with pytest.raises(ScaffoldError, match="pass --servo") as err:
        init_robot(SPOT_URDF, tmp_path / "x")
    assert "\n" not in str(err.value)
    assert not (tmp_path / "x").exists()
    assert list(tmp_path.iterdir()) == []  # nothing half-written


def test_servo_question_is_asked_when_someone_can_answer(tmp_path: Path) -> None:
    asked: list[list[str]] = []

    def servo(known: list[str]) -> str:
        asked.append(known)
        return "STS3215_12V"

    init_robot(SPOT_URDF, tmp_path / "q", questions=Questions(servo=servo))
    assert asked and "STS3215_12V" in asked[0]
    assert robots.load(tmp_path / "q").joints[0].servo.name == "STS3215_12V"


def test_unknown_servo_and_non_empty_folder_are_one_line_errors(tmp_path: Path) -> None:
    with pytest.raises(ScaffoldError, match="unknown servo model 'NOPE'"):
        init_robot(SPOT_URDF, tmp_path / "a", servo="NOPE")
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "keep.txt").write_text("mine")
    with pytest.raises(ScaffoldError, match="not empty"):
        init_robot(SPOT_URDF, tmp_path / "b", servo="STS3215_12V")
    assert (tmp_path / "b" / "keep.txt").read_text() == "mine"


def _with_continuous_tail(tmp_path: Path) -> Path:
    text = SPOT_URDF.read_text().replace(
        "</robot>",
        '  <link name="tail"><inertial><mass value="0.02"/><inertia ixx="1e-6" iyy="1e-6" '
        'izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>\n'
        '    <collision><origin xyz="-0.03 0 0"/><geometry><box size="0.06 0.01 0.01"/>'
        "</geometry></collision></link>\n"
        '  <joint name="tail_wag" type="continuous"><parent link="body"/><child link="tail"/>'
        '<origin xyz="-0.12 0 0.03"/><axis xyz="0 0 1"/></joint>\n</robot>',
    )
    path = tmp_path / "tailspot.urdf"
    path.write_text(text)
    return path


def test_continuous_joint_is_asked_or_reported_never_guessed(tmp_path: Path) -> None:
    urdf = _with_continuous_tail(tmp_path)
    with pytest.raises(ScaffoldError, match=r"tail_wag.*--limit tail_wag=LOWER,UPPER"):
        init_robot(urdf, tmp_path / "a", servo="STS3215_12V")
    result = init_robot(
        urdf, tmp_path / "b", servo="STS3215_12V", limits_deg={"tail_wag": (-60.0, 60.0)}
    )
    assert result.held == ("tail_wag",)
    r = robots.load(tmp_path / "b")
    tail = r.joint("tail_wag")
    assert (tail.lower_rad, tail.upper_rad) == pytest.approx(
        (math.radians(-60), math.radians(60)), abs=1e-4
    )
    asked: list[str] = []

    def limits(joint: str) -> tuple[float, float]:
        asked.append(joint)
        return (-30.0, 30.0)

    init_robot(urdf, tmp_path / "c", servo="STS3215_12V", questions=Questions(limits_deg=limits))
    assert asked == ["tail_wag"]


def test_servo_reach_narrows_the_limits_with_a_note(tmp_path: Path) -> None:
    # AX-12A reaches ±150° around its centre; the tail asks for ±170°
    urdf = _with_continuous_tail(tmp_path)
    result = init_robot(urdf, tmp_path / "n", servo="AX_12A", limits_deg={"tail_wag": (-170, 170)})
    assert any("narrowed" in n and "tail_wag" in n for n in result.notes)
    tail = robots.load(tmp_path / "n").joint("tail_wag")
    assert tail.upper_rad < math.radians(151)


CUBE_OBJ = "\n".join(
    [f"v {x} {y} {z}" for x in (-0.01, 0.01) for y in (-0.01, 0.01) for z in (-0.01, 0.01)]
    + [
        "f 1 2 4 3",
        "f 5 7 8 6",
        "f 1 5 6 2",
        "f 3 4 8 7",
        "f 1 3 7 5",
        "f 2 6 8 4",
    ]
)


def test_mesh_feet_are_copied_and_resolve_from_any_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    src = tmp_path / "src"
    (src / "meshes").mkdir(parents=True)
    (src / "meshes" / "foot.obj").write_text(CUBE_OBJ)
    text = SPOT_URDF.read_text().replace(
        '<geometry><sphere radius="0.015"/></geometry>',
        '<geometry><mesh filename="package://spot_description/meshes/foot.obj"/></geometry>',
    )
    (src / "spot.urdf").write_text(text)
    out = tmp_path / "robot"
    result = init_robot(src / "spot.urdf", out, servo="STS3215_12V")
    assert (out / "assets" / "foot.obj").is_file()
    assert 'file="assets/foot.obj"' in (out / "robot.xml").read_text()
    # a mesh sole cannot be sized by the loader: a point foot, and the note says how to declare it
    assert any("flat soles that are not one upright box" in n for n in result.notes)
    assert all("foot" not in leg for leg in _toml(out)["legs"].values())
    monkeypatch.chdir(tmp_path / "src")
    r = robots.load(out)
    assert check_stand(r).stands


def test_bad_model_file_is_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot><link name='a'/><joint name='j' type='revolute'>")
    with pytest.raises(ScaffoldError, match=r"bad\.urdf") as err:
        init_robot(bad, tmp_path / "o", servo="STS3215_12V")
    assert "\n" not in str(err.value)
    (tmp_path / "robot.stl").write_bytes(b"solid x")
    with pytest.raises(ScaffoldError, match=r"\.urdf or an MJCF"):
        init_robot(tmp_path / "robot.stl", tmp_path / "o", servo="STS3215_12V")


def test_menagerie_style_model_with_include_mesh_and_two_geom_foot(tmp_path: Path) -> None:
    """intake's heldquad fixture: own actuators, no floor, an included mesh head, a held arm
    without a range, a front-left foot of two spheres (neither may sink into the ground)."""
    src = Path(__file__).parent / "fixtures" / "heldquad" / "robot.xml"
    with pytest.raises(ScaffoldError, match="--limit arm_lift="):
        init_robot(src, tmp_path / "a", servo="STS3215_7V4")
    result = init_robot(
        src, tmp_path / "b", servo="STS3215_7V4", limits_deg={"arm_lift": (-45.0, 45.0)}
    )
    assert set(result.held) == {"head_pan", "arm_lift"}
    assert (tmp_path / "b" / "assets" / "head.obj").is_file()
    assert any("actuators" in n for n in result.notes) and any("floor" in n for n in result.notes)
    report = check_stand(robots.load(tmp_path / "b"))
    assert report.stands, report.reasons


def test_ros_style_base_footprint_root(tmp_path: Path) -> None:
    """A URDF rooted at a massless `base_footprint` on the ground, the body fixed 0.2 m above it:
    MuJoCo fuses them, the root frame sits near the floor, and the robot still stands."""
    text = SPOT_URDF.read_text().replace(
        '<robot name="spotmicro">',
        '<robot name="spotmicro">\n  <link name="base_footprint"/>\n'
        '  <joint name="footprint_joint" type="fixed"><parent link="base_footprint"/>'
        '<child link="body"/><origin xyz="0 0 0.2"/></joint>',
    )
    urdf = tmp_path / "footprint.urdf"
    urdf.write_text(text)
    result = init_robot(urdf, tmp_path / "fp", servo="STS3215_12V")
    assert result.base_height_m < 0.05  # the root frame, not the body, is what stands that low
    report = check_stand(robots.load(tmp_path / "fp"))
    assert report.stands, report.reasons


WAIST_MJCF = """<mujoco model="waisted">
  <worldbody>
    <body name="pelvis" pos="0 0 0.3">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.02" mass="0.5"/>
      <body name="waist">
        <joint name="waist_yaw" axis="0 0 1" range="-1 1"/>
        <geom type="box" size="0.02 0.02 0.02" mass="0.1"/>
        <body name="l" pos="0 0.04 0">
          <joint name="l_hip" axis="0 1 0" range="-1 1"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.01" mass="0.1"/>
        </body>
        <body name="r" pos="0 -0.04 0">
          <joint name="r_hip" axis="0 1 0" range="-1 1"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.01" mass="0.1"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_joint_carrying_several_legs_is_reported_not_guessed(tmp_path: Path) -> None:
    (tmp_path / "waisted.xml").write_text(WAIST_MJCF)
    with pytest.raises(ScaffoldError, match=r"waist_yaw.*carry several limbs"):
        init_robot(tmp_path / "waisted.xml", tmp_path / "o", servo="XL430_W250")


def test_joints_without_armature_get_the_servos_identified_rotor(tmp_path: Path) -> None:
    """A URDF has no rotor inertia; init writes the servo's identified one (robots/servos.toml)
    and says so; for a servo without a published figure it says what to add."""
    knee8 = ZOO / "urdf" / "knee8.urdf"
    result = init_robot(knee8, tmp_path / "k", servo="STS3215_7V4")
    r = robots.load(tmp_path / "k")
    model = r.mj_model()
    for j in r.joint_names:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        assert model.dof_armature[model.jnt_dofadr[jid]] == pytest.approx(0.0284), j
    assert any("identified 0.0284 kg·m²" in n for n in result.notes)
    unknown = init_robot(knee8, tmp_path / "k12", servo="STS3215_12V")
    model = robots.load(tmp_path / "k12").mj_model()
    assert not model.dof_armature[6:].any()
    assert any("no identified figure is known for STS3215_12V" in n for n in unknown.notes)

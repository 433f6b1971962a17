"""A user's robot, as they have it (issue #13): user servo models, held joints, an ordinary MJCF
(own actuators, no floor, meshes and includes, a two-geom foot, a joint without range)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

import robots
from robots import RobotConfigError
from robots.robot import damping_budget

FIXTURES = Path(__file__).parent / "fixtures"
HELDQUAD = FIXTURES / "heldquad"


@pytest.fixture
def heldquad(tmp_path: Path) -> Path:
    dst = tmp_path / "heldquad"
    shutil.copytree(HELDQUAD, dst)
    return dst


def _servo_table(name: str, stall_nm: float) -> str:
    return f"""[{name}]
vendor = "Feetech"
protocol = "feetech_sts"
model_number = 777
nominal_voltage_v = 7.4
voltage_min_v = 6.0
voltage_max_v = 8.4
stall_torque_nm = {stall_nm}
no_load_speed_rad_s = 4.717
ticks_per_rev = 4096
position_min_tick = 0
position_max_tick = 4095
default_baud = 1000000
mass_kg = 0.055
max_temperature_c = 70.0
"""


def test_held_joints_user_servo_and_prepared_model() -> None:
    r = robots.load(HELDQUAD)
    assert r.hold_joint_names == ("head_pan", "arm_lift")
    assert r.joint_names[:2] == ("head_pan", "arm_lift") and r.dof == 14
    assert all(n not in leg.joints for leg in r.legs for n in r.hold_joint_names)
    assert r.joint("head_pan").servo.name == "MY_STS"  # from robot.toml's [servos]
    arm = r.joint("arm_lift")  # no MJCF range: limits_deg is its range
    assert (arm.lower_rad, arm.upper_rad) == pytest.approx((-np.pi / 3, np.pi / 3))
    notices = " | ".join(r.notices)
    assert "removed its 2 actuator(s) and 1 actuator sensor(s)" in notices
    assert "no floor" in notices and "gs_floor" in notices
    assert r.legs[0].foot_body == "fl_shank" and len(r.legs[0].foot_geoms) == 2
    model = r.mj_model()
    assert model.nu == 0 and model.nmesh == 1
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "arm_lift")
    assert model.jnt_limited[jid]
    # head and arm masses count exactly as modelled
    assert r.mass_kg == pytest.approx(robots.load("quad12").mass_kg + 0.08 + 0.06)


def test_loads_from_any_directory_and_prepared_xml_works_anywhere(
    heldquad: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    r = robots.load(heldquad)
    (elsewhere / "copy.xml").write_text(r.prepared.xml)  # type: ignore[union-attr]
    model = mujoco.MjModel.from_xml_path(str(elsewhere / "copy.xml"))
    assert model.nmesh == 1 and model.nu == 0
    monkeypatch.chdir(heldquad / "parts")  # relative folder path from a sub-folder
    assert robots.load(Path("..")).fingerprint == r.fingerprint


def test_servo_precedence_robot_toml_then_file_then_builtin(
    heldquad: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cat = tmp_path / "my_servos.toml"
    cat.write_text(_servo_table("MY_STS", 9.0) + "\n" + _servo_table("STS3215_7V4", 2.5))
    plain = robots.load(heldquad)
    r = robots.load(heldquad, servo_catalogue=cat)
    assert r.joint("head_pan").servo.stall_torque_nm == 1.912  # robot.toml's [servos] wins
    assert r.joint("fl_knee").servo.stall_torque_nm == 2.5  # the file beats the built-in
    assert plain.joint("fl_knee").servo.stall_torque_nm == 1.912
    assert r.fingerprint != plain.fingerprint  # other servo figures, other build
    monkeypatch.setenv("GAITSMITH_SERVOS", str(cat))
    assert robots.load(heldquad).fingerprint == r.fingerprint
    monkeypatch.setenv("GAITSMITH_SERVOS", str(tmp_path / "missing.toml"))
    with pytest.raises(RobotConfigError, match="GAITSMITH_SERVOS"):
        robots.load(heldquad)


def test_user_servo_tables_get_the_catalogue_validation(heldquad: Path) -> None:
    toml = heldquad / "robot.toml"
    toml.write_text(toml.read_text().replace("stall_torque_nm = 1.912", "stall_torque_nm = 1e308"))
    with pytest.raises(RobotConfigError) as info:
        robots.load(heldquad)
    assert info.value.field == "[servos.MY_STS].stall_torque_nm"
    toml.write_text(toml.read_text().replace("stall_torque_nm = 1e308\n", ""))
    with pytest.raises(RobotConfigError, match=r"\[servos.MY_STS\].stall_torque_nm: missing"):
        robots.load(heldquad)


def _drop_table(text: str, table: str) -> str:
    return re.sub(rf"\[{re.escape(table)}\]\n(?:[^\[\n].*\n|\n)*", "", text)


def test_unmapped_and_misplaced_joints_say_what_to_do(heldquad: Path) -> None:
    toml = heldquad / "robot.toml"
    original = toml.read_text()
    toml.write_text(_drop_table(original, "joints.head_pan"))
    with pytest.raises(RobotConfigError) as info:
        robots.load(heldquad)
    assert info.value.field == "[joints.head_pan]"
    assert "add a [joints.head_pan] table" in str(info.value) and 'role = "hold"' in str(info.value)
    toml.write_text(original.replace('role = "hold"\nbus_id = 13', "bus_id = 13"))
    with pytest.raises(RobotConfigError, match=r"\[joints.head_pan\]: .*in no leg.*role"):
        robots.load(heldquad)
    toml.write_text(
        original.replace('joints = ["fl_hip_roll"', 'joints = ["head_pan", "fl_hip_roll"')
    )
    with pytest.raises(RobotConfigError, match=r"\[legs.fl\].joints: joint 'head_pan' has role"):
        robots.load(heldquad)


def test_joint_without_range_names_both_fixes(heldquad: Path) -> None:
    toml = heldquad / "robot.toml"
    toml.write_text(toml.read_text().replace("limits_deg = [-60, 60]\n", ""))
    with pytest.raises(RobotConfigError) as info:
        robots.load(heldquad)
    msg = str(info.value)
    assert "joint arm_lift" in msg and 'range="lo hi"' in msg
    assert "limits_deg = [lo, hi] to [joints.arm_lift]" in msg
    xml = heldquad / "robot.xml"
    toml.write_text(
        toml.read_text().replace(
            "stance_deg = -20.0\n", "stance_deg = -20.0\nlimits_deg = [-60, 60]\n"
        )
    )
    xml.write_text(
        xml.read_text().replace('range="-0.6 0.6"', 'range="-0.6 0.6" limited="false"', 1)
    )
    with pytest.raises(RobotConfigError, match=r"joint fl_hip_roll.*limits_deg"):
        robots.load(heldquad)


def test_held_robot_stands_in_sim_and_a_two_geom_foot_is_one_foot() -> None:
    from sim.model import build_sim_model
    from sim.synthetic import standing_gait
    from sim.validate import validate

    r = robots.load(HELDQUAD)
    sim = build_sim_model(r)
    assert len(sim.foot_geoms[0]) == 2 and sim.model.nu == r.dof  # gaitsmith's servos only
    res = validate(standing_gait(r), r, cycles=4)
    assert res.passed, res.reasons  # before: "body touched the ground" at t = 0.01 s
    assert not res.metrics.fell


def test_mjcf_damping_double_counting_is_flagged_and_overridable(quad_copy: Path) -> None:
    xml = quad_copy / "robot.xml"
    xml.write_text(xml.read_text().replace('damping="0.05"', 'damping="4.0"'))
    budget = damping_budget(robots.load(quad_copy))
    assert all(b.flag and "likely models the motor again" in b.flag for b in budget)
    assert budget[0].damping_share == pytest.approx(4.0 * 0.5 * 4.717 / 1.912)
    toml = quad_copy / "robot.toml"
    toml.write_text(
        toml.read_text().replace(
            "stance_deg = 0.0\n", "stance_deg = 0.0\ndamping_nm_s_per_rad = 0.05\n"
        )
    )
    r = robots.load(quad_copy)
    fixed = {b.joint: b for b in damping_budget(r)}
    # fl_hip_roll's damping is fixed; its armature (0.006) stays below the STS3215's identified
    # rotor inertia (0.0284), which is flagged on its own
    assert "models the motor again" not in str(fixed["fl_hip_roll"].flag)
    assert "models the motor again" in str(fixed["fl_knee"].flag)
    model = r.mj_model()  # the one prepared model planner and sim build from
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "fl_hip_roll")
    assert model.dof_damping[model.jnt_dofadr[jid]] == pytest.approx(0.05)
    # the built-in quad12 models its STS3215 rotors at 21 % of the identified inertia
    # (docs/results/servo_armature.md): said, for every joint
    builtin = damping_budget(robots.load("quad12"))
    assert all("identified rotor inertia" in str(b.flag) for b in builtin)


def test_armature_below_the_servos_identified_rotor_is_flagged_the_real_one_is_not(
    quad_copy: Path,
) -> None:
    xml = quad_copy / "robot.xml"
    light = {b.joint: b for b in damping_budget(robots.load(quad_copy))}
    assert "0.006 kg·m² is 21% of STS3215_7V4's identified rotor inertia 0.0284" in str(
        light["fl_knee"].flag
    )
    xml.write_text(xml.read_text().replace('armature="0.006"', 'armature="0.0284"'))
    real = damping_budget(robots.load(quad_copy))
    # the real rotor takes > 25 % of the stall torque at a 2 Hz swing, but that is the servo,
    # not a modelling mistake: no flag
    assert all(b.armature_share > 0.25 and b.flag is None for b in real)
    xml.write_text(xml.read_text().replace('armature="0.0284"', 'armature="0.1"'))
    heavy = damping_budget(robots.load(quad_copy))
    assert all("check damping_nm_s_per_rad" in str(b.flag) for b in heavy)


@pytest.mark.slow
def test_planner_holds_held_joints_and_checks_their_torque() -> None:
    from planner.nlp.spacetime import GaitPlanner
    from planner.templates import make_schedule
    from sim.validate import simulate, validate

    r = robots.load(HELDQUAD)
    planner = GaitPlanner(r, n_knots=16)
    result = planner.solve(make_schedule(r, "trot"), 0.15, warm_start=False)
    assert result.feasible, result.message
    gait = planner.to_gait(result, "trot")
    held = [r.joint_names.index(n) for n in r.hold_joint_names]
    stance = np.asarray(r.nominal_stance_rad)[held]
    expected = np.asarray(gait.expected_joint_angles_rad)[:, held]
    np.testing.assert_allclose(expected, np.tile(stance, (16, 1)), atol=1e-9)
    torques = np.asarray(gait.joint_torques_nm)[:, held]
    assert np.max(np.abs(torques[:, 1])) > 0.01  # the arm's holding torque is computed …
    assert np.max(np.abs(torques)) < 0.8 * 1.912  # … and within its servo's envelope
    # in MuJoCo the servos hold them at stance while the robot walks (the one-sided arm makes
    # it veer, so the heading check is not this test's business)
    result = validate(gait, r, cycles=4)
    assert not result.metrics.fell, result.reasons
    _, traj = simulate(gait, r, cycles=4)
    walking = traj.time_s >= traj.gait_start_s
    np.testing.assert_allclose(
        traj.q_rad[walking][:, held], np.tile(stance, (walking.sum(), 1)), atol=np.radians(2.0)
    )

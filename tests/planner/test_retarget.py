"""Retargeting a gait to another body (planner.retarget, planner.hybrid_body, `gaitsmith
retarget`): Froude scaling, leg matching by position, hybrid MJCFs, and one end-to-end run."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

import robots
import robots.gait as gait_io
from gaitsmith import cli
from planner.hybrid_body import HybridBodyError, hybrid_robot, match_bodies
from planner.retarget import (
    Motion,
    RetargetError,
    froude_number,
    map_motion,
    match_legs,
)
from planner.templates import leg_roles, make_schedule, stance_foot_positions_m

BUILTIN = Path(robots.__file__).parent


def scaled_copy(name: str, folder: Path, leg_scale: float, *, reverse_legs: bool = False,
                rename: str = "") -> Path:
    """A copy of a built-in robot with every link below the root scaled by `leg_scale` and
    every mass by leg_scale³ (inertias by leg_scale⁵); optionally its legs listed in reverse
    order in robot.toml and its bodies renamed with a prefix (same tree, other names)."""
    xml = BUILTIN / name / "robot.xml"
    spec = mujoco.MjSpec.from_file(str(xml))
    spec.compile()
    spec = mujoco.MjSpec.from_string(spec.to_xml())  # geoms as pos/size (no fromto)
    model = mujoco.MjModel.from_xml_path(str(xml))
    root = spec.body(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.jnt_bodyid[0])))
    root.mass *= leg_scale**3
    root.inertia = np.asarray(root.inertia) * leg_scale**3

    def scale(body: mujoco.MjsBody) -> None:
        for child in body.bodies:
            child.pos = np.asarray(child.pos) * leg_scale
            child.mass *= leg_scale**3
            child.inertia = np.asarray(child.inertia) * leg_scale**5
            child.ipos = np.asarray(child.ipos) * leg_scale
            for geom in child.geoms:
                geom.size = np.asarray(geom.size) * leg_scale
                geom.pos = np.asarray(geom.pos) * leg_scale
            for site in child.sites:
                site.pos = np.asarray(site.pos) * leg_scale
            if rename:
                child.name = rename + child.name
            scale(child)

    scale(root)
    folder.mkdir(parents=True)
    (folder / "robot.xml").write_text(spec.to_xml())
    toml = (BUILTIN / name / "robot.toml").read_text()
    toml = toml.replace(f'name = "{name}"', f'name = "{folder.name}"', 1)
    if reverse_legs:
        head, *legs = re.split(r"(?m)^(?=\[legs\.)", toml)
        toml = head + "".join(block.rstrip("\n") + "\n\n" for block in reversed(legs))
    (folder / "robot.toml").write_text(toml)
    return folder


@pytest.fixture(scope="module")
def small_quad(tmp_path_factory: pytest.TempPathFactory) -> robots.Robot:
    folder = tmp_path_factory.mktemp("bodies") / "quad_small"
    return robots.load(scaled_copy("quad12", folder, 0.6, reverse_legs=True, rename="s_"))


def _motion(robot: robots.Robot, gait: str, speed_m_s: float, n_knots: int = 12) -> Motion:
    schedule = make_schedule(robot, gait)
    q = np.tile(np.asarray(robot.nominal_stance_rad), (n_knots, 1))
    q += 0.1 * np.sin(2 * np.pi * np.arange(n_knots) / n_knots)[:, None]
    base = np.zeros((n_knots, 6))
    base[:, 2] = robot.stance_base_height_m
    forces = np.zeros((n_knots, len(robot.legs), 3))
    forces[:, :, 2] = schedule.contact_matrix(n_knots)
    return Motion(robot, schedule, speed_m_s, base, q, forces, np.zeros_like(q))


def test_leg_counts_that_differ_are_refused_in_one_line() -> None:
    with pytest.raises(RetargetError, match=r"quad12 \(4 legs\) to hex18 \(6 legs\)"):
        match_legs(robots.load("quad12"), robots.load("hex18"))


def test_legs_match_by_position_not_by_order(small_quad: robots.Robot) -> None:
    quad = robots.load("quad12")
    match = match_legs(quad, small_quad)
    assert small_quad.foot_names == ("hr", "hl", "fr", "fl")
    for s, t in enumerate(match.target_foot):
        assert small_quad.foot_names[t] == quad.foot_names[s]  # same role, other index
    for jt, js in enumerate(match.joint_source):
        assert quad.joint_names[js] == small_quad.joint_names[jt]
    assert match.joint_sign == (1.0,) * 12


def test_two_joint_legs_take_the_pitch_joints(tmp_path: Path) -> None:
    """A quadruped without hip-roll joints (2 per leg, like a Bittle): shoulder and knee take
    quad12's hip pitch and knee; nothing is held at its stance."""
    folder = tmp_path / "noroll"
    shutil.copytree(BUILTIN / "quad12", folder)
    xml = re.sub(r'<joint name="\w+_hip_roll"[^>]*/>', "", (folder / "robot.xml").read_text())
    (folder / "robot.xml").write_text(xml)
    toml = (folder / "robot.toml").read_text().replace('name = "quad12"', 'name = "noroll"', 1)
    toml = re.sub(r"(?ms)^\[joints\.\w+_hip_roll\].*?(?=^\[)", "", toml)
    toml = re.sub(r'"\w+_hip_roll", ', "", toml)
    (folder / "robot.toml").write_text(toml)
    quad, noroll = robots.load("quad12"), robots.load(folder)
    match = match_legs(quad, noroll)
    assert [quad.joint_names[s] for s in match.joint_source] == [
        n for n in quad.joint_names if not n.endswith("hip_roll")]


def test_froude_scaling_keeps_fr_duty_and_phases_by_role(small_quad: robots.Robot) -> None:
    quad = robots.load("quad12")
    motion = _motion(quad, "trot", 0.25)
    mapped = map_motion(motion, small_quad, match_legs(quad, small_quad))
    factor = math.sqrt(small_quad.leg_length_m / quad.leg_length_m)
    assert mapped.speed_m_s == pytest.approx(0.25 * factor, rel=1e-12)
    assert mapped.schedule.period_s == pytest.approx(motion.schedule.period_s * factor, rel=1e-12)
    assert froude_number(mapped.speed_m_s, small_quad.leg_length_m) == pytest.approx(
        froude_number(0.25, quad.leg_length_m), rel=1e-12)
    roles_s, roles_t = leg_roles(quad), leg_roles(small_quad)
    for role, fs in roles_s.items():
        ft = roles_t[role]
        assert mapped.schedule.touchdown_phase[ft] == motion.schedule.touchdown_phase[fs]
        assert mapped.schedule.duty_factor[ft] == motion.schedule.duty_factor[fs]
        np.testing.assert_array_equal(mapped.forces_mg[:, ft], motion.forces_mg[:, fs])
    # the base height follows the leg length; joint motion is kept as offsets from the stance
    assert mapped.base_pose[0, 2] == pytest.approx(small_quad.stance_base_height_m)
    np.testing.assert_allclose(
        mapped.joint_angles_rad - np.asarray(small_quad.nominal_stance_rad),
        (motion.joint_angles_rad - np.asarray(quad.nominal_stance_rad))[
            :, [quad.joint_names.index(n) for n in small_quad.joint_names]],
        atol=1e-12)


def test_hybrid_bodies_interpolate_lengths_and_masses(
    small_quad: robots.Robot, tmp_path: Path
) -> None:
    quad = robots.load("quad12")
    match = match_legs(quad, small_quad)
    pairs = match_bodies(quad, small_quad, match.target_foot)
    assert ("fl_shank", "s_fl_shank") in pairs.pairs
    ends = [hybrid_robot(quad, small_quad, pairs, a, tmp_path / f"h{a}") for a in (0.0, 0.5, 1.0)]
    assert ends[0].leg_length_m == pytest.approx(quad.leg_length_m, rel=1e-6)
    assert ends[0].mass_kg == pytest.approx(quad.mass_kg, rel=1e-6)
    assert ends[2].leg_length_m == pytest.approx(small_quad.leg_length_m, rel=1e-6)
    assert ends[2].mass_kg == pytest.approx(small_quad.mass_kg, rel=1e-6)
    assert ends[1].mass_kg == pytest.approx(0.5 * (quad.mass_kg + small_quad.mass_kg), rel=1e-6)
    assert quad.leg_length_m > ends[1].leg_length_m > small_quad.leg_length_m
    assert ends[1].joint_names == quad.joint_names  # hybrids keep the source's servo map


def _body_tensor(robot: robots.Robot, body: str) -> np.ndarray:
    """A body's inertia tensor about its centre of mass, in its own frame."""
    model = robot.mj_model()
    b = model.body(body).id
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, model.body_iquat[b])
    rot = mat.reshape(3, 3)
    return rot @ np.diag(model.body_inertia[b]) @ rot.T


def test_hybrid_inertias_blend_the_tensors_and_keep_the_mirror_symmetry(tmp_path: Path) -> None:
    """quad12's torso has principal axes along its frame, spotmicro's turned half a turn about
    an axis in the x–z plane: the hybrid's tensor is the blend of the two tensors, with no
    product of inertia the y → −y mirror lacks (blending the principal axes' quaternions tilted
    it about x, and the half-cycle solve of that hybrid broke the full NLP's dynamics rows)."""
    quad = robots.load("quad12")
    spot = robots.load(Path(__file__).parents[1] / "zoo" / "spotmicro")
    pairs = match_bodies(quad, spot, match_legs(quad, spot).target_foot)
    torso_q, torso_s = quad.mj_model().body(1).name, spot.mj_model().body(1).name
    assert (torso_q, torso_s) in pairs.pairs
    alpha = 1.0 / 3.0
    mid = hybrid_robot(quad, spot, pairs, alpha, tmp_path / "mid")
    blend = (1 - alpha) * _body_tensor(quad, torso_q) + alpha * _body_tensor(spot, torso_s)
    got = _body_tensor(mid, torso_q)
    np.testing.assert_allclose(got, blend, atol=1e-5 * np.abs(blend).max())  # the MJCF text
    assert abs(got[0, 1]) + abs(got[1, 2]) < 1e-9 * np.abs(blend).max()  # mirror-symmetric
    end = hybrid_robot(quad, spot, pairs, 1.0, tmp_path / "end")
    np.testing.assert_allclose(_body_tensor(end, torso_q), _body_tensor(spot, torso_s),
                               atol=1e-5 * np.abs(blend).max())  # the MJCF text


def knee_rezeroed_copy(folder: Path, shift_rad: float) -> Path:
    """quad12 with every knee's zero moved by `shift_rad` (shank contents rotated about the
    knee, range and stance shifted back): the same body in space, another joint convention."""
    spec = mujoco.MjSpec.from_file(str(BUILTIN / "quad12" / "robot.xml"))
    spec.compile()
    spec = mujoco.MjSpec.from_string(spec.to_xml())
    c, s = math.cos(shift_rad / 2), math.sin(shift_rad / 2)
    quat = np.array([c, 0.0, s, 0.0])  # about +y, the knee axis
    rot = np.array([[math.cos(shift_rad), 0, math.sin(shift_rad)], [0, 1, 0],
                    [-math.sin(shift_rad), 0, math.cos(shift_rad)]])
    for leg in ("fl", "fr", "hl", "hr"):
        shank = spec.body(f"{leg}_shank")
        for item in (*shank.geoms, *shank.sites):
            item.pos = rot @ np.asarray(item.pos)
            q = np.zeros(4)
            mujoco.mju_mulQuat(q, quat, np.asarray(item.quat, dtype=float))
            item.quat = q
        shank.ipos = rot @ np.asarray(shank.ipos)
        knee = spec.joint(f"{leg}_knee")
        knee.range = np.asarray(knee.range) - shift_rad
    folder.mkdir(parents=True)
    (folder / "robot.xml").write_text(spec.to_xml())
    toml = (BUILTIN / "quad12" / "robot.toml").read_text().replace(
        'name = "quad12"', 'name = "quad12_knee"', 1)
    toml = toml.replace("stance_deg = -80.0", f"stance_deg = {-80.0 - math.degrees(shift_rad)}")
    (folder / "robot.toml").write_text(toml)
    return folder


def test_hybrids_blend_in_the_stance_pose_across_joint_conventions(tmp_path: Path) -> None:
    """Source quad12, target the same body with its knees zeroed 69° elsewhere: every blend is
    that body again (a blend of the two zero poses would fold the shank: a shorter leg)."""
    quad = robots.load("quad12")
    same = robots.load(knee_rezeroed_copy(tmp_path / "knee", -1.2))
    np.testing.assert_allclose(stance_foot_positions_m(same), stance_foot_positions_m(quad),
                               atol=1e-6)  # the copy is the same body
    pairs = match_bodies(quad, same, match_legs(quad, same).target_foot)
    mid = hybrid_robot(quad, same, pairs, 0.5, tmp_path / "mid")
    np.testing.assert_allclose(stance_foot_positions_m(mid), stance_foot_positions_m(quad),
                               atol=1e-5)  # blending a body with itself changes nothing
    end = hybrid_robot(quad, same, pairs, 1.0, tmp_path / "end")
    assert end.joint("fl_knee").lower_rad == pytest.approx(quad.joint("fl_knee").lower_rad)


def test_hybrids_between_different_trees_are_refused(tmp_path: Path) -> None:
    quad = robots.load("quad12")
    folder = tmp_path / "longshank"
    shutil.copytree(BUILTIN / "quad12", folder)
    xml = (folder / "robot.xml").read_text()
    # a foot body under the hind-right shank: one more body on that chain
    foot_geom = ('<geom name="hr_foot" class="collide" type="sphere" pos="0 0 -0.12" '
                 'size="0.012" rgba="0.1 0.1 0.1 1"/>')
    assert foot_geom in xml
    xml = xml.replace(foot_geom, "").replace(
        '<site name="hr_foot" pos="0 0 -0.12" size="0.005"/>',
        '<body name="hr_toe" pos="0 0 -0.12"><inertial pos="0 0 0" mass="0.01" '
        'diaginertia="1e-6 1e-6 1e-6"/><geom name="hr_foot" class="collide" type="sphere" '
        'size="0.012"/><site name="hr_foot" pos="0 0 0" size="0.005"/></body>')
    (folder / "robot.xml").write_text(xml)
    other = robots.load(folder)
    with pytest.raises(HybridBodyError, match="bodies"):
        match_bodies(quad, other, match_legs(quad, other).target_foot)


def test_retarget_refuses_other_leg_counts_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    quad = robots.load("quad12")
    schedule = make_schedule(quad, "trot")
    n = 12
    gait = gait_io.Gait.create(
        robot=quad, knots_rad=np.tile(np.asarray(quad.nominal_stance_rad), (n, 1)),
        schedule=schedule, velocity=gait_io.Velocity(0.2), gait_label="trot")
    src = tmp_path / "trot.json"
    gait_io.save(gait, src)
    out = tmp_path / "out.json"
    assert cli.main(["retarget", str(src), "--to", "hex18", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "4 legs" in err and "6 legs" in err and "Traceback" not in err
    assert not out.exists()
    assert cli.main(["retarget", str(src), "--to", "hex18", "--steps", "0", "-o", str(out)]) == 2
    assert "--steps" in capsys.readouterr().err


@pytest.mark.slow
def test_retarget_cli_quad_to_small_quad_and_back(
    small_quad: robots.Robot, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """quad12 trot (N=12) → the 0.6× quadruped through one hybrid → back: Froude law to 1 %,
    the comparison table printed, and A → B → A within 5 % of A's cost."""
    a, b, back = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "back.json"
    assert cli.main(["plan", "quad12", "--gait", "trot", "--speed", "0.2", "--knots", "12",
                     "-o", str(a)]) == 0
    assert cli.main(["retarget", str(a), "--to", str(small_quad.root_dir), "--steps", "2",
                     "-o", str(b)]) == 0
    out = capsys.readouterr().out
    assert "what retargeting bought" in out and "from scratch" in out
    quad = robots.load("quad12")
    ga, gb = gait_io.load(a, quad), gait_io.load(b, small_quad)
    factor = math.sqrt(small_quad.leg_length_m / quad.leg_length_m)
    assert gb.velocity.vx_m_s == pytest.approx(ga.velocity.vx_m_s * factor, rel=0.01)
    assert gb.period_s == pytest.approx(ga.period_s * factor, rel=0.01)
    assert gb.planner["retarget"]["solves"] == 2
    assert sorted(gb.schedule.duty_factor) == sorted(ga.schedule.duty_factor)
    assert cli.main(["retarget", str(b), "--to", "quad12", "--no-compare", "-o", str(back)]) == 2
    assert "pass its folder with --from" in capsys.readouterr().err  # not the built-in's name
    assert cli.main(["retarget", str(b), "--from", str(small_quad.root_dir), "--to", "quad12",
                     "--no-compare", "-o", str(back)]) == 0
    g_back = gait_io.load(back, quad)
    assert g_back.velocity.vx_m_s == pytest.approx(ga.velocity.vx_m_s, rel=1e-9)
    assert g_back.planner["objective"] == pytest.approx(ga.planner["objective"], rel=0.05)

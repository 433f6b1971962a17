"""Body design (planner.design, W&P 2009 §3.6): link scaling at constant density with the
servos' catalogue masses (checked against MuJoCo's compiled model), servo swaps in robot.toml,
the design space of robots never seen, and a tiny design run that writes a robot folder which
loads and stands."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import tomllib

import robots
from gaitsmith.cli import main
from planner.design.body import (
    BodyDesign,
    DesignError,
    design_space,
    design_spec,
    design_toml,
    leg_segments,
    link_groups_named,
    write_design,
)
from planner.design.report import atomic_folder
from planner.design.search import supplied_samples
from planner.search.basin_cma import BasinCma
from robots.servo import servo_model
from sim.stand_check import check_stand
from tests.zoo.fixtures import ZOO


def _full_inertia(model: mujoco.MjModel, b: int) -> np.ndarray:
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.body_iquat[b])
    r = rot.reshape(3, 3)
    return np.asarray(r @ np.diag(model.body_inertia[b]) @ r.T)


def _body(model: mujoco.MjModel, name: str) -> int:
    return int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name))


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


def test_the_unchanged_design_reproduces_the_compiled_inertials(quad: robots.Robot) -> None:
    space = design_space(quad)
    m0, m1 = quad.mj_model(), design_spec(quad, space, space.original()).compile()
    for b in range(1, m0.nbody):
        assert m1.body_mass[b] == pytest.approx(m0.body_mass[b], abs=1e-12)
        np.testing.assert_allclose(m1.body_ipos[b], m0.body_ipos[b], atol=1e-12)
        np.testing.assert_allclose(_full_inertia(m1, b), _full_inertia(m0, b), atol=1e-12)
        np.testing.assert_allclose(m1.body_pos[b], m0.body_pos[b], atol=1e-12)


def test_link_scaling_keeps_density_and_the_servo_masses(quad: robots.Robot,
                                                         tmp_path: Path) -> None:
    segments = leg_segments(quad)
    groups = link_groups_named(quad, segments, ["shank", "thigh"])
    space = design_space(quad, ["shank", "thigh"])
    assert [g.bodies for g in space.link_groups] == [g.bodies for g in groups]
    assert set(space.link_groups[0].bodies) == {"fl_shank", "fr_shank", "hl_shank", "hr_shank"}
    s_shank, s_thigh = 1.5, 1.4
    design = BodyDesign((s_shank, s_thigh), space.original().servos)
    body = write_design(quad, space, design, tmp_path / "long", "long")
    m0, m1 = quad.mj_model(), body.mj_model()
    knee_servo = quad.joint("fl_knee").servo.mass_kg
    # the shank carries no servo (the knee's sits in the thigh): mass × s, Σ' = s·S·Σ·Sᵀ
    b = _body(m0, "fl_shank")
    assert m1.body_mass[b] == pytest.approx(s_shank * m0.body_mass[b], rel=1e-9)
    i0 = _full_inertia(m0, b)
    sigma0 = 0.5 * np.trace(i0) * np.eye(3) - i0
    stretch = np.diag([1.0, 1.0, s_shank])  # the shank runs along its local −z
    sigma1 = s_shank * stretch @ sigma0 @ stretch
    np.testing.assert_allclose(_full_inertia(m1, b), np.trace(sigma1) * np.eye(3) - sigma1,
                               rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(m1.body_ipos[b], m0.body_ipos[b] * [1, 1, s_shank], atol=1e-12)
    site = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_SITE, "fl_foot")
    np.testing.assert_allclose(m1.site_pos[site], m0.site_pos[site] * s_shank, atol=1e-12)
    # the thigh: knee servo (catalogue mass, unscaled) + structure × s; the shank starts s farther
    t = _body(m0, "fl_thigh")
    structure = m0.body_mass[t] - knee_servo
    assert m1.body_mass[t] == pytest.approx(knee_servo + s_thigh * structure, rel=1e-9)
    np.testing.assert_allclose(m1.body_pos[b], m0.body_pos[b] * s_thigh, atol=1e-12)
    # nothing else changed mass; the legs got longer
    others = [i for i in range(1, m0.nbody)
              if not any(k in mujoco.mj_id2name(m0, mujoco.mjtObj.mjOBJ_BODY, i)
                         for k in ("shank", "thigh"))]
    np.testing.assert_allclose(m1.body_mass[others], m0.body_mass[others], atol=1e-12)
    assert body.leg_length_m > 1.3 * quad.leg_length_m
    expected = quad.mass_kg + 4 * ((s_shank - 1) * m0.body_mass[b] + (s_thigh - 1) * structure)
    assert body.mass_kg == pytest.approx(expected, rel=1e-9)


def test_servo_swap_rewrites_the_toml_and_the_masses(quad: robots.Robot, tmp_path: Path) -> None:
    space = design_space(quad, ["shank"], ["STS3032_12V", "STS3215_12V"])
    assert all(sg.candidates == ("STS3032_12V", "STS3215_12V") for sg in space.servo_groups)
    small = servo_model("STS3032_12V")
    design = BodyDesign((1.0,), ("STS3032_12V",) * len(space.servo_groups))
    body = write_design(quad, space, design, tmp_path / "light", "light", note="a note")
    assert {j.servo.name for j in body.joints} == {"STS3032_12V"}
    text = (tmp_path / "light" / "robot.toml").read_text()
    assert text.startswith("# a note\n")
    assert "# Modelled on SpotMicro-class hobby builds" in text  # the file's own comments kept
    data = tomllib.loads(text)
    assert data["robot"]["name"] == "light"
    assert all(t["servo"] == "STS3032_12V" for t in data["joints"].values())
    assert all(t["bus_id"] == quad.joint(n).bus_id for n, t in data["joints"].items())
    old = quad.joint("fl_knee").servo
    assert body.mass_kg == pytest.approx(quad.mass_kg - 12 * (old.mass_kg - small.mass_kg))
    m0, m1 = quad.mj_model(), body.mj_model()
    hip = _body(m0, "fl_hip")  # carries the hip-pitch servo
    assert m1.body_mass[hip] == pytest.approx(m0.body_mass[hip] - old.mass_kg + small.mass_kg)


def test_zero_offsets_follow_the_new_servos_goal_range(quad: robots.Robot) -> None:
    space = design_space(quad, ["shank"], ["AX_12A"])
    with pytest.raises(DesignError, match="one protocol"):
        design_space(quad, ["shank"], ["AX_12A", "STS3215_12V"])
    text = design_toml(quad, space, BodyDesign((1.0,), ("AX_12A",) * 3), "ax")
    ticks = {t["zero_offset_ticks"] for t in tomllib.loads(text)["joints"].values()}
    assert ticks == {512}  # 2048 of 0…4095 → the middle of the AX-12A's 0…1023


@pytest.mark.parametrize("name", ["quad12", str(ZOO / "spotmicro"), str(ZOO / "bittle8"),
                                  str(ZOO / "phantomx18")])
def test_default_space_pairs_mirrored_legs_and_offers_catalogue_neighbours(name: str) -> None:
    robot = robots.load(name)
    space = design_space(robot)
    bodies = [b for g in space.link_groups for b in g.bodies]
    assert len(bodies) == len(set(bodies))
    assert all(len(g.bodies) == 2 for g in space.link_groups)  # a leg and its mirror image
    joints = [j for g in space.servo_groups for j in g.joints]
    assert sorted(joints) == sorted(j.name for j in robot.joints if not j.held)
    for sg in space.servo_groups:
        assert sg.own in sg.candidates
        models = [space.model(n) for n in sg.candidates]
        assert [m.stall_torque_nm for m in models] == sorted(m.stall_torque_nm for m in models)
        assert {m.protocol for m in models} == {space.model(sg.own).protocol}
    x0 = space.encode(space.original())
    assert space.decode(x0) == space.original()
    assert np.allclose(space.snap(x0 + 0.3), np.r_[x0[: len(space.link_groups)] + 0.3,
                                                   x0[len(space.link_groups):]])


def test_vary_names_that_match_nothing_or_twice_are_refused(quad: robots.Robot) -> None:
    with pytest.raises(DesignError, match="'tail' matches no leg segment of quad12"):
        design_space(quad, ["tail"])
    with pytest.raises(DesignError, match="matched by both 'fl_thigh' and 'thigh'"):
        design_space(quad, ["fl_thigh", "thigh"])
    with pytest.raises(DesignError, match="unknown servo model 'NOPE'"):
        design_space(quad, None, ["NOPE"])


def test_an_output_folder_is_renamed_into_place_only_when_complete(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), atomic_folder(out) as tmp:
        (tmp / "robot.xml").write_text("half")
        raise RuntimeError("stopped")
    assert not out.exists() and list(tmp_path.iterdir()) == []
    with atomic_folder(out) as tmp:
        (tmp / "robot.xml").write_text("whole")
    assert (out / "robot.xml").read_text() == "whole"
    with pytest.raises(DesignError, match="not an empty folder"), atomic_folder(out):
        pass


@pytest.mark.slow
def test_a_tiny_design_run_writes_a_folder_that_loads_and_stands(tmp_path: Path) -> None:
    out = tmp_path / "quad_design"
    code = main(["design", "quad12", "--speed", "0.2", "--knots", "10", "--generations", "1",
                 "--popsize", "2", "--vary", "shank", "-o", str(out)])
    assert code == 0
    body = robots.load(out)
    assert body.name == "quad_design"
    assert check_stand(body).stands
    for name in ("gait.json", "original_gait.json", "design_report.md", "design_tradeoff.png",
                 "design_samples.csv"):
        assert (out / name).is_file(), name
    rows = (out / "design_samples.csv").read_text().splitlines()
    assert rows[1].startswith("original,") and len(rows) == 2 + 2
    gait = robots.gait.load(out / "gait.json")
    gait.check_robot(body, str(out / "gait.json"))
    assert "quad12" in (out / "design_report.md").read_text()
    assert [p.name for p in tmp_path.iterdir()] == ["quad_design"]  # no temp folder left


def test_front_and_hind_legs_scaled_apart_get_a_level_stance(quad: robots.Robot,
                                                              tmp_path: Path) -> None:
    space = design_space(quad)  # default: front and hind segments are separate groups
    names = [g.name for g in space.link_groups]
    scales = tuple(1.3 if n.startswith("fl_shank") else 0.8 if n.startswith("hl_shank") else 1.0
                   for n in names)
    body = write_design(quad, space, BodyDesign(scales, space.original().servos),
                        tmp_path / "tilted", "tilted")
    model = body.mj_model()
    data = mujoco.MjData(model)
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    for j in body.joints:
        data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT,
                                                      j.name)]] = j.stance_rad
    mujoco.mj_kinematics(model, data)
    z = [data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, leg.foot_site)][2]
         for leg in body.legs]
    assert max(z) - min(z) < 1e-4 * body.leg_length_m
    assert body.joint("fl_knee").stance_rad != quad.joint("fl_knee").stance_rad
    assert check_stand(body).stands


def test_samples_are_redrawn_until_their_servos_share_a_supply(quad: robots.Robot) -> None:
    space = design_space(quad)  # 7.4 V and 12 V models: many mixes share no supply
    lo, hi = space.bounds()
    cma = BasinCma(space.encode(space.original()), (hi - lo) / 3, (lo, hi), popsize=12,
                   rng=np.random.default_rng(1))
    xs = supplied_samples(cma, space)
    assert xs.shape == (12, space.dim)
    for x in xs:
        v_lo, v_hi = space.supply_range_v(space.decode(x))
        assert v_lo <= v_hi

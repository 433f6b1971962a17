"""Flat feet in robot.toml: `foot = "flat"`, the sole from the box geom or `sole_size_m`."""

from __future__ import annotations

import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

import robots
from robots.errors import RobotConfigError
from robots.sole import sole_corners_local, sole_pose_world

BIPED = Path(__file__).parents[1] / "planner" / "fixtures" / "biped12"


def _copy(tmp_path: Path, toml_edit: tuple[str, str] | None = None, xml_edit=None) -> Path:
    root = tmp_path / "biped"
    shutil.copytree(BIPED, root)
    for name, edit in (("robot.toml", toml_edit), ("robot.xml", xml_edit)):
        if edit is not None:
            text = (root / name).read_text()
            assert edit[0] in text
            (root / name).write_text(text.replace(edit[0], edit[1]))
    return root


def test_flat_feet_take_the_sole_from_the_box_geom() -> None:
    r = robots.load(BIPED)
    for leg in r.legs:
        assert leg.is_flat and leg.foot_kind == "flat"
        assert leg.sole_half_extents_m == (0.055, 0.035)
        assert leg.sole_geom in ("l_sole", "r_sole")
    # at the stance pose the soles are level and the base height puts them on the ground
    model = r.mj_model()
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[2] = r.stance_base_height_m
    for j in r.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        data.qpos[model.jnt_qposadr[jid]] = j.stance_rad
    mujoco.mj_kinematics(model, data)
    for leg in r.legs:
        centre, rot = sole_pose_world(model, data, leg)
        assert abs(centre[2]) < 1e-9
        np.testing.assert_allclose(rot[:, 2], [0, 0, 1], atol=1e-9)
        corners = centre + sole_corners_local(leg) @ rot.T
        np.testing.assert_allclose(corners[:, 2], 0.0, atol=1e-9)


def test_point_feet_are_the_default() -> None:
    assert all(leg.foot_kind == "point" and not leg.is_flat for leg in robots.load("quad12").legs)


def test_sole_size_overrides_the_geom(tmp_path: Path) -> None:
    root = _copy(
        tmp_path,
        ('foot_site = "l_foot"\njoints', 'foot_site = "l_foot"\nsole_size_m = [0.1, 0.06]\njoints'),
    )
    r = robots.load(root)
    left = r.legs[0]
    assert left.sole_half_extents_m == pytest.approx((0.05, 0.03)) and left.sole_geom == ""
    assert r.legs[1].sole_geom == "r_sole"


@pytest.mark.parametrize(
    ("edit", "field", "words"),
    [
        (('foot = "flat"', 'foot = "round"'), ".foot", 'must be "point" or "flat"'),
        (
            ('foot = "flat"', 'foot = "point"\nsole_size_m = [0.1, 0.05]'),
            ".sole_size_m",
            "only a flat foot",
        ),
        (
            ('foot = "flat"', 'foot = "flat"\nsole_size_m = [0.1]'),
            ".sole_size_m",
            "[length, width]",
        ),
        (
            ('foot = "flat"', 'foot = "flat"\nsole_size_m = [0.1, -1]'),
            ".sole_size_m[1]",
            "must be a number",
        ),
    ],
)
def test_bad_flat_foot_fields_name_the_field(
    tmp_path: Path, edit: tuple[str, str], field: str, words: str
) -> None:
    root = _copy(tmp_path, edit)
    with pytest.raises(RobotConfigError) as err:
        robots.load(root)
    assert "[legs.left]" + field in str(err.value) and words in str(err.value)


def test_flat_foot_without_a_box_geom_says_what_to_do(tmp_path: Path) -> None:
    root = _copy(
        tmp_path,
        xml_edit=(
            'name="l_sole" class="collide" type="box" size="0.055 0.035 0.004"',
            'name="l_sole" class="collide" type="sphere" size="0.02"',
        ),
    )
    with pytest.raises(RobotConfigError, match=r"\[legs.left\].foot.*box geom.*sole_size_m"):
        robots.load(root)

import json
import math
from pathlib import Path

import numpy as np
import pytest

import robots
from robots import ContactSchedule, Gait, GaitFileError, Velocity
from robots import gait as gaitfile

N = 24


def make_gait(robot: robots.Robot, n: int = N) -> Gait:
    phase = np.arange(n) / n
    knots = np.array(robot.nominal_stance_rad)[None, :] + 0.1 * np.sin(2 * np.pi * phase)[:, None]
    sched = ContactSchedule(
        0.5,
        robot.foot_names,
        tuple(0.5 * (i % 2) for i in range(len(robot.legs))),
        (0.6,) * len(robot.legs),
    )
    return Gait.create(
        robot=robot,
        knots_rad=knots,
        schedule=sched,
        velocity=Velocity(0.25),
        gait_label="trot",
        base_pose=np.zeros((n, 6)),
        contact_forces_n=np.zeros((n, len(robot.legs), 3)),
        joint_torques_nm=np.zeros((n, robot.dof)),
        planner={"seed": 3},
    )


@pytest.fixture(scope="module")
def quad() -> robots.Robot:
    return robots.load("quad12")


def test_round_trip(tmp_path: Path, quad: robots.Robot) -> None:
    g = make_gait(quad)
    path = tmp_path / "trot.json"
    gaitfile.save(g, path)
    assert json.loads(path.read_text())["schema"] == "gaitsmith.gait/1"
    h = gaitfile.load(path, quad)
    assert h.joint_names == quad.joint_names and h.n_knots == N
    np.testing.assert_allclose(h.joint_angles_rad, g.joint_angles_rad)
    assert h.schedule == g.schedule and h.velocity == g.velocity and h.planner == {"seed": 3}
    assert [p.name for p in tmp_path.iterdir()] == ["trot.json"]  # no temp file left behind


def test_spline_hits_knots_and_is_smooth_across_the_wrap(quad: robots.Robot) -> None:
    g = make_gait(quad)
    t_knots = np.arange(N) / N * g.period_s
    np.testing.assert_allclose(g.joint_targets(t_knots), g.knots_rad, atol=1e-12)
    eps = 1e-7
    for t in (0.0, g.period_s):  # C¹ across the cycle boundary
        np.testing.assert_allclose(g.joint_targets(t - eps), g.joint_targets(t + eps), atol=1e-6)
    v = g.joint_velocities(0.13)
    fd = (g.joint_targets(0.13 + 1e-6) - g.joint_targets(0.13 - 1e-6)) / 2e-6
    np.testing.assert_allclose(v, fd, rtol=1e-5, atol=1e-6)
    # a sine sampled at 24 knots is reproduced to spline accuracy between knots
    t = np.linspace(0, 1, 101)
    exact = quad.nominal_stance_rad[0] + 0.1 * np.sin(2 * np.pi * t / g.period_s)
    assert np.max(np.abs(g.joint_targets(t)[:, 0] - exact)) < 1e-4


def test_save_is_atomic_when_serialisation_fails(tmp_path: Path, quad: robots.Robot) -> None:
    path = tmp_path / "g.json"
    gaitfile.save(make_gait(quad), path)
    before = path.read_text()
    bad = make_gait(quad).with_validation({"x": object()})
    with pytest.raises(GaitFileError):
        gaitfile.save(bad, path)
    assert path.read_text() == before
    assert len(list(tmp_path.iterdir())) == 1


def _doc(quad: robots.Robot) -> dict:
    return gaitfile.to_dict(make_gait(quad))


@pytest.mark.parametrize(
    ("mutate", "field"),
    [
        (lambda d: d.update(schema="gaitsmith.gait/9"), "schema"),
        (lambda d: d["joint_angles_rad"][3].__setitem__(2, float("nan")), "joint_angles_rad[3, 2]"),
        (lambda d: d["joint_angles_rad"][-1].__setitem__(0, 1.0), "not periodic"),
        (lambda d: d["joint_angles_rad"][5].pop(), "joint_angles_rad"),
        (lambda d: d.update(period_s=-1), "period_s"),
        (lambda d: d.update(joint_names=d["joint_names"][:-1]), "joint_angles_rad"),
        (lambda d: d["schedule"].update(duty_factor=[0.5, 1.5, 0.5, 0.5]), "schedule"),
        (lambda d: d["schedule"].update(touchdown_phase=[0.0]), "schedule"),
        (lambda d: d.update(contact_forces_n=[[0, 0, 0]]), "contact_forces_n"),
        (lambda d: d["velocity"].pop("vx_m_s"), "velocity"),
        (lambda d: d.pop("gait_label"), "gait_label"),
        (lambda d: d.update(extra=1), "extra"),
    ],
)
def test_malformed_documents_name_the_field(quad: robots.Robot, mutate, field: str) -> None:
    d = _doc(quad)
    mutate(d)
    text = json.dumps(d)  # NaN is written as the bare token NaN
    with pytest.raises(GaitFileError) as info:
        gaitfile.loads(text, "bad.json")
    assert field in str(info.value) and "bad.json" in str(info.value)


def test_gait_for_another_robot_is_refused(tmp_path: Path, quad: robots.Robot) -> None:
    path = tmp_path / "g.json"
    gaitfile.save(make_gait(quad), path)
    with pytest.raises(GaitFileError, match="robot_fingerprint"):
        gaitfile.load(path, robots.load("hex18"))
    d = json.loads(path.read_text())
    d["joint_names"] = list(reversed(d["joint_names"]))
    path.write_text(json.dumps(d))
    with pytest.raises(GaitFileError, match="joint_names"):
        gaitfile.load(path, quad)


def test_samples_outside_joint_limits_are_refused(quad: robots.Robot) -> None:
    d = _doc(quad)
    knee = quad.joint_names.index("fl_knee")
    for row in (d["joint_angles_rad"][4],):
        row[knee] = -3.0
    g = gaitfile.from_dict(d)
    with pytest.raises(GaitFileError, match=r"fl_knee's limits"):
        g.check_robot(quad)


def test_unreadable_and_non_json_files(tmp_path: Path) -> None:
    with pytest.raises(GaitFileError, match="cannot read"):
        gaitfile.load(tmp_path / "missing.json")
    (tmp_path / "x.json").write_text("{not json")
    with pytest.raises(GaitFileError, match="not valid JSON"):
        gaitfile.load(tmp_path / "x.json")
    assert math.isfinite(1.0)


def test_saved_files_get_normal_permissions_not_mkstemp_private(
    tmp_path: Path, quad: robots.Robot
) -> None:
    import os
    import stat

    old = os.umask(0o022)
    try:
        gaitfile.save(make_gait(quad), tmp_path / "g.json")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "g.json").stat().st_mode) == 0o644

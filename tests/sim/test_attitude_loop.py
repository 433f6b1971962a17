"""sim.attitude_loop: the law's signs in MuJoCo, the closed-loop rollout, its options."""

from __future__ import annotations

from pathlib import Path

import mujoco
import mujoco.rollout
import numpy as np
import pytest

import robots
from gaitsmith.cli import main
from robots.attitude import ATTITUDE_GAIN_KEY, AttitudeLaw, roll_pitch
from robots.attitude_maps import attitude_map
from sim.attitude_loop import AttitudeSettings, ImuSettings
from sim.errors import SimConfigError
from sim.model import SimConditions, build_sim_model
from sim.validate import validate

BIPED_WALK = Path(__file__).parent / "fixtures" / "biped_walk_0222.json"


def _stand_with(sim: object, goals: np.ndarray, seconds: float = 1.5) -> np.ndarray:
    """Roll/pitch after holding `goals` on the servos for `seconds` from the stance."""
    model = sim.model  # type: ignore[attr-defined]
    n = int(seconds / model.opt.timestep)
    st, _ = mujoco.rollout.rollout(model, mujoco.MjData(model),
                                   sim.initial_state()[None],  # type: ignore[attr-defined]
                                   np.tile(goals, (n, 1))[None])
    return np.asarray(roll_pitch(st[0, -1, 4:8]))


@pytest.mark.parametrize("robot", ["biped", "quad12"])
@pytest.mark.parametrize("pivot", [1.0, 0.0])
def test_offsets_for_a_measured_tilt_turn_the_body_back(robot: str, pivot: float) -> None:
    """With every foot down, the offsets the law gives for a measured tilt e (gain 1) make the
    servos stand the body at about −e from where the stance stands it: the signs come out of
    the model's kinematics."""
    bot = robots.load(robot)
    sim = build_sim_model(bot, SimConditions())
    amap = attitude_map(bot, sim.model)
    stance = np.asarray(bot.nominal_stance_rad)
    level = _stand_with(sim, stance)
    law = AttitudeLaw(1.0, pivot_fraction=pivot)
    from robots.attitude import attitude_offsets

    for tilt in ([0.05, 0.0], [0.0, 0.05], [-0.04, 0.03]):
        off = attitude_offsets(law, amap, np.array(tilt), np.ones(len(bot.legs)), 1.0)
        moved = _stand_with(sim, stance + off) - level
        np.testing.assert_allclose(moved, -np.array(tilt), atol=0.02)


def test_closed_loop_biped_walk_passes_where_open_loop_fails() -> None:
    """The built-in biped's 0.222 m/s template walk turns +12° open loop; with the IMU
    feedback at gain 0.5 it walks straight, and the verdict records the gain."""
    gait = robots.gait.load(BIPED_WALK)
    bot = robots.load("biped")
    open_loop = validate(gait, bot, 20, keep_trajectory=True)
    assert not open_loop.passed and any("heading" in r for r in open_loop.reasons)
    assert ATTITUDE_GAIN_KEY not in open_loop.conditions
    closed = validate(gait, bot, 20, keep_trajectory=True,
                      attitude=AttitudeSettings(AttitudeLaw(0.5)))
    assert closed.passed, closed.reasons
    assert closed.conditions[ATTITUDE_GAIN_KEY] == 0.5
    traj, ref = closed.trajectory, open_loop.trajectory
    assert traj is not None and ref is not None and traj.attitude_gain == 0.5
    # the goals differ from open loop's only once the gait blends in, and by at most the clip
    n = min(traj.n_steps, ref.n_steps)
    diff = traj.goal_rad[:n] - ref.goal_rad[:n]
    before = traj.time_s[:n] < traj.ramp.blend_start_s
    assert np.max(np.abs(diff[before])) == 0.0
    assert 1e-3 < np.max(np.abs(diff)) <= 0.15 + 1e-12


def test_imu_settings_are_checked() -> None:
    with pytest.raises(SimConfigError, match="IMU latency"):
        ImuSettings(latency_s=-0.01)
    with pytest.raises(SimConfigError, match="IMU noise"):
        ImuSettings(noise_rad=float("nan"))


def test_imu_latency_and_noise_run_reproducibly() -> None:
    gait = robots.gait.load(BIPED_WALK)
    bot = robots.load("biped")
    att = AttitudeSettings(AttitudeLaw(0.5), ImuSettings(0.01, 0.002, seed=3))
    a = validate(gait, bot, 4, keep_trajectory=True, attitude=att)
    b = validate(gait, bot, 4, keep_trajectory=True, attitude=att)
    assert a.trajectory is not None and b.trajectory is not None
    np.testing.assert_array_equal(a.trajectory.goal_rad, b.trajectory.goal_rad)


@pytest.mark.parametrize("args, needle", [
    (["simulate", str(BIPED_WALK), "--attitude-gain", "3"], "--attitude-gain"),
    (["simulate", str(BIPED_WALK), "--attitude-gain", "nan"], "--attitude-gain"),
    (["simulate", str(BIPED_WALK), "--attitude-gain", "0.5", "--imu-latency-ms", "-1"],
     "--imu-latency-ms"),
    (["plan", "biped", "-o", "/nonexistent/g.json", "--attitude-gain", "0.5"],
     "needs --simulate"),
    (["plan", "biped", "-o", "/nonexistent/g.json", "--search", "--no-sim-accept",
      "--attitude-gain", "0.5"], "needs --simulate (or --search with its MuJoCo acceptance"),
    (["sweep", "biped", "-o", "/nonexistent/s", "--attitude-gain", "2.5"],
     "--attitude-gain must be"),
    (["sweep", "biped", "-o", "/nonexistent/s", "--no-sim-accept", "--attitude-gain", "0.5"],
     "needs --simulate or --sim-accept"),
    (["library", "biped", "-o", "/nonexistent/l.json", "--attitude-gain", "-0.1"],
     "--attitude-gain must be"),
    (["library", "biped", "-o", "/nonexistent/l.json", "--attitude-gain", "inf"],
     "--attitude-gain must be"),
])
def test_bad_attitude_options_are_one_line_errors(
    args: list[str], needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(args) == 2
    lines = [ln for ln in capsys.readouterr().err.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and needle in lines[0], lines

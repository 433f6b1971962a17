"""`gaitsmith plan --supply-v`: the planner gets the servos' envelope at that voltage."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import robots
from gaitsmith import cli, plan_cmd


class _Built(Exception):
    pass


def test_plan_builds_the_nlp_at_the_supply_voltage(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    seen: list[robots.Robot] = []

    def factory(robot: robots.Robot, n_knots: int = 30, options: Any = None) -> Any:
        seen.append(robot)
        raise _Built  # stop before the (slow) NLP build: the robot handed over is what counts

    monkeypatch.setattr(plan_cmd, "GaitPlanner", factory)
    with pytest.raises(_Built):
        cli.app(["plan", "quad12", "--gait", "trot", "--supply-v", "7.0", "-o",
                 str(tmp_path / "g.json")], standalone_mode=False)
    (bot,) = seen
    nominal = robots.load("quad12")
    for j, j0 in zip(bot.joints, nominal.joints, strict=True):
        assert j.servo.stall_torque_nm == pytest.approx(j0.servo.stall_torque_nm * 7.0 / 7.4)
        assert j.servo.no_load_speed_rad_s == pytest.approx(
            j0.servo.no_load_speed_rad_s * 7.0 / 7.4
        )
    assert bot.fingerprint == nominal.fingerprint


@pytest.mark.parametrize("value", ["5.9", "8.5", "inf"])
def test_plan_refuses_a_voltage_outside_the_servo_range(
    value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    assert cli.main(["plan", "quad12", "--supply-v", value, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--supply-v must be a number in [6, 8.4] V" in " ".join(err.split())
    assert "STS3215_7V4" in err and not out.exists()


def test_plan_simulate_writes_the_heating_prediction(tmp_path: Path) -> None:
    from sim.synthetic import standing_gait

    bot = robots.load("quad12")
    out = tmp_path / "stand.json"
    plan_cmd._write(standing_gait(bot), bot, out, simulate=True, cycles=4)
    v = robots.gait.load(out).validation or {}
    assert v["thermal"]["schema"] == "gaitsmith.thermal/1"
    assert [j["joint"] for j in v["thermal"]["joints"]] == list(bot.joint_names)
    assert v["supply"]["supply_v"] == 7.4  # nominal: the simulated peaks, for pre-flight
    assert len(v["supply"]["joints"]) == bot.dof

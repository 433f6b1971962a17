"""Predicted servo heating of a simulated gait (sim.thermal_report), `gaitsmith simulate`'s
heating table, --supply-v, the validation block and the HTML report section."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import robots.gait as gait_io
from gaitsmith.cli import main
from robots.gait import Gait
from robots.robot import Robot
from robots.servo import servo_model
from robots.thermal import thermal_model
from robots.voltage import robot_at_voltage
from sim.errors import SimConfigError
from sim.metrics import steady_mask
from sim.report import render_html
from sim.thermal_report import (
    THERMAL_SCHEMA,
    predict_from_trajectory,
    predict_heating,
    temperature_plot,
)
from sim.validate import evaluate, simulate


@pytest.fixture(scope="module")
def stand_run(quad: Robot, quad_stand: Gait):  # type: ignore[no-untyped-def]
    return simulate(quad_stand, quad, cycles=4)


def test_prediction_is_the_thermal_model_of_each_joint(quad: Robot) -> None:
    rng = np.random.default_rng(0)
    tau = rng.normal(0.0, 0.6, size=(400, quad.dof))
    tau[:, 2] *= 2.0  # one joint works harder
    pred = predict_heating(quad, tau, bout_s=600.0, ambient_c=25.0)
    assert len(pred.joints) == quad.dof and not pred.unmodelled
    m = thermal_model(quad.joints[2].servo)
    h = pred.joints[2]
    p = float(np.mean(m.power_w(tau[:, 2])))
    assert h.mean_power_w == pytest.approx(p)
    assert h.temperature_after_bout_c == pytest.approx(25.0 + float(m.rise_k(p, 600.0)))
    assert pred.hottest[0].joint == quad.joint_names[2]
    d = pred.to_dict()
    assert d["schema"] == THERMAL_SCHEMA and len(d["joints"]) == quad.dof  # type: ignore[arg-type]
    json.dumps(d)  # JSON-safe (minutes_to_limit None → null)
    assert temperature_plot(pred)[:8] == b"\x89PNG\r\n\x1a\n"


def test_servo_without_thermal_data_is_listed_not_guessed(quad: Robot) -> None:
    j0 = dataclasses.replace(quad.joints[0], servo=servo_model("MG996R"))
    bot = dataclasses.replace(quad, joints=(j0, *quad.joints[1:]))
    pred = predict_heating(bot, np.ones((10, bot.dof)))
    assert pred.unmodelled == (bot.joint_names[0],)
    assert len(pred.joints) == bot.dof - 1


def test_bad_bout_and_shapes_are_errors(quad: Robot) -> None:
    for bout, amb in ((0.0, 25.0), (float("nan"), 25.0), (600.0, 200.0)):
        with pytest.raises(SimConfigError):
            predict_heating(quad, np.ones((5, quad.dof)), bout_s=bout, ambient_c=amb)
    with pytest.raises(SimConfigError, match="torques"):
        predict_heating(quad, np.ones((5, 3)))


def test_standing_heats_from_the_rollout_torques(stand_run, quad: Robot) -> None:  # type: ignore[no-untyped-def]
    _sim, traj = stand_run
    pred = predict_from_trajectory(traj, quad)
    tau = traj.torque_nm[steady_mask(traj, 2)]
    assert np.max(np.abs(tau)) > 0.05  # holding the body up takes torque
    direct = predict_heating(quad, tau)
    assert pred == direct
    assert all(h.rise_after_bout_k > 0.0 for h in pred.joints)


def test_supply_voltage_scales_the_simulated_servos(quad: Robot) -> None:
    from sim.model import SimConditions, build_sim_model

    low = build_sim_model(robot_at_voltage(quad, 7.0), SimConditions())
    nom = build_sim_model(quad, SimConditions())
    assert np.allclose(low.stall_torque_nm, nom.stall_torque_nm * 7.0 / 7.4)


def test_report_has_the_heating_section(stand_run, quad: Robot, quad_stand: Gait) -> None:  # type: ignore[no-untyped-def]
    sim, traj = stand_run
    result = evaluate(traj, quad_stand, sim)
    pred = predict_from_trajectory(traj, quad)
    text = render_html(result, quad_stand, sim, thermal=pred)
    assert "Predicted servo heating" in text and "minutes to limit" in text
    assert "Predicted servo temperature over the bout" in text
    assert text.count("data:image/png;base64") == 5


def test_cli_simulate_heating_and_supply(quad_stand: Gait, tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "stand.json"
    gait_io.save(quad_stand, path)
    report = tmp_path / "r.html"
    code = main(["simulate", str(path), "--cycles", "4", "--supply-v", "7.0", "--bout-min",
                 "20", "--report", str(report), "--write-validation"])
    out = capsys.readouterr().out
    assert code in (0, 1), out
    assert "predicted servo heating over 20 min" in out
    assert "at 7.00 V the peak" in out and "7.40 V nominal" in out
    v = gait_io.load(path).validation or {}
    assert v["thermal"]["bout_s"] == 1200.0 and len(v["thermal"]["joints"]) == 12
    assert v["supply"]["supply_v"] == 7.0
    html = report.read_text()
    assert "Supply voltage" in html and "Predicted servo heating" in html


@pytest.mark.parametrize("args, needle", [
    (["--supply-v", "5"], "--supply-v must be a number in [6, 8.4] V"),
    (["--supply-v", "nan"], "--supply-v must be a number"),
    (["--bout-min", "0"], "--bout-min must be a number in (0"),
    (["--ambient-c", "99"], "--ambient-c must be a number in [-40, 60]"),
])
def test_cli_bad_thermal_options_are_one_line(  # type: ignore[no-untyped-def]
    quad_stand: Gait, tmp_path: Path, capsys, args: list[str], needle: str
) -> None:
    path = tmp_path / "stand.json"
    gait_io.save(quad_stand, path)
    assert main(["simulate", str(path), "--cycles", "4", *args]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err


def test_cli_simulate_uses_the_planned_supply(quad_stand: Gait, tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "stand.json"
    gait_io.save(dataclasses.replace(quad_stand, planner={"supply_v": 7.0}), path)
    assert main(["simulate", str(path), "--cycles", "4"]) in (0, 1)
    out = capsys.readouterr().out
    assert "supply 7 V (the voltage the gait was planned at)" in out and "at 7.00 V" in out
    gait_io.save(dataclasses.replace(quad_stand, planner={"supply_v": 20.0}), path)
    assert main(["simulate", str(path), "--cycles", "4"]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "planner.supply_v must be a number in [6, 8.4] V" in err

"""`gaitsmith plan ROBOT --speed 0 --simulate` end to end (real NLP, real MuJoCo): a stand on a
quadruped and a zoo robot, stepping in place on a quadruped, a hexapod and a zoo hexapod — all
pass the zero-command criteria (drift, heading, tilt, fall, slip, torque)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gaitsmith.cli import main
from tests.zoo.fixtures import ZOO

CASES = [
    pytest.param("quad12", [], id="quad12-stand"),
    pytest.param(str(ZOO / "star5"), [], id="star5-stand"),
    pytest.param("quad12", ["--gait", "walk"], id="quad12-walk-in-place"),
    pytest.param("hex18", ["--gait", "tripod"], id="hex18-tripod-in-place"),
    pytest.param(str(ZOO / "phantomx18"), ["--gait", "tripod"],
                 id="phantomx18-tripod-in-place"),
]


@pytest.mark.slow
@pytest.mark.parametrize(("robot", "extra"), CASES)
def test_speed_zero_plans_pass_mujoco(robot: str, extra: list[str], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "g.json"
    code = main(["plan", robot, "--speed", "0", "--knots", "16", *extra, "-o", str(out),
                 "--simulate"])
    printed = " ".join(capsys.readouterr().out.split())
    assert code in (0, None), printed[-2000:]
    gait = json.loads(out.read_text())
    v = gait["validation"]
    assert v["passed"] is True, v["reasons"]
    checks = {c["name"]: c for c in v["checks"]}
    assert "speed" not in checks and checks["drift"]["ok"]
    duty = gait["schedule"]["duty_factor"]
    if "--gait" in extra:
        assert max(duty) < 1.0 and v["metrics"]["stances"] > 0  # it steps
        assert "simulation verdict (20 cycles)" in printed
    else:
        assert set(duty) == {1.0} and gait["gait_label"] == "stand"
        assert v["metrics"]["duration_s"] >= 10.0  # a stand is judged over a duration
        assert "simulation verdict (standing 1" in printed

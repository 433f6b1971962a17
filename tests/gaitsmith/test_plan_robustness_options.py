"""`gaitsmith plan --mirror` and `--knife-edge`: refused before any work when they cannot hold,
and the knife-edge check's verdict printed after the plan's own."""

from __future__ import annotations

from pathlib import Path

import pytest

from gaitsmith.cli import main


def test_plan_refuses_mirror_for_an_odd_n_and_an_asymmetric_schedule(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "--gait", "trot", "--mirror", "--knots", "11", "-o",
                 str(out)]) == 2
    assert "--mirror needs an even --knots" in capsys.readouterr().err
    assert main(["plan", "quad12", "--gait", "bound", "--mirror", "--knots", "12", "-o",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert "not half-cycle mirror symmetric" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize(
    "extra",
    [["--search"], ["--yaw-rate", "0.2", "--simulate"], []],
    ids=["search", "turn", "no-simulate"],
)
def test_plan_refuses_knife_edge_where_it_cannot_run(
    extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "--gait", "trot", "--knife-edge", "-o", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert "--knife-edge: needs --simulate" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.slow
def test_plan_knife_edge_prints_the_verdict_over_its_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "--gait", "trot", "--speed", "0.2", "--knots", "12",
                 "--simulate", "--cycles", "4", "--knife-edge", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    line = next(ln for ln in text.splitlines() if ln.startswith("knife-edge check:"))
    # the nominal at 0, 5 and 10 ms, re-plans at -1 %, +1 % speed and N 8, N 16
    assert " of 7 runs pass" in line
    assert any(word in line for word in ("robust", "knife edge", "fails"))
    assert out.exists()

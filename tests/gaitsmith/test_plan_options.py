"""`gaitsmith.plan_options`: the one table of `gaitsmith plan`'s options covers every option
the command has, and `--search` refuses the ones the table says it refuses, before any work."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

from gaitsmith.cli import main
from gaitsmith.plan_cmd import plan
from gaitsmith.plan_options import (
    OPTION_ROUTES,
    OptionRoute,
    planner_options,
    search_planner_options,
)
from gaitsmith.stance_options import StanceShaped


def _flags() -> dict[str, str]:
    """`plan`'s parameters by name → their first flag (without a `/--no-` half)."""
    return {name: p.default.param_decls[0].split("/")[0]
            for name, p in inspect.signature(plan).parameters.items()
            if getattr(p.default, "param_decls", None)}


def test_every_plan_option_has_one_route() -> None:
    assert {r.param: r.flag for r in OPTION_ROUTES} == _flags()
    assert len({r.flag for r in OPTION_ROUTES}) == len(OPTION_ROUTES)
    for route in OPTION_ROUTES:
        assert route.template or route.search, route.flag  # each option goes somewhere
        assert route.refused_with_search is None or not route.search, route.flag


@pytest.mark.parametrize("route", [r for r in OPTION_ROUTES if r.refused_with_search],
                         ids=lambda r: r.flag)
def test_search_refuses_what_the_table_refuses(
    route: OptionRoute, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    value = {"--vy": ["0.05"], "--yaw-rate": ["0.2"], "--servo-params": ["servo_params.toml"],
             "--attitude-gain": ["0.5"]}
    out = tmp_path / "g.json"
    argv = ["plan", "quad12", "--speed", "0.2", "--search", route.flag,
            *value.get(route.flag, []), "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {route.refused_with_search}"
    assert not out.exists()


def test_search_options_drop_only_the_template_paths_own() -> None:
    shaped = StanceShaped(10.0, 30.0, 3, {})
    full = planner_options(0.7, "expanded", shaped, 0.15, 0.02, verbose=True, mirror=True,
                           line_capture_margin=0.16)
    searched = search_planner_options(full)
    assert full.print_level == 5 and full.half_cycle_mirror
    assert searched == planner_options(0.7, "expanded", shaped, 0.15, 0.02,
                                       line_capture_margin=0.16)
    assert searched.line_capture_margin_leg_lengths == 0.16
    assert searched.normal_force_rate_weights_per_t0 == 10.0
    assert searched.weights.bounce_s2_m2 == 30.0


def test_plan_rejects_an_unknown_nlp_hessian_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "-o", str(out), "--nlp-hessian", "exact"]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert lines == ["error: --nlp-hessian 'exact': use one of ad, assembled"]
    assert not out.exists()


class _Built(Exception):
    """Raised by the stand-in planner: the options `plan` built it with."""


@pytest.mark.parametrize("flag", [[], ["--nlp-hessian", "ad"], ["--nlp-hessian", "assembled"]],
                         ids=["default", "ad", "assembled"])
def test_plan_nlp_hessian_reaches_the_planner(
    flag: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import gaitsmith.plan_cmd as plan_cmd
    from planner.nlp.config import PlannerOptions

    def built(*args: object, options: PlannerOptions, **kwargs: object) -> None:
        raise _Built(options.nlp_hessian)

    monkeypatch.setattr(plan_cmd, "GaitPlanner", built)
    with pytest.raises(_Built) as caught:
        main(["plan", "quad12", "--gait", "trot", "-o", str(tmp_path / "g.json"), *flag])
    assert caught.value.args[0] == (flag[1] if flag else PlannerOptions().nlp_hessian)


def test_plan_rejects_an_unknown_inactive_rows_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from planner.nlp.config import INACTIVE_ROWS

    out = tmp_path / "g.json"
    assert main(["plan", "quad12", "-o", str(out), "--inactive-rows", "none"]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert lines == ["error: --inactive-rows 'none': use one of "
                     + ", ".join(repr(v) for v in INACTIVE_ROWS)]
    assert not out.exists()


@pytest.mark.parametrize("flag", [[], ["--inactive-rows", "rows"],
                                  ["--inactive-rows", "free stance"]],
                         ids=["default", "rows", "free stance"])
def test_plan_inactive_rows_reaches_the_planner(
    flag: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`plan` (no --search) builds its planner with --inactive-rows, by default
    `PlannerOptions.inactive_rows`' default."""
    import gaitsmith.plan_cmd as plan_cmd
    from planner.nlp.config import DEFAULT_INACTIVE_ROWS, PlannerOptions

    def built(*args: object, options: PlannerOptions, **kwargs: object) -> None:
        raise _Built(options.inactive_rows)

    monkeypatch.setattr(plan_cmd, "GaitPlanner", built)
    with pytest.raises(_Built) as caught:
        main(["plan", "quad12", "--gait", "trot", "-o", str(tmp_path / "g.json"), *flag])
    assert caught.value.args[0] == (flag[1] if flag else DEFAULT_INACTIVE_ROWS)

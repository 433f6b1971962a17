"""`gaitsmith plan`'s last step on both paths: the optional MuJoCo validation (`--simulate`,
its verdict written into the gait file's `validation` block) and the gait file itself."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import robots
from gaitsmith.console import console
from gaitsmith.validation_record import validation_record
from robots.servo_params import ServoSetting

if TYPE_CHECKING:
    from sim.attitude_loop import AttitudeSettings

DEFAULT_CYCLES = 20  # simulated cycles of a stepping gait (--simulate)
STAND_S = 10.0  # simulated seconds of a stand (issue #14: "standing 10 s in MuJoCo")


def is_stand(gait_obj: robots.Gait) -> bool:
    """Every foot down all cycle (duty factor 1): a stand, judged over a duration."""
    return all(d >= 1.0 - 1e-9 for d in gait_obj.schedule.duty_factor)


def simulated_cycles(gait_obj: robots.Gait, cycles: int | None) -> tuple[int, str]:
    """Cycles to simulate and how to say it: `--cycles`, else `DEFAULT_CYCLES`, or for a stand
    (which has no steps to count) the whole cycles that last at least `STAND_S`."""
    from sim.validate import PassCriteria  # lazy: MuJoCo only on request

    if is_stand(gait_obj):
        n = cycles or max(math.ceil(STAND_S / gait_obj.period_s - 1e-9),
                          PassCriteria().warmup_cycles + 1)
        return n, f"standing {n * gait_obj.period_s:.1f} s"
    n = cycles or DEFAULT_CYCLES
    return n, f"{n} cycles"


def write_gait(gait_obj: robots.Gait, bot: robots.Robot, output: Path, simulate: bool,
               cycles: int | None, servo_settings: tuple[ServoSetting, ...] | None = None,
               attitude: AttitudeSettings | None = None) -> None:
    """Validate in MuJoCo if `simulate` (the verdict goes into the file; `attitude`: closed
    loop, recorded as the validation's ``attitude_gain``), then save."""
    if simulate:
        from sim.validate import validate  # lazy: MuJoCo only on request

        n_cycles, what = simulated_cycles(gait_obj, cycles)
        with console.status(f"validating in MuJoCo ({what})…"):
            result = validate(gait_obj, bot, n_cycles, servo_settings=servo_settings,
                              attitude=attitude)
        v, thermal = validation_record(result, gait_obj, bot)
        assert thermal is not None  # validate keeps the trajectory by default
        gait_obj = gait_obj.with_validation(v)
        verdict = "[bold green]PASS[/]" if result.passed else "[bold red]FAIL[/]"
        loop = "" if attitude is None else f", attitude gain {attitude.law.gain:g}"
        console.print(f"simulation verdict ({what}{loop}): {verdict} "
                      + "; ".join(result.reasons))
        console.print(f"heating: {thermal.summary()}")
    robots.gait.save(gait_obj, output)
    console.print(f"wrote [bold]{output}[/]")

"""`--attitude-gain G` (`plan --simulate`/`--knife-edge`, `plan --search`'s acceptance, `simulate`,
`sweep`, `library`, `drive-sim`): closed-loop IMU feedback in the MuJoCo runs (`robots.attitude`,
`sim.attitude_loop`); without it each gait gets the robot's rule
(`robots.attitude.gait_attitude_gain`). Checked before any work; the gain a run used is written
into the validation's conditions (``attitude_gain``); `drive-sim` reports it beside its metrics."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import typer

from gaitsmith.errors import OptionError
from gaitsmith.options import check_number
from robots.attitude import MAX_ATTITUDE_GAIN

if TYPE_CHECKING:
    from robots.gait import Gait
    from robots.robot import Robot
    from sim.attitude_loop import AttitudeSettings

MAX_IMU_LATENCY_MS = 500.0
MAX_IMU_NOISE_DEG = 10.0


def attitude_gain_option() -> Any:
    return typer.Option(
        None, "--attitude-gain",
        help="close the loop on body roll/pitch from a simulated IMU with gain G (0 to "
        f"{MAX_ATTITUDE_GAIN:g}; 1 corrects the whole tilt error each tick) through the stance "
        "legs' joints (`robots.attitude`); 0: open loop; default: 0.5 for a robot with fewer "
        "than 3 legs whose robot.toml declares an [imu] (the built-in biped, humanoid20) on a "
        "walk, else robot.toml's [imu].attitude_gain, else 0")


def imu_latency_option() -> Any:
    return typer.Option(
        0.0, "--imu-latency-ms", help="with --attitude-gain: age of the simulated IMU's reading "
        "[ms]")


def imu_noise_option() -> Any:
    return typer.Option(
        0.0, "--imu-noise-deg", help="with --attitude-gain: 1σ noise of the simulated IMU's roll "
        "and pitch [°] (seeded)")


def check_imu_options(latency_ms: float, noise_deg: float) -> None:
    """--imu-latency-ms and --imu-noise-deg in range (one-line OptionError)."""
    check_number("--imu-latency-ms", latency_ms, 0.0, MAX_IMU_LATENCY_MS, unit="ms")
    check_number("--imu-noise-deg", noise_deg, 0.0, MAX_IMU_NOISE_DEG, unit="°")


def check_attitude_gain(option: str, gain: float | None) -> None:
    """`gain` (None: not given) finite and in [0, MAX_ATTITUDE_GAIN] (one-line OptionError)."""
    check_number(option, gain, 0.0, MAX_ATTITUDE_GAIN)


def check_attitude_judged(gain: float | None, judged: bool, needs: str) -> None:
    """`--attitude-gain` in range, and given only where a MuJoCo run uses it (`judged`; `needs`:
    the options that run one), as one-line `OptionError`s."""
    check_attitude_gain("--attitude-gain", gain)
    if gain is not None and not judged:
        raise OptionError(f"--attitude-gain: closes the loop in the MuJoCo run, so it needs "
                          f"{needs}")


def resolved_gain(gain: float | None, robot: Robot, gait: Gait) -> float:
    """The gain a run of `gait` uses (`robots.attitude.gait_attitude_gain`: the option if
    given, else the robot's default), said on the console when the default closes the loop."""
    return resolved_library_gain(gain, robot, (gait,), "runs")


def resolved_library_gain(gain: float | None, robot: Robot, gaits: Sequence[Gait],
                          verb: str = "drives") -> float:
    """`resolved_gain` for a drive through a library's `gaits` (`drive-sim`): the option if
    given, else the largest of the robot's defaults over the gaits (a biped's walks close the
    loop at the rule's gain even if the library also holds a run, which the rule keeps open loop:
    the law runs on the blend, one gain for the drive), said on the console when the default
    closes the loop (`verb`: what ``--attitude-gain 0`` then does open loop)."""
    from robots.attitude import gait_attitude_gain

    resolved, why = max((gait_attitude_gain(robot, g, gain) for g in gaits), key=lambda d: d[0])
    if gain is None and resolved > 0.0:
        from gaitsmith.console import console

        console.print(f"attitude feedback: gain {resolved:g} ({why}); --attitude-gain 0 {verb} "
                      "open loop", highlight=False, markup=False)
    return resolved


def attitude_settings(gain: float | None, imu_latency_ms: float = 0.0,
                      imu_noise_deg: float = 0.0) -> AttitudeSettings | None:
    """The run's closed-loop settings (None: open loop), from checked options."""
    if not gain:
        return None
    import math

    from sim.attitude_loop import ImuSettings, closed_loop

    return closed_loop(float(gain), ImuSettings(imu_latency_ms / 1000.0,
                                                math.radians(imu_noise_deg)))

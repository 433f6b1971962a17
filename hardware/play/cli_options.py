"""The typer options `gaitsmith-play run`, `drive` and `identify` share, declared once.

Each function returns a fresh `typer.Option` (typer keeps per-parameter state on the object, so
one instance is not shared between commands). The default and flag names are the same in every
command; the help text may add what a command does differently.
"""

from __future__ import annotations

from typing import Any

import typer

from hardware.play.player import OnStop, RestPose

SUSTAINED_RATE_HZ = 100.0  # the loop's sustainable rate (see hardware.play.commands)


def robot_option() -> Any:
    return typer.Option(..., "--robot", help="Robot name or folder, e.g. quad12.")


def port_option() -> Any:
    return typer.Option(None, "--port", "-p", help="Serial device, e.g. /dev/ttyUSB0.")


def calibration_option() -> Any:
    return typer.Option(None, "--calibration", help="Calibration JSON.")


def rate_option(help_text: str | None = None) -> Any:
    return typer.Option(
        100.0,
        "--rate",
        help=help_text or f"Stream rate [Hz], 1..1000 (sustained: ≤ {SUSTAINED_RATE_HZ:g}).",
    )


def telemetry_option() -> Any:
    return typer.Option(None, "--telemetry", help="Write per-tick CSV here.")


def ramp_option() -> Any:
    return typer.Option(2.0, "--ramp-s", help="Minimum ramp-in time [s].")


def rest_option() -> Any:
    return typer.Option(RestPose.STANCE, "--rest", help="Pose to ramp to on stop.")


def on_stop_option() -> Any:
    return typer.Option(OnStop.TORQUE_OFF, "--on-stop", help="After the rest ramp.")


def timeout_option() -> Any:
    return typer.Option(3.0, "--timeout-ms", help="Reply allowance per packet.")


def baud_option() -> Any:
    return typer.Option(None, "--baud", help="Baud rate; default: the robot's.")


def realtime_option() -> Any:
    return typer.Option(True, "--realtime/--no-realtime", help="Virtual: real time.")


def fault_option(help_text: str) -> Any:
    return typer.Option(None, "--fault", metavar="KIND=VALUE@T", help=help_text)


def supply_option(help_text: str) -> Any:
    return typer.Option(None, "--supply-v", help=help_text)


def attitude_gain_option(default_text: str) -> Any:
    """`--attitude-gain` (`run`, `drive`); `default_text` says what the default gain is."""
    return typer.Option(
        None, "--attitude-gain",
        help="IMU feedback on body roll/pitch with gain G (0 to 2; hardware.play.attitude), "
        "added to the goals before the safety gate, from --imu or --virtual sim (the MuJoCo "
        f"twin's body); default with either: {default_text}, else 0.")


def imu_option() -> Any:
    return typer.Option(
        None, "--imu", metavar="PORT",
        help="Serial port of a WitMotion IMU (WT901/JY901/HWT901B; hardware.imu.witmotion) "
        "on the robot's body, for --attitude-gain; it must stream angle frames at >= 40 Hz.")


def imu_baud_option() -> Any:
    from hardware.imu.witmotion import DEFAULT_BAUD

    return typer.Option(
        DEFAULT_BAUD, "--imu-baud", help="The IMU's baud rate (WitMotion factory: 9600).")


def imu_mount_option() -> Any:
    return typer.Option(
        "", "--imu-mount", metavar="yaw=DEG,roll=DEG",
        help="The IMU's axes on the body (x forward, y left, z up): yaw turns its X axis "
        "about body up (X pointing right: yaw=-90); roll=180: mounted upside down.")


__all__ = [
    "SUSTAINED_RATE_HZ",
    "attitude_gain_option",
    "baud_option",
    "calibration_option",
    "fault_option",
    "imu_baud_option",
    "imu_mount_option",
    "imu_option",
    "on_stop_option",
    "port_option",
    "ramp_option",
    "rate_option",
    "realtime_option",
    "rest_option",
    "robot_option",
    "supply_option",
    "telemetry_option",
    "timeout_option",
]

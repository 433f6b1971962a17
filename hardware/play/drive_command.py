"""`gaitsmith-play drive LIB --robot R (--port P | --virtual [sim])`: drive from live commands.

The robot stands up (pre-flight, ramp-in to the library's stand), then walks at the commands of
`--input` (default: the keyboard in a terminal, JSON lines on stdin otherwise; see
`hardware.play.command_sources`), blended from the library's gaits (`hardware.play.drive`).
No command for `--deadman-s` → decelerate to the stand. The drive ends standing once the input
ends (EOF, `{"end": true}`, X on the keyboard) or after `--max-drive-s`; then, as after `run`,
the ramp to rest and torque off. Signals, the watchdog, faults (`--fault`, virtual bus only) and
exit codes are `run`'s (`hardware.play.commands`). IMU attitude feedback (`--attitude-gain`,
`--imu PORT`, or the twin's body with `--virtual sim`) is `run`'s too, options and wiring
shared, applied to the blended command (`hardware.play.drive`).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Any

import typer
from rich.markup import escape

from hardware.bus.servo_bus import BusConfig
from hardware.play.cli_options import (
    SUSTAINED_RATE_HZ,
    attitude_gain_option,
    baud_option,
    calibration_option,
    fault_option,
    imu_baud_option,
    imu_mount_option,
    imu_option,
    on_stop_option,
    port_option,
    ramp_option,
    rate_option,
    realtime_option,
    rest_option,
    robot_option,
    supply_option,
    telemetry_option,
    timeout_option,
)
from hardware.play.clock import Clock
from hardware.play.commands import (
    Feedback,
    VirtualMode,
    _attitude_problem,
    _fail,
    _fault_schedule,
    _load_inputs,
    _summary,
    check_option,
    console,
    err_console,
    feedback_clock,
    finish_session,
    open_feedback,
    play_session,
)
from hardware.play.player import OnStop, PlayerConfig, RestPose

# option: (lowest, highest, unit) — checked before anything runs
DRIVE_OPTION_RANGES: dict[str, tuple[float, float, str]] = {
    "--deadman-s": (0.02, 60.0, "s"),
    "--accel": (0.01, 20.0, "m/s²"),
    "--yaw-accel": (0.01, 50.0, "rad/s²"),
    "--max-drive-s": (0.0, 86400.0, "s (0 = until the input ends)"),
}


def _check(name: str, value: float) -> str | None:
    if name not in DRIVE_OPTION_RANGES:
        return check_option(name, value)
    lo, hi, unit = DRIVE_OPTION_RANGES[name]
    if not (math.isfinite(value) and lo <= value <= hi):
        return f"{name} {value:g}: must be a finite number in [{lo:g}, {hi:g}] {unit}"
    return None


def drive(
    library: Path = typer.Argument(..., help="Gait library (gaitsmith.library/1 JSON)."),
    robot: str = robot_option(),
    port: str | None = port_option(),
    virtual: VirtualMode | None = typer.Option(
        None, "--virtual", help="No hardware: alone = in-process virtual bus; 'sim' = MuJoCo twin."
    ),
    input_spec: str | None = typer.Option(
        None,
        "--input",
        help="keyboard | gamepad[:/dev/input/eventN] | stdin | socket:PATH (JSON lines "
        '{"vx":0.1,"vy":0,"yaw_rate":0.2}); default: keyboard in a terminal, else stdin.',
    ),
    deadman_s: float = typer.Option(
        0.5, "--deadman-s", help="No command for this long → decelerate to the stand [s]."
    ),
    rate_hz: float = rate_option(),
    telemetry: Path | None = telemetry_option(),
    accel: float = typer.Option(0.5, "--accel", help="Command acceleration limit [m/s²]."),
    yaw_accel: float = typer.Option(
        1.5, "--yaw-accel", help="Yaw-rate acceleration limit [rad/s²]."
    ),
    max_drive_s: float = typer.Option(
        0.0, "--max-drive-s", help="End (standing) after this long [s]; 0 = when input ends."
    ),
    calibration: Path | None = calibration_option(),
    ramp_s: float = ramp_option(),
    rest: RestPose = rest_option(),
    on_stop: OnStop = on_stop_option(),
    force: bool = typer.Option(False, "--force", help="Drive gaits that did not pass sim."),
    timeout_ms: float = timeout_option(),
    baud: int | None = baud_option(),
    realtime: bool = realtime_option(),
    fault: list[str] | None = fault_option(
        "Virtual bus only, repeatable: inject a fault (as `run --fault`)."
    ),
    supply_v: float | None = supply_option("Servo supply [V] for pre-flight's torque margin."),
    attitude_gain: float | None = attitude_gain_option(
        "the largest gain the library's gaits were validated with"),
    imu: str | None = imu_option(),
    imu_baud: int = imu_baud_option(),
    imu_mount: str = imu_mount_option(),
) -> None:
    """Drive the robot live: keyboard, gamepad or JSON-line commands, blended from a gait
    library; every target through the safety gate; no command for --deadman-s → stand.

    Ctrl-C, SIGTERM, SIGHUP and SIGQUIT stop safely as in `run` (ramp to rest, torque off);
    exit codes as `run`: 0 completed, 2 refused, 3-9 watchdog / bus, 129-143 signals."""
    from hardware.play.command_sources import check_input_spec

    for name, value in (
        ("--rate", rate_hz), ("--ramp-s", ramp_s), ("--timeout-ms", timeout_ms), ("--baud", baud),
        ("--deadman-s", deadman_s), ("--accel", accel), ("--yaw-accel", yaw_accel),
        ("--max-drive-s", max_drive_s),
    ):  # fmt: skip
        problem = None if value is None else _check(name, value)
        if problem is not None:
            raise _fail(problem)
    if rate_hz > SUSTAINED_RATE_HZ:
        err_console.print(
            f"[bold yellow]WARNING: --rate {rate_hz:g} is above the {SUSTAINED_RATE_HZ:g} Hz "
            "this player sustains with margin; expect overruns[/]",
            highlight=False,
        )
    stdin_fd = _stdin_fd()
    if input_spec is None:
        input_spec = "keyboard" if stdin_fd is not None and os.isatty(stdin_fd) else "stdin"
    problem = check_input_spec(input_spec)
    if problem is not None:
        raise _fail(problem)
    if fault and virtual is None:
        raise _fail("--fault injects faults into the virtual bus only: add --virtual")
    if port is None and virtual is None:
        raise _fail("give --port DEVICE or --virtual [bus|sim]")
    problem = _attitude_problem(attitude_gain, virtual, imu)
    if problem is not None:
        raise _fail(problem)
    rob, _, cal = _load_inputs(robot, None, calibration)
    lib = _load_library(library, rob)
    faults = _fault_schedule(fault or [], [j.bus_id for j in rob.joints])
    try:
        config = PlayerConfig(
            rate_hz=rate_hz, cycles=None, ramp_s=ramp_s, rest=rest, on_stop=on_stop,
            force=force, supply_v=supply_v,
        )  # fmt: skip
        bus_config = BusConfig(
            timeout_s=timeout_ms / 1000.0, retries=1, baudrate=baud or rob.bus_baud
        )
        from hardware.play.drive import DriveConfig

        drive_config = DriveConfig(
            deadman_s=deadman_s, accel_m_s2=accel, yaw_accel_rad_s2=yaw_accel,
            max_drive_s=max_drive_s or None,
        )  # fmt: skip
    except ValueError as exc:
        raise _fail(str(exc)) from None
    clock = feedback_clock(realtime, virtual, imu)
    feedback = open_feedback(attitude_gain, imu, imu_baud, imu_mount, clock)
    try:
        _drive(rob, lib, cal, port, virtual, input_spec, stdin_fd, config, bus_config,
               drive_config, faults, clock, telemetry, feedback)
    finally:
        feedback.close()


def _drive(rob: Any, lib: Any, cal: Any, port: str | None, virtual: VirtualMode | None,
           input_spec: str, stdin_fd: int | None, config: PlayerConfig, bus_config: BusConfig,
           drive_config: Any, faults: Any, clock: Clock, telemetry: Path | None,
           feedback: Feedback) -> None:
    """`drive` after its options are checked and the IMU is open: drive, report, exit."""
    from hardware.play.command_sources import open_source
    from hardware.play.drive import TELEMETRY_COLUMNS, drive_from_library

    rate_hz = config.rate_hz
    with play_session(
        rob, port, virtual, bus_config, clock, faults, telemetry, TELEMETRY_COLUMNS
    ) as session:
        echo = None
        if input_spec == "keyboard":
            from hardware.play.command_sources import KEYBOARD_HELP

            err_console.print(KEYBOARD_HELP, highlight=False)

            def echo(text: str) -> None:
                err_console.print(text, highlight=False)

        if stdin_fd is None and input_spec in ("keyboard", "stdin"):
            raise _fail(f"--input {input_spec}: this process has no stdin to read")
        source = open_source(input_spec, lib.command_bounds(), stdin_fd or 0, echo)
        try:
            gaits = [lib.stand, *(e.gait for e in lib.entries)]
            driver = drive_from_library(
                rob, lib, source, bus=session.bus, calibration=cal, config=config,
                drive=drive_config, clock=clock, telemetry=session.writer,
                on_tick=faults.on_tick if faults is not None and faults.timed else None,
                attitude=feedback.corrector(rob, gaits, session.twin, clock),
            )  # fmt: skip
            result = driver.drive_run()
        finally:
            source.close()  # the terminal restored, the socket removed, on every path

    def report() -> None:
        _report(result, session.twin, rate_hz, telemetry)
        feedback.report()

    finish_session(report, result.exit_code)


def _stdin_fd() -> int | None:
    """The file descriptor of stdin (None when stdin is not a real file, e.g. closed)."""
    try:
        return sys.stdin.fileno()
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both
        return None


def _load_library(path: Path, robot: Any) -> Any:
    import robots
    from robots.library import load

    try:
        return load(path, robot)
    except robots.RobotsError as exc:
        raise _fail(str(exc)) from None


def _report(result: Any, twin: Any, rate_hz: float, telemetry: Path | None) -> None:
    play = result.play
    if play.supply_margin is not None:
        console.print(escape(play.supply_margin), highlight=False)
    for w in play.warnings:
        err_console.print(f"[bold yellow]{escape(w)}[/]", highlight=False)
    _summary(play, twin, rate_hz)
    console.print(escape(result.summary()), highlight=False, soft_wrap=True)
    for note in result.notes:
        err_console.print(f"[bold yellow]{escape(note)}[/]", highlight=False)
    if telemetry is not None and play.telemetry_cut is not None:
        err_console.print(
            f"[bold yellow]telemetry CUT SHORT: {escape(str(telemetry))}: "
            f"{escape(play.telemetry_cut)}[/]",
            highlight=False,
        )
    elif telemetry is not None:
        console.print(f"telemetry: {telemetry}", highlight=False)


"""`gaitsmith-play run | calibrate | plot`: the player's commands, registered onto hardware.cli.

Exit codes: 0 completed, 2 refused (pre-flight, bad file or option), 3 no response,
4 servo fault, 5 over-temperature, 6 low voltage, 7 bus error, 8 status lost (servo health
unreadable), 130 SIGINT, 143 SIGTERM.

`run --virtual --fault KIND=VALUE[@T]` (repeatable) injects faults into the virtual bus to
rehearse the safe stop without hardware; the syntax is in `hardware.fault_spec`.
"""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.markup import escape
from typer.core import TyperCommand

from hardware.bus import BusConfig, ServoBus
from hardware.clock import Clock, MonotonicClock, VirtualClock
from hardware.errors import HardwareError
from hardware.player import OnStop, Player, PlayerConfig, PlayResult, RestPose
from hardware.watchdog import EXIT_PREFLIGHT, StopReason

if TYPE_CHECKING:
    from hardware.fault_spec import FaultSchedule

console = Console()
err_console = Console(stderr=True)
VIRTUAL_CHOICES = ("bus", "sim")


class VirtualMode(str, Enum):
    bus = "bus"
    sim = "sim"


class _RunCommand(TyperCommand):
    """`--virtual` takes an optional value: alone it means the in-process bus ("bus")."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        out: list[str] = []
        for i, a in enumerate(args):
            out.append(a)
            if a == "--virtual" and (i + 1 >= len(args) or args[i + 1] not in VIRTUAL_CHOICES):
                out.append("bus")
        return super().parse_args(ctx, out)


def _fail(message: str, code: int = EXIT_PREFLIGHT) -> typer.Exit:
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return typer.Exit(code)


def _load_inputs(robot_name: str, gait_path: Path | None, calibration: Path | None) -> Any:
    """(robot, gait or None, calibration) or a one-line failure."""
    import robots
    from hardware.calibration import Calibration, load_or_default
    from robots.gait import load as load_gait

    try:
        robot = robots.load(robot_name)
        _require_drivable_servos(robot)
        gait = load_gait(gait_path, robot) if gait_path is not None else None
        cal = Calibration.load(calibration, robot) if calibration else load_or_default(robot)
    except (robots.RobotsError, HardwareError) as exc:
        raise _fail(str(exc)) from None
    return robot, gait, cal


# How the refusal names a catalogue protocol that has no bus driver (hardware.control_table.TABLES).
_UNDRIVABLE_LABELS = {
    "pwm": "PWM",
    "dynamixel1": "Dynamixel Protocol 1.0",
    "dynamixel2_xl320": "the XL-320's own Protocol 2.0 control table",
    "feetech_scs": "the big-endian Feetech SCS protocol",
    "hiwonder_bus": "the Hiwonder bus protocol",
}


def _require_drivable_servos(robot: Any) -> None:
    """PlayerError unless every servo speaks a protocol with a bus driver and control table."""
    from hardware.control_table import TABLES
    from hardware.play_errors import PlayerError

    for j in robot.joints:
        protocol = j.servo.protocol
        if protocol not in TABLES:
            label = _UNDRIVABLE_LABELS.get(protocol, f"protocol {protocol!r}")
            raise PlayerError(
                f"servo model {j.servo.name} on joint {j.name} uses {label}, which gaitsmith-play "
                "cannot drive; plan and simulate work, play needs a Dynamixel (Protocol 2.0) or "
                "Feetech STS bus servo"
            )


def _open_bus(
    robot: Any,
    port: str | None,
    virtual: VirtualMode | None,
    config: BusConfig,
    clock: Clock,
    faults: FaultSchedule | None = None,
) -> tuple[ServoBus, Any]:
    """An opened bus: a real port, the in-process virtual bus, or the MuJoCo twin (`faults`:
    put on the virtual bus before anything is sent)."""
    if virtual is VirtualMode.sim:
        from sim.twin import MujocoTwin  # lazy: hardware never imports mujoco at import time

        twin = MujocoTwin(robot, clock=clock.now_s)
        if faults is not None:
            faults.attach(twin.vbus)
        return twin.vbus.connect(config), twin
    if virtual is VirtualMode.bus:
        from hardware.virtual_rig import virtual_robot_bus

        vbus = virtual_robot_bus(robot, clock=clock.now_s)
        if faults is not None:
            faults.attach(vbus)
        return vbus.connect(config), vbus
    if port is None:
        raise _fail("give --port DEVICE, --virtual [bus|sim], or --dry-run")
    from hardware.dynamixel import DynamixelBus
    from hardware.feetech import FeetechBus

    bus: ServoBus = (
        DynamixelBus(port, config)
        if robot.servo_protocol == "dynamixel2"
        else FeetechBus(port, config)
    )
    bus.open()
    return bus, None


def _summary(result: PlayResult, twin: Any) -> None:
    stop = result.stop
    colour = "green" if stop.reason is StopReason.COMPLETED else "bold red"
    console.print(
        f"[{colour}]stopped: {stop.reason.value}[/] — {escape(stop.message)}", highlight=False
    )
    phases = ", ".join(f"{k} {v}" for k, v in result.ticks_by_phase.items())
    console.print(
        f"{result.ticks} ticks ({phases}); rate {result.achieved_rate_hz:.1f} Hz; jitter p50 "
        f"{result.jitter_p50_s * 1e3:.3f} ms, p99 {result.jitter_p99_s * 1e3:.3f} ms, max "
        f"{result.jitter_max_s * 1e3:.3f} ms; overruns {result.overruns}; missed reads "
        f"{result.misses} (status {result.status_misses}); clipped: limits "
        f"{result.limit_clips}, steps {result.step_clips}",
        highlight=False,
    )
    if result.torque_off_failures:
        err_console.print(
            f"[bold red]torque-off NOT confirmed by servos {list(result.torque_off_failures)}: "
            "cut the power[/]"
        )
    if twin is not None and hasattr(twin, "summary"):
        console.print(twin.summary(), highlight=False)


def run(
    gait: Path = typer.Argument(..., help="Gait file (gaitsmith.gait/1 JSON)."),
    robot: str = typer.Option(..., "--robot", help="Robot name or folder, e.g. quad12."),
    port: str | None = typer.Option(None, "--port", "-p", help="Serial device, e.g. /dev/ttyUSB0."),
    virtual: VirtualMode | None = typer.Option(
        None, "--virtual", help="No hardware: alone = in-process virtual bus; 'sim' = MuJoCo twin."
    ),
    calibration: Path | None = typer.Option(None, "--calibration", help="Calibration JSON."),
    rate_hz: float = typer.Option(100.0, "--rate", help="Stream rate [Hz]."),
    cycles: float = typer.Option(1.0, "--cycles", help="Gait cycles to play (0 = until Ctrl-C)."),
    speed_scale: float = typer.Option(1.0, "--speed-scale", help="Gait time scaling (<1 slower)."),
    dry_run: bool = typer.Option(False, "--dry-run", help="Check and compute; send nothing."),
    telemetry: Path | None = typer.Option(None, "--telemetry", help="Write per-tick CSV here."),
    ramp_s: float = typer.Option(2.0, "--ramp-s", help="Minimum ramp-in time \\[s]."),
    rest: RestPose = typer.Option(RestPose.STANCE, "--rest", help="Pose to ramp to on stop."),
    on_stop: OnStop = typer.Option(OnStop.TORQUE_OFF, "--on-stop", help="After the rest ramp."),
    force: bool = typer.Option(False, "--force", help="Play a gait that did not pass sim."),
    timeout_ms: float = typer.Option(3.0, "--timeout-ms", help="Reply allowance per packet."),
    baud: int | None = typer.Option(None, "--baud", help="Baud rate; default: the robot's."),
    realtime: bool = typer.Option(True, "--realtime/--no-realtime", help="Virtual: real time."),
    fault: list[str] | None = typer.Option(
        None,
        "--fault",
        metavar="KIND=VALUE@T",
        help="Virtual bus only, repeatable: inject a fault to rehearse the safe stop. "
        "KIND=VALUE is one of drop=P, corrupt=P, delay=S, sag=V, vanish=ID, overload=ID, "
        "overheat=ID, voltage-error=ID, or status-lost (no value); an optional @T starts it "
        "T seconds into the run (without it: from the start, pre-flight included). "
        "E.g. --fault drop=0.01 --fault vanish=3@2.0",
    ),
) -> None:
    """Play a gait on the servos: pre-flight, ramp-in, stream, watchdog, safe stop."""
    if fault and virtual is None:
        raise _fail(
            "--fault injects faults into the virtual bus only: add --virtual (or --virtual sim) "
            "to rehearse on it, or drop --fault to play on real servos"
        )
    rob, gait_obj, cal = _load_inputs(robot, gait, calibration)
    faults = _fault_schedule(fault or [], [j.bus_id for j in rob.joints])
    try:
        config = PlayerConfig(
            rate_hz=rate_hz,
            cycles=cycles or None,
            speed_scale=speed_scale,
            ramp_s=ramp_s,
            rest=rest,
            on_stop=on_stop,
            dry_run=dry_run,
            force=force,
        )
        bus_config = BusConfig(
            timeout_s=timeout_ms / 1000.0, retries=1, baudrate=baud or rob.bus_baud
        )
    except ValueError as exc:
        raise _fail(str(exc)) from None
    clock: Clock = MonotonicClock() if realtime or virtual is None else VirtualClock()
    bus: ServoBus | None = None
    twin: Any = None
    writer = None
    try:
        if not dry_run or port is not None or virtual is not None:
            bus, twin = _open_bus(rob, port, virtual, bus_config, clock, faults)
        if telemetry is not None:
            from hardware.telemetry import TelemetryWriter

            writer = TelemetryWriter(telemetry, rob.joint_names, [j.bus_id for j in rob.joints])
        player = Player(
            rob,
            gait_obj,
            bus=bus,
            calibration=cal,
            config=config,
            clock=VirtualClock() if dry_run else clock,
            telemetry=writer,
            on_tick=faults.on_tick if faults is not None and faults.timed else None,
        )
        if faults is not None:
            console.print(f"[bold]virtual bus faults[/]: {faults.describe()}", highlight=False)
        if dry_run:
            console.print("[bold]dry run[/]: nothing is sent to the servos")
        result = player.run()
    except HardwareError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"{exc.filename or ''}: {exc.strerror or exc}") from None
    finally:
        if writer is not None:
            writer.close()
        if bus is not None:
            bus.close()
    for w in result.warnings:
        err_console.print(f"[bold yellow]{w}[/]", highlight=False)
    _summary(result, twin)
    if telemetry is not None:
        console.print(f"telemetry: {telemetry}", highlight=False)
    if result.exit_code:
        raise typer.Exit(result.exit_code)


def _fault_schedule(texts: list[str], servo_ids: list[int]) -> FaultSchedule | None:
    """The `--fault` options as a schedule (None without any), or a one-line failure."""
    if not texts:
        return None
    from hardware.fault_spec import FaultSchedule, FaultSpecError, parse_fault

    try:
        return FaultSchedule([parse_fault(t, servo_ids) for t in texts])
    except FaultSpecError as exc:
        raise _fail(str(exc)) from None


def calibrate(
    robot: str = typer.Option(..., "--robot", help="Robot name or folder."),
    port: str | None = typer.Option(None, "--port", "-p", help="Serial device."),
    virtual: bool = typer.Option(False, "--virtual", help="Use the in-process virtual bus."),
    output: Path | None = typer.Option(None, "--output", "-o", help="Default: per-build path."),
    timeout_ms: float = typer.Option(10.0, "--timeout-ms", help="Reply allowance per packet."),
) -> None:
    """Record zero offsets: torque off, pose the robot in its reference pose, press Enter."""
    from hardware.calibrate_flow import record_zero_offsets
    from hardware.calibration import default_path

    rob, _, _ = _load_inputs(robot, None, None)
    config = BusConfig(timeout_s=timeout_ms / 1000.0, retries=2, baudrate=rob.bus_baud)

    def ask(text: str) -> str:
        return str(typer.prompt(text, default="", show_default=False))

    try:
        bus, _ = _open_bus(
            rob, port, VirtualMode.bus if virtual else None, config, MonotonicClock()
        )
        with bus:
            outcome = record_zero_offsets(
                rob, bus, ask, lambda s: console.print(s, highlight=False)
            )
        path = outcome.calibration.save(output or default_path(rob))
    except HardwareError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"cannot save calibration: {exc}") from None
    for w in outcome.warnings:
        err_console.print(f"[bold yellow]WARNING: {w}[/]", highlight=False)
    console.print(f"calibration saved: {path}", highlight=False, soft_wrap=True)


def plot(
    telemetry: Path = typer.Argument(..., help="Telemetry CSV from `run --telemetry`."),
    output: Path = typer.Option(Path("telemetry.png"), "--output", "-o", help="PNG to write."),
) -> None:
    """Plot targets vs present positions per joint, and the loop jitter."""
    from hardware.telemetry import plot_telemetry, read_telemetry

    try:
        tel = read_telemetry(telemetry)
        out = plot_telemetry(tel, output, title=telemetry.name)
    except (OSError, ValueError) as exc:
        raise _fail(str(exc)) from None
    console.print(f"plot: {out} ({len(tel.tick)} ticks, stop: {tel.stop_reason})", highlight=False)


def register(app: typer.Typer) -> None:
    """Add `run`, `calibrate` and `plot` to the `gaitsmith-play` app."""
    app.command("run", cls=_RunCommand)(run)
    app.command("calibrate")(calibrate)
    app.command("plot")(plot)

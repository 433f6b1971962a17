"""`gaitsmith-play run | drive | calibrate | plot | report | budget`: the player's commands
(`drive`: `hardware.play.drive_command`).

Exit codes: 0 completed, 2 refused (pre-flight, bad file or option), 3 no response,
4 servo fault, 5 over-temperature, 6 low voltage, 7 bus error, 8 status lost (servo health
unreadable), 9 adapter lost (the serial adapter failed: unplugged, EIO), 129 SIGHUP (terminal
closed), 130 SIGINT (Ctrl-C), 131 SIGQUIT, 143 SIGTERM. A telemetry log cut short (disk full)
does not change the exit code: the run ends as it would have, and a last line says so.

Signals: SIGINT (Ctrl-C), SIGTERM (kill, systemd), SIGHUP (the terminal or ssh session closed)
and SIGQUIT (Ctrl-\\) all do the same: stop safely — ramp to the rest pose, then torque off
(or hold, with `--on-stop hold` after a clean ramp). The first signal is the stop reason (the
telemetry stop row and the exit code say which); any later one skips what is left of the rest
ramp and goes straight to torque off, which is always sent. The handlers are in place from the
moment the command has loaded until the torque-off and the telemetry stop row are written; a
signal in the first fraction of a second, before anything was sent to a servo, ends the process
with the signal's default action. SIGKILL cannot be caught: with it, the servos hold their last
goal with torque on — cut the power.

Rates: the loop sustains up to `SUSTAINED_RATE_HZ` = 100 Hz with margin (benchmarks/
player_bench.py, quad12 = 12 × STS3215 on the in-process virtual bus, 2 shared cores at load
average 3-6: 100 Hz held, 0 overruns, p99 tick work 2.6 ms of the 10 ms budget; 200 Hz gave
193 Hz with 239 overruns, 500 Hz 348 Hz, 1000 Hz 248 Hz). `run` warns before a run asked above
it and, after any run, when the achieved rate fell below 98 % of the request or more than 5 %
of the ticks overran, naming the rate this machine sustains (0.7 / p99 tick work). On a real
port it also warns before the run when --rate is beyond what the bus sustains (`gaitsmith-play
budget`, with the adapter's latency timer read from sysfs); a warning, not a refusal: late ticks
are safe (no burst, per-tick step limit), the robot only plays slower than asked.

`run --virtual --fault KIND=VALUE[@T]` (repeatable) injects faults into the virtual bus to
rehearse the safe stop without hardware; the syntax is in `hardware.play.fault_spec`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.markup import escape
from typer.core import TyperCommand

from hardware.bus.servo_bus import BusConfig, ServoBus
from hardware.errors import HardwareError
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
from hardware.play.clock import Clock, MonotonicClock, VirtualClock
from hardware.play.player import MAX_RAMP_S, OnStop, Player, PlayerConfig, PlayResult, RestPose
from hardware.play.watchdog import EXIT_PREFLIGHT, StopReason

if TYPE_CHECKING:
    from hardware.play.fault_spec import FaultSchedule
    from hardware.play.telemetry import TelemetryWriter

console = Console()
err_console = Console(stderr=True)
VIRTUAL_CHOICES = ("bus", "sim")
RATE_SHORTFALL = 0.98  # achieved / requested below this: warn after the run
OVERRUN_FRACTION = 0.05  # more overrunning ticks than this: warn after the run
MAX_CYCLES = 1e6
# option: (lowest, highest, unit, what 0 / the bounds mean) — checked before anything runs
OPTION_RANGES: dict[str, tuple[float, float, str]] = {
    "--rate": (1.0, 1000.0, "Hz"),
    "--cycles": (0.0, MAX_CYCLES, "(0 = until stopped)"),
    "--speed-scale": (0.01, 10.0, ""),
    "--ramp-s": (0.01, MAX_RAMP_S, "s"),
    "--stand-s": (0.0, MAX_RAMP_S, "s"),
    "--timeout-ms": (0.1, 1000.0, "ms"),
    "--baud": (1200, 10_000_000, "bit/s"),
}


def check_option(name: str, value: float) -> str | None:
    """The one-line complaint about option `name`'s `value` (None: accepted)."""
    lo, hi, unit = OPTION_RANGES[name]
    if not (math.isfinite(value) and lo <= value <= hi):
        return f"{name} {value:g}: must be a finite number in [{lo:g}, {hi:g}] {unit}".rstrip()
    return None


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
    from hardware.play.calibration import Calibration, load_or_default
    from robots.gait import load as load_gait

    try:
        robot = robots.load(robot_name)
        _require_drivable_servos(robot)
        gait = load_gait(gait_path, robot) if gait_path is not None else None
        cal = Calibration.load(calibration, robot) if calibration else load_or_default(robot)
    except (robots.RobotsError, HardwareError) as exc:
        raise _fail(str(exc)) from None
    return robot, gait, cal


# How the refusal names a catalogue protocol that has no bus driver
# (hardware.bus.control_table.TABLES).
_UNDRIVABLE_LABELS = {
    "pwm": "PWM",
    "dynamixel2_xl320": "the XL-320's own Protocol 2.0 control table",
    "feetech_scs": "the big-endian Feetech SCS protocol",
    "hiwonder_bus": "the Hiwonder bus protocol",
}


def _require_drivable_servos(robot: Any) -> None:
    """PlayerError unless every servo speaks a protocol with a bus driver and control table."""
    from hardware.bus.control_table import TABLES
    from hardware.play.errors import PlayerError

    for j in robot.joints:
        protocol = j.servo.protocol
        if protocol not in TABLES:
            label = _UNDRIVABLE_LABELS.get(protocol, f"protocol {protocol!r}")
            raise PlayerError(
                f"servo model {j.servo.name} on joint {j.name} uses {label}, which gaitsmith-play "
                "cannot drive; plan and simulate work, play needs a Dynamixel (Protocol 1.0 AX / "
                "MX or 2.0 X-series) or Feetech STS bus servo"
            )


VIRTUAL_PLANTS_GROUP = "gaitsmith.virtual_buses"  # entry points: name -> factory(robot, clock=)


def _virtual_plant(name: str) -> Any:
    """The factory of a virtual bus driven by a plant outside `hardware` (e.g. `sim`'s MuJoCo
    twin), found by entry point so that hardware never imports sim, not even lazily; the
    factory's result carries the virtual bus as `.vbus`."""
    from importlib.metadata import entry_points

    for point in entry_points(group=VIRTUAL_PLANTS_GROUP):
        if point.name == name:
            return point.load()
    raise _fail(
        f"--virtual {name}: no virtual bus {name!r} is installed (entry point group "
        f"{VIRTUAL_PLANTS_GROUP}); the MuJoCo twin comes with the full install: pip install -e ."
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
        twin = _virtual_plant("sim")(robot, clock=clock.now_s)
        if faults is not None:
            faults.attach(twin.vbus)
        return twin.vbus.connect(config), twin
    if virtual is VirtualMode.bus:
        from hardware.play.virtual_rig import virtual_robot_bus

        vbus = virtual_robot_bus(robot, clock=clock.now_s)
        if faults is not None:
            faults.attach(vbus)
        return vbus.connect(config), vbus
    if port is None:
        raise _fail("give --port DEVICE, --virtual [bus|sim], or --dry-run")
    from hardware.bus.dynamixel import Dynamixel1Bus, DynamixelBus
    from hardware.bus.feetech import FeetechBus

    drivers = {"dynamixel1": Dynamixel1Bus, "dynamixel2": DynamixelBus}
    bus: ServoBus = drivers.get(robot.servo_protocol, FeetechBus)(port, config)
    bus.open()
    return bus, None


def _summary(result: PlayResult, twin: Any, requested_hz: float) -> None:
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
    for w in rate_warnings(result, requested_hz):
        err_console.print(f"[bold yellow]{escape(w)}[/]", highlight=False)


def rate_warnings(result: PlayResult, requested_hz: float) -> list[str]:
    """After a run: say so when the loop fell short of the requested rate or overran often,
    with the rate this machine sustains (70 % of 1 / the p99 tick work, rounded down)."""
    if result.dry_run or result.ticks < 20:
        return []
    short = result.achieved_rate_hz < RATE_SHORTFALL * requested_hz
    many = result.overruns > OVERRUN_FRACTION * result.ticks
    if not (short or many):
        return []
    advice = ""
    if result.work_p99_s > 0:
        sustained = 0.7 / result.work_p99_s
        nice = max(1.0, float(10 * math.floor(sustained / 10)) if sustained >= 10 else 1.0)
        if nice < requested_hz:
            advice = f"; this machine sustains about --rate {nice:g}"
    return [
        f"WARNING: the loop held {result.achieved_rate_hz:.1f} Hz of the {requested_hz:g} Hz "
        f"asked; {result.overruns} of {result.ticks} ticks overran (p99 tick work "
        f"{result.work_p99_s * 1e3:.2f} ms){advice}"
    ]


def run(
    gait: Path = typer.Argument(..., help="Gait file (gaitsmith.gait/1 JSON)."),
    robot: str = robot_option(),
    port: str | None = port_option(),
    virtual: VirtualMode | None = typer.Option(
        None, "--virtual", help="No hardware: alone = in-process virtual bus; 'sim' = MuJoCo twin."
    ),
    calibration: Path | None = calibration_option(),
    rate_hz: float = rate_option(),
    cycles: float = typer.Option(
        1.0, "--cycles", help="Gait cycles to play (0 = until stopped by a signal)."
    ),
    speed_scale: float = typer.Option(1.0, "--speed-scale", help="Gait time scaling (<1 slower)."),
    dry_run: bool = typer.Option(False, "--dry-run", help="Check and compute; send nothing."),
    telemetry: Path | None = telemetry_option(),
    ramp_s: float = ramp_option(),
    rest: RestPose = rest_option(),
    on_stop: OnStop = on_stop_option(),
    stand_s: float = typer.Option(
        0.0, "--stand-s", help="Hold the gait's stand (mean pose) this long [s] after the "
        "ramp-in and, on completion, at the end."),
    end_at_stand: bool = typer.Option(
        True, "--end-at-stand/--end-at-rest",
        help="On completion blend the gait out to its stand (default), or ramp to --rest. "
        "Stops for a fault or a signal always ramp to --rest."),
    force: bool = typer.Option(False, "--force", help="Play a gait that did not pass sim."),
    timeout_ms: float = timeout_option(),
    baud: int | None = baud_option(),
    realtime: bool = realtime_option(),
    fault: list[str] | None = fault_option(
        "Virtual bus only, repeatable: inject a fault to rehearse the safe stop. "
        "KIND=VALUE is one of drop=P, corrupt=P, delay=S, sag=V, vanish=ID, overload=ID, "
        "overheat=ID, voltage-error=ID, or status-lost / unplug (no value; unplug: the serial "
        "adapter vanishes, EIO); an optional @T starts it "
        "T seconds into the run (without it: from the start, pre-flight included). "
        "E.g. --fault drop=0.01 --fault vanish=3@2.0"
    ),
    supply_v: float | None = supply_option(
        "Servo supply [V] for pre-flight's torque margin; default: measured (the lowest "
        "servo reading)."
    ),
    attitude_gain: float | None = attitude_gain_option("the gain the gait was validated with"),
    imu: str | None = imu_option(),
    imu_baud: int = imu_baud_option(),
    imu_mount: str = imu_mount_option(),
) -> None:
    """Play a gait on the servos: pre-flight, ramp-in, stream, watchdog, safe stop.

    Ctrl-C, SIGTERM, SIGHUP (terminal closed) and SIGQUIT all stop safely: ramp to rest, then
    torque off; a second signal skips the rest of the ramp, never the torque-off. Exit codes:
    0 completed, 2 refused, 3 no response, 4 servo fault, 5 over-temperature, 6 low voltage,
    7 bus error, 8 status lost, 9 adapter lost, 129 SIGHUP, 130 SIGINT, 131 SIGQUIT,
    143 SIGTERM.
    """
    for name, value in (
        ("--rate", rate_hz), ("--cycles", cycles), ("--speed-scale", speed_scale),
        ("--ramp-s", ramp_s), ("--stand-s", stand_s), ("--timeout-ms", timeout_ms),
        ("--baud", baud),
    ):  # fmt: skip
        problem = None if value is None else check_option(name, value)
        if problem is not None:
            raise _fail(problem)
    if rate_hz > SUSTAINED_RATE_HZ and not dry_run:
        err_console.print(
            f"[bold yellow]WARNING: --rate {rate_hz:g} is above the {SUSTAINED_RATE_HZ:g} Hz "
            "this player sustains with margin; expect overruns (the end of the run says how "
            "many)[/]",
            highlight=False,
        )
    if fault and virtual is None:
        raise _fail(
            "--fault injects faults into the virtual bus only: add --virtual (or --virtual sim) "
            "to rehearse on it, or drop --fault to play on real servos"
        )
    problem = _attitude_problem(attitude_gain, virtual, imu)
    if problem is not None:
        raise _fail(problem)
    rob, gait_obj, cal = _load_inputs(robot, gait, calibration)
    if port is not None and virtual is None and not dry_run:
        _warn_beyond_bus_budget(rob, port, baud or rob.bus_baud, rate_hz)
    faults = _fault_schedule(fault or [], [j.bus_id for j in rob.joints])
    try:
        config = PlayerConfig(
            rate_hz=rate_hz,
            cycles=cycles or None,
            speed_scale=speed_scale,
            ramp_s=ramp_s,
            stand_s=stand_s,
            end_at_stand=end_at_stand,
            rest=rest,
            on_stop=on_stop,
            dry_run=dry_run,
            force=force,
            supply_v=supply_v,
        )
        bus_config = BusConfig(
            timeout_s=timeout_ms / 1000.0, retries=1, baudrate=baud or rob.bus_baud
        )
    except ValueError as exc:
        raise _fail(str(exc)) from None
    clock = feedback_clock(realtime, virtual, imu)
    feedback = open_feedback(attitude_gain, imu, imu_baud, imu_mount, clock)
    try:
        _play(rob, gait_obj, cal, port, virtual, config, bus_config, faults, clock, telemetry,
              feedback)
    finally:
        feedback.close()


@dataclass(frozen=True)
class Feedback:
    """The attitude feedback settings of `run` and `drive`: --attitude-gain and the opened
    --imu (or None)."""

    gain: float | None
    imu: Any

    def corrector(self, robot: Any, gaits: Sequence[Any], twin: Any, clock: Clock) -> Any:
        """The `AttitudeCorrector` for these gaits (None: open loop; `attitude_corrector`)."""
        return attitude_corrector(self.gain, robot, gaits, twin, self.imu, clock)

    def report(self) -> None:
        """After the run: the IMU's own summary (frames, bad checksums, a lost port)."""
        if self.imu is not None:
            console.print(self.imu.summary(), highlight=False)

    def close(self) -> None:
        if self.imu is not None:
            self.imu.close()


def feedback_clock(realtime: bool, virtual: VirtualMode | None, imu: str | None) -> Clock:
    """The run's clock: real time on real servos, with --realtime, and with a real IMU (its
    readings are only fresh on a real clock); else the virtual clock."""
    return MonotonicClock() if realtime or virtual is None or imu else VirtualClock()


def open_feedback(gain: float | None, imu: str | None, imu_baud: int, imu_mount: str,
                  clock: Clock) -> Feedback:
    """--attitude-gain and --imu (opened and heard streaming, `_open_imu`) of `run` / `drive`;
    the options were checked by `_attitude_problem` before anything was loaded."""
    return Feedback(gain, None if imu is None else _open_imu(imu, imu_baud, imu_mount, clock))


def _play(rob: Any, gait_obj: Any, cal: Any, port: str | None, virtual: VirtualMode | None,
          config: PlayerConfig, bus_config: BusConfig, faults: FaultSchedule | None,
          clock: Clock, telemetry: Path | None, feedback: Feedback) -> None:
    """`run` after its options are checked and the IMU is open: play, report, exit."""
    dry_run, rate_hz = config.dry_run, config.rate_hz
    with play_session(
        rob, port, virtual, bus_config, clock, faults, telemetry,
        open_bus=not dry_run or port is not None or virtual is not None,
    ) as session:  # fmt: skip
        player = Player(
            rob,
            gait_obj,
            bus=session.bus,
            calibration=cal,
            config=config,
            clock=VirtualClock() if dry_run else clock,
            telemetry=session.writer,
            on_tick=faults.on_tick if faults is not None and faults.timed else None,
            attitude=feedback.corrector(rob, [gait_obj], session.twin, clock),
        )
        if dry_run:
            console.print("[bold]dry run[/]: nothing is sent to the servos")
        result = player.run()

    def report() -> None:
        _report(result, session.twin, rate_hz, telemetry)
        feedback.report()

    finish_session(report, result.exit_code)


def _attitude_problem(gain: float | None, virtual: VirtualMode | None,
                      imu: str | None = None) -> str | None:
    """--attitude-gain / --imu's one-line refusal (None: fine)."""
    if imu is not None and virtual is VirtualMode.sim:
        return ("--imu: --virtual sim reads the twin's body as its IMU; drop --imu, or play on "
                "the in-process virtual bus (--virtual) or real servos with it")
    if gain is None:
        return None
    from robots.attitude import AttitudeError, check_gain

    try:
        check_gain("--attitude-gain", gain)
    except AttitudeError as exc:
        return str(exc)
    if gain > 0 and virtual is not VirtualMode.sim and imu is None:
        return ("--attitude-gain: no IMU to read here; pass --imu PORT (a WitMotion serial "
                "IMU), or use --virtual sim (the MuJoCo twin's body)")
    return None


def _open_imu(path: str, baud: int, mount: str, clock: Clock) -> Any:
    """The WitMotion IMU on `path`, heard streaming before any servo moves (else a one-line
    failure naming --imu and the port)."""
    from hardware.errors import ImuError
    from hardware.imu.witmotion import open_witmotion, parse_mount
    from hardware.play.attitude import DEFAULT_MAX_AGE_S

    try:
        parsed = parse_mount(mount)
    except ImuError as exc:
        raise _fail(f"--imu-mount: {exc}") from None
    try:
        # two fresh readings per max age: a reading stamped up to a tick late stays fresh
        return open_witmotion(path, baud, clock.now_s, parsed,
                              min_rate_hz=2.0 / DEFAULT_MAX_AGE_S)
    except ImuError as exc:
        raise _fail(f"--imu {path}: {exc}") from None


def attitude_corrector(gain: float | None, robot: Any, gaits: Sequence[Any], twin: Any,
                       imu: Any, clock: Clock) -> Any:
    """The IMU feedback for `Player` / `Driver` (None: open loop): the source is `imu` (a real
    IMU, `hardware.imu`) or else the twin's body; the gain is `gain`, or — when there is a
    source — the gain the gaits were validated with: `run`'s one gait's, `drive`'s largest over
    its library (a library built closed loop holds its walks at the rule's gain; pre-flight
    warns about every gait validated at another). One gait (`run`): the corrector follows it;
    several (`drive`): the reference comes from the blend each tick."""
    if imu is not None:
        source, what = imu, f"the IMU on {imu.name}"
    elif twin is not None and hasattr(twin, "roll_pitch_rad"):
        from hardware.play.attitude import SyntheticAttitude

        source = SyntheticAttitude(lambda _t: twin.roll_pitch_rad(), clock.now_s)
        what = "the twin's body orientation"
    else:
        return None
    from hardware.play.attitude import AttitudeCorrector
    from robots.attitude import AttitudeLaw, validated_attitude_gain
    from robots.attitude_maps import attitude_map

    validated = sorted({validated_attitude_gain(g.validation) for g in gaits})
    g = validated[-1] if gain is None else gain
    if not g:
        if imu is not None:
            console.print(f"attitude feedback: off (gain 0: validated open loop; "
                          f"--attitude-gain G uses {what})", highlight=False)
        return None
    why = ""
    if gain is None and len(validated) > 1:
        why = f" (the largest of the gains the library was validated with: " \
              f"{', '.join(f'{v:g}' for v in validated)})"
    console.print(f"attitude feedback: gain {g:g} from {what}{why}", highlight=False)
    return AttitudeCorrector(AttitudeLaw(g), attitude_map(robot),
                             gaits[0] if len(gaits) == 1 else None, source)


@dataclass
class Session:
    """What `play_session` opened: the bus (None for a dry run), the twin, the telemetry."""

    bus: ServoBus | None
    twin: Any
    writer: TelemetryWriter | None


@contextmanager
def play_session(
    robot: Any,
    port: str | None,
    virtual: VirtualMode | None,
    bus_config: BusConfig,
    clock: Clock,
    faults: FaultSchedule | None,
    telemetry: Path | None,
    extra_columns: tuple[str, ...] = (),
    open_bus: bool = True,
) -> Iterator[Session]:
    """The bus (faults attached), the telemetry writer, closed on every path; a HardwareError
    or OSError inside becomes a one-line failure (`run` and `drive` share this)."""
    session = Session(None, None, None)
    try:
        if open_bus:
            session.bus, session.twin = _open_bus(robot, port, virtual, bus_config, clock, faults)
            if faults is not None:
                faults.attach_port(session.bus)
        if telemetry is not None:
            from hardware.play.telemetry import TelemetryWriter

            session.writer = TelemetryWriter(
                telemetry, robot.joint_names, [j.bus_id for j in robot.joints], extra_columns
            )
        if faults is not None:
            console.print(f"[bold]virtual bus faults[/]: {faults.describe()}", highlight=False)
        yield session
    except HardwareError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"{exc.filename or ''}: {exc.strerror or exc}") from None
    finally:
        if session.writer is not None:
            session.writer.close()
        if session.bus is not None:
            try:
                session.bus.close()
            except (HardwareError, OSError):
                pass  # an adapter that vanished cannot be closed either


def finish_session(report: Callable[[], None], exit_code: int) -> None:
    """Print the report (a vanished terminal does not change the outcome), exit with the code."""
    try:
        report()
    except OSError:
        pass  # the terminal is gone (SIGHUP): the exit code still says how the run ended
    if exit_code:
        raise typer.Exit(exit_code)


def _warn_beyond_bus_budget(robot: Any, port: str, baud: int, rate_hz: float) -> None:
    """Warn (not refuse) when --rate is beyond what the bus sustains (`hardware.bus.budget`,
    with the adapter's latency timer read from sysfs). Not a refusal: a late tick is safe —
    the player skips passed deadlines instead of bursting, and the step limit is per tick, so
    the robot moves slower than asked, never faster; the end of the run says what it held."""
    from hardware.bus.budget import for_robot, rate_check
    from hardware.bus.sdk_bus import usb_latency_timer_s

    try:
        budget = for_robot(robot, baud=baud, latency_ms=usb_latency_timer_s(port) * 1000.0)
    except ValueError:
        return  # a setting out of range is refused where it is used, with its own message
    warning = rate_check(budget, rate_hz)
    if warning is not None:
        err_console.print(f"[bold yellow]{escape(warning)}[/]", highlight=False, soft_wrap=True)


def budget(
    robot: str = typer.Option(..., "--robot", help="Robot name or folder."),
    baud: int | None = baud_option(),
    return_delay_us: float | None = typer.Option(
        None, "--return-delay-us", help="Servos' Return Delay Time [µs]; default: factory."
    ),
    latency_ms: float | None = typer.Option(
        None,
        "--latency-ms",
        help="USB adapter latency timer [ms]; default: read from sysfs for --port, else 16 "
        "(FTDI factory).",
    ),
    port: str | None = typer.Option(None, "--port", "-p", help="Read its latency timer."),
    rate_hz: float | None = typer.Option(None, "--rate", help="Also check this rate [Hz]."),
) -> None:
    """The loop rate the robot's bus sustains: bytes per tick, wire time, return delays, USB
    latency; which term dominates and what to change."""
    import robots
    from hardware.bus.budget import FTDI_DEFAULT_LATENCY_MS, for_robot, rate_check
    from hardware.bus.sdk_bus import usb_latency_timer_s

    for name, value in (("--baud", baud), ("--rate", rate_hz)):
        problem = None if value is None else check_option(name, value)
        if problem is not None:
            raise _fail(problem)
    try:
        rob = robots.load(robot)
        _require_drivable_servos(rob)
    except (robots.RobotsError, HardwareError) as exc:
        raise _fail(str(exc)) from None
    if latency_ms is None:
        latency_ms = FTDI_DEFAULT_LATENCY_MS
        if port is not None:
            latency_ms = usb_latency_timer_s(port) * 1000.0
    try:
        result = for_robot(rob, baud=baud, return_delay_us=return_delay_us, latency_ms=latency_ms)
    except ValueError as exc:
        raise _fail(str(exc)) from None
    text = escape(f"robot {rob.name}: " + result.report())
    console.print(text, highlight=False, soft_wrap=True)
    if rate_hz is not None:
        warning = rate_check(result, rate_hz)
        console.print(warning or f"--rate {rate_hz:g}: within the bus budget", highlight=False)


def _report(result: PlayResult, twin: Any, rate_hz: float, telemetry: Path | None) -> None:
    if result.supply_margin is not None:
        console.print(result.supply_margin, highlight=False)
    for w in result.warnings:
        err_console.print(f"[bold yellow]{w}[/]", highlight=False)
    _summary(result, twin, rate_hz)
    if telemetry is not None and result.telemetry_cut is not None:
        err_console.print(
            f"[bold yellow]telemetry CUT SHORT: {escape(str(telemetry))}: "
            f"{escape(result.telemetry_cut)}; the run itself went on and stopped as it would "
            "have[/]",
            highlight=False,
            soft_wrap=True,
        )
    elif telemetry is not None:
        console.print(f"telemetry: {telemetry}", highlight=False)


def _fault_schedule(texts: list[str], servo_ids: list[int]) -> FaultSchedule | None:
    """The `--fault` options as a schedule (None without any), or a one-line failure."""
    if not texts:
        return None
    from hardware.play.fault_spec import FaultSchedule, FaultSpecError, parse_fault

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
    from hardware.play.calibrate_flow import record_zero_offsets
    from hardware.play.calibration import default_path

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
    from hardware.play.telemetry import plot_telemetry, read_telemetry

    try:
        tel = read_telemetry(telemetry)
        out = plot_telemetry(tel, output, title=telemetry.name)
    except (OSError, ValueError) as exc:
        raise _fail(str(exc)) from None
    console.print(f"plot: {out} ({len(tel.tick)} ticks, stop: {tel.stop_reason})", highlight=False)


def report(
    telemetry: Path = typer.Argument(..., help="Telemetry CSV from `run --telemetry`."),
    gait: Path = typer.Argument(..., help="The gait file that was played (with its validation)."),
    output: Path = typer.Option(Path("run.html"), "--output", "-o", help="HTML page to write."),
    robot: str | None = typer.Option(
        None, "--robot", help="Robot name or folder: load in N·m against the servo envelope."
    ),
    speed_scale: float = typer.Option(
        1.0, "--speed-scale", help="The --speed-scale the run was played at."
    ),
    departure_factor: float = typer.Option(
        3.0, "--departure-factor", help="Departure: this many × a joint's median plan error."
    ),
    departure_rad: float = typer.Option(
        0.1, "--departure-rad", help="Departure: absolute plan error cap [rad]."
    ),
) -> None:
    """Planned vs measured after a run: tracking, load, temperature, loop timing, and where
    the run departed from the plan (self-contained HTML)."""
    from hardware.play.run_report import DepartureRule, write_report
    from robots.errors import OutputWriteError

    problem = check_option("--speed-scale", speed_scale)
    if problem is not None:
        raise _fail(problem)
    for name, value in (("--departure-factor", departure_factor),
                        ("--departure-rad", departure_rad)):
        if not (math.isfinite(value) and value > 0):
            raise _fail(f"{name} {value:g}: must be a finite positive number")
    try:
        rule = DepartureRule(
            factor=departure_factor, abs_rad=departure_rad,
            floor_rad=min(DepartureRule.floor_rad, departure_rad),
        )
        rep = write_report(telemetry, gait, output, robot_name=robot, speed_scale=speed_scale,
                           rule=rule)
    except (HardwareError, OutputWriteError) as exc:
        raise _fail(str(exc)) from None
    for w in rep.warnings:
        err_console.print(f"[bold yellow]WARNING: {escape(w)}[/]", highlight=False)
    console.print(rep.departure_line(), highlight=False, soft_wrap=True)
    console.print(f"report: {output}", highlight=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add `run`, `drive`, `calibrate`, `plot`, `report` and `budget` to the `gaitsmith-play`
    app."""
    from hardware.play.drive_command import drive

    app.command("run", cls=_RunCommand)(run)
    app.command("drive", cls=_RunCommand)(drive)
    app.command("calibrate")(calibrate)
    app.command("plot")(plot)
    app.command("report")(report)
    app.command("budget")(budget)

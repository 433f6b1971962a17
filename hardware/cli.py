"""`gaitsmith-play`: servo-side commands (scan a bus, serve a virtual bus; the player adds more).

Run as `gaitsmith-play run` or `drive` (or `python -m hardware.cli run`), this module first
latches the stop signals (SIGINT, SIGTERM, SIGHUP, SIGQUIT;
`hardware.play.watchdog.latch_stop_signals`) before it loads the rest, so a signal that arrives
while the command starts up becomes the player's stop request instead of killing it half-way;
see `hardware.play.commands` for what each signal does.
"""

from __future__ import annotations

import os
import signal
import sys
import time

from hardware.play.watchdog import STOP_SIGNALS, latch_stop_signals

_AS_COMMAND = __name__ == "__main__" or os.path.basename(sys.argv[0]) == "gaitsmith-play"
_LATCHED = _AS_COMMAND and sys.argv[1:2] in (["run"], ["drive"], ["identify"])
if _LATCHED:
    latch_stop_signals()  # before typer / rich / the player load (tenths of a second)
from enum import Enum  # noqa: E402 (after the latch)
from types import FrameType  # noqa: E402 (after the latch)

import typer  # noqa: E402 (after the latch)
from rich.console import Console  # noqa: E402 (after the latch)
from rich.markup import escape  # noqa: E402 (after the latch)
from rich.table import Table  # noqa: E402 (after the latch)

from hardware.bus.servo_bus import BusConfig, ServoBus  # noqa: E402 (after the latch)
from hardware.errors import HardwareError  # noqa: E402 (after the latch)
from robots.cli_usage import run_app  # noqa: E402 (after the latch)

app = typer.Typer(
    name="gaitsmith-play",
    help="Play gaits on Dynamixel / Feetech servos; scan buses; run a virtual servo bus.",
    no_args_is_help=True,
    add_completion=False,
    # help texts are plain: units like [ms] or [s] are not rich markup tags to be eaten
    rich_markup_mode=None,
)
console = Console()
err_console = Console(stderr=True)


class ProtocolName(str, Enum):
    dynamixel = "dynamixel"
    dynamixel1 = "dynamixel1"
    feetech = "feetech"


_CATALOGUE_PROTOCOL = {
    ProtocolName.dynamixel: "dynamixel2",
    ProtocolName.dynamixel1: "dynamixel1",
    ProtocolName.feetech: "feetech_sts",
}
_DEFAULT_MODEL = {
    ProtocolName.dynamixel: "XL430_W250",
    ProtocolName.dynamixel1: "AX_12A",
    ProtocolName.feetech: "STS3215_7V4",
}


def _fail(message: str, code: int = 1) -> typer.Exit:
    err_console.print(f"[bold red]error:[/] {message}")
    return typer.Exit(code)


def _parse_ids(text: str) -> list[int]:
    """ "1-12,15" → [1..12, 15]."""
    ids: list[int] = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        lo, _, hi = part.partition("-")
        try:
            a, b = int(lo), int(hi or lo)
        except ValueError:
            raise typer.BadParameter(f"bad id range {part!r}") from None
        if not 0 <= a <= b <= 252:
            raise typer.BadParameter(f"ids must lie in 0..252: {part!r}")
        ids.extend(range(a, b + 1))
    if not ids:
        raise typer.BadParameter("no ids given")
    return sorted(set(ids))


def make_bus(protocol: ProtocolName, port: str, config: BusConfig) -> ServoBus:
    """A driver for `protocol` on device `port` (not yet opened)."""
    if protocol is ProtocolName.dynamixel:
        from hardware.bus.dynamixel import DynamixelBus

        return DynamixelBus(port, config)
    if protocol is ProtocolName.dynamixel1:
        from hardware.bus.dynamixel import Dynamixel1Bus

        return Dynamixel1Bus(port, config)
    from hardware.bus.feetech import FeetechBus

    return FeetechBus(port, config)


def model_names(protocol: str, model_number: int) -> str:
    """Catalogue model name(s) for a pinged model number ("?" when unknown)."""
    from robots.servo import load_catalogue

    names = [
        m.name
        for m in load_catalogue().values()
        if m.model_number == model_number and m.protocol == protocol
    ]
    return " / ".join(names) if names else "?"


@app.command()
def scan(
    port: str = typer.Option(..., "--port", "-p", help="Serial device, e.g. /dev/ttyUSB0."),
    protocol: ProtocolName = typer.Option(..., "--protocol", help="Wire protocol."),
    baud: int | None = typer.Option(None, "--baud", help="Baud rate [bit/s]; default: factory."),
    ids: str = typer.Option("0-252", "--ids", help="Ids to ping, e.g. 1-12,20."),
    timeout_ms: float = typer.Option(10.0, "--timeout-ms", help="Reply allowance per ping."),
) -> None:
    """List the servos that answer on a bus (id, model, firmware)."""
    id_list = _parse_ids(ids)
    bus = make_bus(protocol, port, BusConfig(timeout_s=timeout_ms / 1000.0, baudrate=baud))
    try:
        with bus:
            found = bus.scan(id_list)
    except HardwareError as exc:
        raise _fail(str(exc)) from None
    catalogue_protocol = _CATALOGUE_PROTOCOL[protocol]
    table = Table(title=f"{protocol.value} servos on {port}")
    table.add_column("id", justify="right")
    table.add_column("model number", justify="right")
    table.add_column("model")
    table.add_column("firmware")
    for info in found:
        table.add_row(
            str(info.servo_id),
            str(info.model_number),
            model_names(catalogue_protocol, info.model_number),
            info.firmware,
        )
    console.print(table)
    console.print(f"{len(found)} servo(s) found among {len(id_list)} id(s).")


@app.command("virtual-bus")
def virtual_bus(
    robot: str | None = typer.Option(None, "--robot", help="Robot whose servos to emulate."),
    protocol: ProtocolName | None = typer.Option(None, "--protocol", help="Without --robot."),
    ids: str = typer.Option("1-12", "--ids", help="Servo ids (without --robot), e.g. 1-12."),
    model: str | None = typer.Option(None, "--model", help="Catalogue servo model (no --robot)."),
    duration_s: float | None = typer.Option(None, "--duration", help="Stop after this [s]."),
    wire_baud: int | None = typer.Option(
        None, "--wire-baud", help="Emulate wire time at this baud [bit/s] (default: off)."
    ),
    latency_ms: float = typer.Option(
        0.0, "--latency-ms", help="With --wire-baud: emulated USB adapter latency [ms]."
    ),
) -> None:
    """Emulate a servo bus on a pseudo-terminal; prints its device path; runs until Ctrl-C."""
    from hardware.bus.virtual import PtyServer, VirtualServoBus, WireTiming

    try:
        if robot is not None:
            import robots

            vbus = VirtualServoBus.from_robot(robots.load(robot))
            label = robot
        else:
            if protocol is None:
                raise _fail("give --robot, or --protocol (with --ids / --model)")
            from robots.servo import servo_model

            sm = servo_model(model or _DEFAULT_MODEL[protocol])
            vbus = VirtualServoBus({i: sm for i in _parse_ids(ids)}, _CATALOGUE_PROTOCOL[protocol])
            label = f"{len(vbus.servos)} x {sm.name}"
        if wire_baud is not None:
            vbus.wire = WireTiming(wire_baud, latency_ms / 1000.0)
    except (HardwareError, ValueError) as exc:
        raise _fail(str(exc)) from None
    except Exception as exc:  # robots' own typed errors (unknown robot, bad config)
        if type(exc).__module__.startswith("robots"):
            raise _fail(str(exc)) from None
        raise

    stop = {"now": False}

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop["now"] = True

    signal.signal(signal.SIGTERM, on_signal)
    server = PtyServer(vbus)
    path = server.start()
    console.print(f"virtual {vbus.protocol} bus ({label}), ids {vbus.ids}")
    console.print(path, highlight=False, soft_wrap=True)
    sys.stdout.flush()
    deadline = None if duration_s is None else time.monotonic() + duration_s
    try:
        while not stop["now"] and (deadline is None or time.monotonic() < deadline):
            time.sleep(0.1)
            if server.error is not None:
                raise _fail(f"virtual bus stopped: {server.error}")
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    console.print(f"served {vbus.instructions} instruction packet(s); bye")


from hardware.play.commands import register as _register_player  # noqa: E402

_register_player(app)

from hardware.play.identify import register as _register_identify  # noqa: E402

_register_identify(app)


def _print_error(message: str) -> None:
    """One line on stderr (no wrapping, no rich markup taken from the message)."""
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)


def _print_interrupted() -> None:
    err_console.print("[yellow]interrupted[/]")


def main(argv: list[str] | None = None) -> int:
    """Run `gaitsmith-play` (`robots.cli_usage.run_app`): a usage mistake is one line on stderr
    and exit code 2, as with `gaitsmith`; the commands report their own hardware errors."""
    try:
        return run_app(app, argv, tuple, _print_error, _print_interrupted)
    finally:
        if _LATCHED:  # the run is over (torque off): a late signal must not turn the exit code
            _ignore_stop_signals()  # into "killed" as Python restores default handlers at exit


def _ignore_stop_signals() -> None:
    """Ignore the stop signals from now on, without a traceback on stderr.

    A stop signal that the C handler has recorded but Python has not yet run would otherwise
    meet SIG_IGN as its handler, and CPython prints "OSError: Signal N ignored due to race
    condition" with a traceback (seen in a SIGINT storm while the player stopped). So the
    signals are blocked first: the first `signal.signal` call still runs any recorded one with
    the old (latching) handler, none arrives while the handlers change, and those the kernel
    holds while blocked are discarded when SIG_IGN is their handler, at the unblock."""
    stops = set(STOP_SIGNALS)
    block = getattr(signal, "pthread_sigmask", None)
    if block is not None:
        block(signal.SIG_BLOCK, stops)
    try:
        for s in stops:
            signal.signal(s, signal.SIG_IGN)
    finally:
        if block is not None:
            block(signal.SIG_UNBLOCK, stops)


if __name__ == "__main__":
    sys.exit(main())

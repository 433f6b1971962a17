"""`gaitsmith-play identify`: a bounded excitation run for servo identification (issue #18 item 6).

With the robot LIFTED off the ground (hung or on a stand, legs free), the joints are excited
group by group around the stance pose and the player's telemetry CSV records, per tick, the goal
sent, the present position and (on status ticks) the load the servo reports, with timestamps.
`gaitsmith identify` fits each servo's position gain, latency and strength from that file.

Groups: joint k of every leg moves at once (the legs of a lifted robot are coupled only through
the fixed base), joints outside the legs one at a time; `--joints` limits the run to some.
Each group's segment of `segment_s` (`--duration-s`), per joint j with centre c_j (the stance,
moved inside the limits so that c_j ± A_j fits) and amplitude A_j (`--amplitude-deg`, smaller
where the joint's range is):

- 0 – 40 % steps c + A·(+1, −1, +½, −½, +1, 0), equal holds: large errors saturate the drive
  (strength), the small ones show the linear gain, every edge the latency;
- 40 – 70 % a linear chirp 0.3 → 3 Hz, amplitude min(0.6·A, the speed cap / 2πf);
- 70 – 100 % held back for the fit's check ("check" ticks): steps ±0.75·A, then a three-tone
  multisine — a different signal from the training part.

All targets go through the player's `SafetyGate` (joint limits, the per-tick speed limit
`speed_margin`·ω₀), so a step reaches the servo as the steepest ramp the gate allows; the
telemetry records what was sent. The excitation keeps the chirp's peak speed at half that limit.

Phases in the telemetry: ``ramp_in`` (present pose → centres), ``settle`` (0.5 s hold),
``excite<g>`` (training part of group g) and ``check<g>`` (held-back part), then the player's
``ramp_out`` to the stance and torque off. The stop contract is the player's (`IdentifyPlayer`
is a `Player`): signals, watchdog, ramp to rest, torque off, exit codes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.console import Console

from hardware.bus.servo_bus import BusConfig, ServoBus
from hardware.errors import HardwareError
from hardware.play.calibration import Calibration
from hardware.play.cli_options import (
    baud_option,
    calibration_option,
    port_option,
    ramp_option,
    rate_option,
    realtime_option,
    robot_option,
    timeout_option,
)
from hardware.play.clock import Clock, MonotonicClock, VirtualClock
from hardware.play.commands import VirtualMode
from hardware.play.errors import PlayerError
from hardware.play.player import ADAPTER_ERRORS, Player, PlayerConfig, _os_text
from hardware.play.preflight import check_bus
from hardware.play.telemetry import TelemetryWriter
from hardware.play.watchdog import StopReason
from robots.gait import Gait, Velocity
from robots.ramp import ramp_to
from robots.robot import Robot
from robots.schedule import ContactSchedule

DEFAULT_AMPLITUDE_DEG = 15.0
DEFAULT_SEGMENT_S = 8.0
LIMIT_MARGIN_RAD = math.radians(3.0)  # the excitation keeps this far inside the joint limits
MIN_AMPLITUDE_RAD = math.radians(1.0)
SETTLE_S = 0.5
GAP_S = 0.3  # hold at the centres between groups
TRAIN_FRACTION = 0.7
STEP_LEVELS = (1.0, -1.0, 0.5, -0.5, 1.0, 0.0)
CHIRP_HZ = (0.3, 3.0)
MULTISINE_HZ = (0.7, 1.3, 2.3)
CHIRP_SPEED_FRACTION = 0.5  # of the gate's allowed speed
TRAIN_PHASE = "excite"
CHECK_PHASE = "check"
console = Console()


def joint_groups(
    robot: Robot, joints: tuple[str, ...] | None = None
) -> tuple[tuple[int, ...], ...]:
    """Joint indices moved together: k-th joint of every leg, then every other joint alone."""
    names = robot.joint_names
    wanted = set(names if joints is None else joints)
    unknown = sorted(wanted - set(names))
    if unknown:
        raise PlayerError(
            f"--joints: robot {robot.name} has no joint {unknown[0]!r}; joints: {', '.join(names)}"
        )
    index = {n: i for i, n in enumerate(names)}
    groups: list[tuple[int, ...]] = []
    in_legs: set[str] = set()
    depth = max((len(leg.joints) for leg in robot.legs), default=0)
    for k in range(depth):
        group = []
        for leg in robot.legs:
            if k < len(leg.joints):
                in_legs.add(leg.joints[k])
                if leg.joints[k] in wanted:
                    group.append(index[leg.joints[k]])
        if group:
            groups.append(tuple(group))
    groups += [(index[n],) for n in names if n in wanted and n not in in_legs]
    return tuple(groups)


@dataclass(frozen=True, eq=False)
class Excitation:
    """The excitation targets over time (see the module docstring); t = 0 at the first group."""

    joint_names: tuple[str, ...]
    groups: tuple[tuple[int, ...], ...]
    centre_rad: np.ndarray  # (J,)
    amplitude_rad: np.ndarray  # (J,)
    speed_cap_rad_s: np.ndarray  # (J,) the gate's allowed speed
    segment_s: float

    @property
    def group_span_s(self) -> float:
        return self.segment_s + GAP_S

    @property
    def duration_s(self) -> float:
        return len(self.groups) * self.group_span_s

    def phase(self, t_s: float) -> str:
        """Telemetry phase at `t_s`: excite<g>, check<g>, or settle (between groups)."""
        g, u = divmod(t_s, self.group_span_s)
        if not 0.0 <= t_s < self.duration_s or u >= self.segment_s:
            return "settle"
        return f"{TRAIN_PHASE if u < TRAIN_FRACTION * self.segment_s else CHECK_PHASE}{int(g)}"

    def targets(self, t_s: float) -> np.ndarray:
        """(J,) joint targets [rad] at time `t_s` (the centres outside the groups' segments)."""
        out = self.centre_rad.copy()
        if not 0.0 <= t_s < self.duration_s:
            return out
        g, u = divmod(t_s, self.group_span_s)
        if u >= self.segment_s:
            return out
        for j in self.groups[int(g)]:
            out[j] += self._offset(u / self.segment_s, j)
        return out

    def _offset(self, x: float, j: int) -> float:
        """Excursion of joint j at fraction x ∈ [0, 1) of its segment."""
        a, seg = float(self.amplitude_rad[j]), self.segment_s
        cap = CHIRP_SPEED_FRACTION * float(self.speed_cap_rad_s[j])
        if x < 0.4:  # steps
            return a * STEP_LEVELS[min(int(x / 0.4 * len(STEP_LEVELS)), len(STEP_LEVELS) - 1)]
        if x < TRAIN_FRACTION:  # chirp: f(t) = f0 + (f1 − f0)·t/T, phase = 2π∫f
            f0, f1 = CHIRP_HZ
            span = (TRAIN_FRACTION - 0.4) * seg
            t = (x - 0.4) * seg
            f = f0 + (f1 - f0) * t / span
            amp = min(0.6 * a, cap / (2 * math.pi * f))
            return amp * math.sin(2 * math.pi * (f0 * t + 0.5 * (f1 - f0) * t * t / span))
        y = (x - TRAIN_FRACTION) / (1 - TRAIN_FRACTION)  # held back
        if y < 0.5:
            return 0.75 * a * (1.0 if y < 0.25 else -1.0)
        t = (y - 0.5) * (1 - TRAIN_FRACTION) * seg
        amp = min(0.3 * a, cap / (2 * math.pi * sum(MULTISINE_HZ)))
        return sum(amp * math.sin(2 * math.pi * f * t) for f in MULTISINE_HZ)


def excitation_for(
    robot: Robot,
    speed_cap_rad_s: np.ndarray,
    *,
    amplitude_rad: float = math.radians(DEFAULT_AMPLITUDE_DEG),
    segment_s: float = DEFAULT_SEGMENT_S,
    joints: tuple[str, ...] | None = None,
) -> Excitation:
    """The excitation of `robot`'s joints (all, or `joints`) within their limits."""
    if not (math.isfinite(amplitude_rad) and MIN_AMPLITUDE_RAD <= amplitude_rad <= math.pi / 2):
        raise PlayerError(
            f"--amplitude-deg {math.degrees(amplitude_rad):g}: must lie in "
            f"[{math.degrees(MIN_AMPLITUDE_RAD):g}, 90] degrees"
        )
    if not (math.isfinite(segment_s) and 2.0 <= segment_s <= 120.0):
        raise PlayerError(f"--duration-s {segment_s:g}: must lie in [2, 120] s per joint group")
    groups = joint_groups(robot, joints)
    stance = np.asarray(robot.nominal_stance_rad, float)
    lo = np.array([j.lower_rad for j in robot.joints]) + LIMIT_MARGIN_RAD
    hi = np.array([j.upper_rad for j in robot.joints]) - LIMIT_MARGIN_RAD
    amp = np.minimum(amplitude_rad, np.maximum((hi - lo) / 2, 0.0))
    for g in groups:
        for j in g:
            if amp[j] < MIN_AMPLITUDE_RAD:
                raise PlayerError(
                    f"joint {robot.joints[j].name}: its range leaves less than "
                    f"{math.degrees(MIN_AMPLITUDE_RAD):g}° to excite inside the limits; leave it "
                    "out (--joints)"
                )
    centre = np.clip(stance, lo + amp, hi - amp)
    return Excitation(
        joint_names=robot.joint_names,
        groups=groups,
        centre_rad=centre,
        amplitude_rad=amp,
        speed_cap_rad_s=np.asarray(speed_cap_rad_s, float),
        segment_s=float(segment_s),
    )


def hold_gait(robot: Robot) -> Gait:
    """A gait that holds the stance (what the player's pre-flight and thermal watch are given:
    the excitation itself is not a gait)."""
    stance = np.asarray(robot.nominal_stance_rad, float)
    legs = len(robot.legs)
    schedule = ContactSchedule(1.0, robot.foot_names, (0.0,) * legs, (1.0,) * legs)
    return Gait.create(
        robot=robot,
        knots_rad=np.tile(stance, (4, 1)),
        schedule=schedule,
        velocity=Velocity(),
        gait_label="identify",
    )


class IdentifyPlayer(Player):
    """The player, streaming an `Excitation` instead of a gait (same gate, watchdog, stop)."""

    def __init__(
        self,
        robot: Robot,
        *,
        bus: ServoBus | None,
        amplitude_rad: float = math.radians(DEFAULT_AMPLITUDE_DEG),
        segment_s: float = DEFAULT_SEGMENT_S,
        joints: tuple[str, ...] | None = None,
        calibration: Calibration | None = None,
        config: PlayerConfig | None = None,
        clock: Clock | None = None,
        telemetry: TelemetryWriter | None = None,
    ) -> None:
        super().__init__(
            robot, hold_gait(robot), bus=bus, calibration=calibration, config=config,
            clock=clock, telemetry=telemetry,
        )  # fmt: skip
        self.excitation = excitation_for(
            robot,
            self.gate.enforced_speed_rad_s,
            amplitude_rad=amplitude_rad,
            segment_s=segment_s,
            joints=joints,
        )

    def _preflight(self) -> tuple[list[str], np.ndarray | dict[int, int]]:
        """The bus checks of a run (ping, model, health, pose within limits); the gait checks
        do not apply: the excitation stays inside the limits and the gate's speed by design."""
        cfg = self.config
        if self.bus is None:
            return [], self.calibration.rad_to_ticks(self.robot.nominal_stance_rad)
        try:
            present = check_bus(
                self.robot, self.calibration, self.bus, cfg.limits, cfg.pose_tolerance_rad
            )
        except ADAPTER_ERRORS as exc:
            raise PlayerError(f"pre-flight: serial adapter failed: {_os_text(exc)}") from None
        return [], present

    def _play(self) -> None:
        cfg, ex = self.config, self.excitation
        ramp = ramp_to(
            self.gate.last_rad, ex.centre_rad,
            self.allowed_speed_rad_s * cfg.ramp_speed_fraction, cfg.ramp_s,
        )  # fmt: skip
        n_ramp = math.ceil(ramp.duration_s * cfg.rate_hz - 1e-9)
        n_settle = round(SETTLE_S * cfg.rate_hz)
        n_excite = round(ex.duration_s * cfg.rate_hz)
        k = 0
        while self.watchdog.stop is None:
            if k < n_ramp:
                phase, target = "ramp_in", ramp.positions((k + 1) * self.period_s)
            elif k < n_ramp + n_settle:
                phase, target = "settle", ex.centre_rad
            elif k < n_ramp + n_settle + n_excite:
                t = (k - n_ramp - n_settle) * self.period_s
                phase, target = ex.phase(t), ex.targets(t)
            else:
                self.watchdog.request(
                    StopReason.COMPLETED,
                    f"excited {len(ex.groups)} joint group(s) for {ex.segment_s:g} s each",
                    self.ticks,
                    self._now_rel(),
                )
                break
            k = self._tick(k, phase, target, watch=True)


# -- the command ------------------------------------------------------------------------------
def identify_command(
    robot: str = robot_option(),
    output: Path = typer.Option(..., "--output", "-o", help="Telemetry CSV to record."),
    port: str | None = port_option(),
    virtual: VirtualMode | None = typer.Option(
        None,
        "--virtual",
        help="No hardware: alone = in-process virtual bus; 'sim' = the MuJoCo twin, lifted.",
    ),
    joints: str | None = typer.Option(
        None, "--joints", help="Comma-separated joint names to excite (default: all)."
    ),
    amplitude_deg: float = typer.Option(
        DEFAULT_AMPLITUDE_DEG, "--amplitude-deg", help="Step amplitude about stance [deg]."
    ),
    duration_s: float = typer.Option(
        DEFAULT_SEGMENT_S, "--duration-s", help="Excitation per joint group [s] (2..120)."
    ),
    yes: bool = typer.Option(False, "--yes", "-y", help="The robot is lifted: do not ask."),
    calibration: Path | None = calibration_option(),
    rate_hz: float = rate_option("Stream rate [Hz], 1..1000."),
    ramp_s: float = ramp_option(),
    timeout_ms: float = timeout_option(),
    baud: int | None = baud_option(),
    realtime: bool = realtime_option(),
    twin_servo_params: Path | None = typer.Option(
        None,
        "--twin-servo-params",
        help="--virtual sim only: the twin's servos differ from the "
        "catalogue as this servo_params.toml says (a run with known parameters to fit against).",
    ),
) -> None:
    """Excite the joints of a LIFTED robot (steps, chirp, multisine about stance) and record
    goal / present / load per tick for `gaitsmith identify`. Same safety as `run`: limits,
    speed limit, watchdog; Ctrl-C / SIGTERM / SIGHUP / SIGQUIT ramp to stance, then torque off."""
    from hardware.play.commands import (
        _fail,
        _load_inputs,
        _open_bus,
        _report,
        _virtual_plant,
        check_option,
    )

    for name, value in (
        ("--rate", rate_hz), ("--ramp-s", ramp_s), ("--timeout-ms", timeout_ms), ("--baud", baud),
    ):  # fmt: skip
        problem = None if value is None else check_option(name, value)
        if problem is not None:
            raise _fail(problem)
    if port is None and virtual is None:
        raise _fail("give --port DEVICE (the lifted robot's bus) or --virtual [bus|sim]")
    if twin_servo_params is not None and virtual is not VirtualMode.sim:
        raise _fail("--twin-servo-params sets the MuJoCo twin's servos: use it with --virtual sim")
    rob, _, cal = _load_inputs(robot, None, calibration)
    settings = None
    if twin_servo_params is not None:
        from robots import servo_params
        from robots.errors import RobotsError

        try:
            settings = servo_params.load(twin_servo_params)
            settings.for_robot(rob)
        except RobotsError as exc:
            raise _fail(str(exc)) from None
    names = None if joints is None else tuple(n.strip() for n in joints.split(",") if n.strip())
    try:
        config = PlayerConfig(rate_hz=rate_hz, ramp_s=ramp_s)
        bus_config = BusConfig(
            timeout_s=timeout_ms / 1000.0, retries=1, baudrate=baud or rob.bus_baud
        )
        excitation = excitation_for(
            rob,
            np.array([config.speed_margin * j.servo.no_load_speed_rad_s for j in rob.joints]),
            amplitude_rad=math.radians(amplitude_deg),
            segment_s=duration_s,
            joints=names,
        )
    except (ValueError, PlayerError) as exc:
        raise _fail(str(exc)) from None
    console.print(
        f"[bold]The robot must be LIFTED off the ground[/] (hung or on a stand, legs free): "
        f"{len(excitation.groups)} joint group(s) will each move up to "
        f"±{math.degrees(float(np.max(excitation.amplitude_rad))):.0f}° about stance for "
        f"{duration_s:g} s, {excitation.duration_s + 2 * ramp_s:.0f} s in all; keep clear.",
        highlight=False,
    )
    if not yes:
        try:
            if not typer.confirm("Is the robot lifted and clear?", default=False):
                raise _fail("not confirmed: nothing was sent to the servos")
        except typer.Abort:
            raise _fail("not confirmed (no answer): pass --yes once the robot is lifted") from None
    clock: Clock = MonotonicClock() if realtime or virtual is None else VirtualClock()
    bus: ServoBus | None = None
    twin: Any = None
    writer = None
    try:
        if virtual is VirtualMode.sim:
            twin = _virtual_plant("sim")(
                rob, clock=clock.now_s, lifted=True, servo_settings=settings
            )
            bus = twin.vbus.connect(bus_config)
        else:
            bus, twin = _open_bus(rob, port, virtual, bus_config, clock)
        writer = TelemetryWriter(output, rob.joint_names, [j.bus_id for j in rob.joints])
        player = IdentifyPlayer(
            rob, bus=bus, calibration=cal, config=config, clock=clock, telemetry=writer,
            amplitude_rad=math.radians(amplitude_deg), segment_s=duration_s, joints=names,
        )  # fmt: skip
        result = player.run()
    except HardwareError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"{exc.filename or ''}: {exc.strerror or exc}") from None
    finally:
        if writer is not None:
            writer.close()
        if bus is not None:
            try:
                bus.close()
            except (HardwareError, OSError):
                pass  # an adapter that vanished cannot be closed either
    try:
        _report(result, twin, rate_hz, output)
        if result.exit_code == 0:
            console.print(
                f"fit it: gaitsmith identify {output} --robot {robot} -o servo_params.toml",
                highlight=False,
                soft_wrap=True,
            )
    except OSError:
        pass  # the terminal is gone (SIGHUP): the exit code still says how the run ended
    if result.exit_code:
        raise typer.Exit(result.exit_code)


def register(app: typer.Typer) -> None:
    """Add `identify` to the `gaitsmith-play` app."""
    from hardware.play.commands import _RunCommand

    app.command("identify", cls=_RunCommand)(identify_command)

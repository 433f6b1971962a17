"""`Driver`: drive the robot live from velocity commands, through a gait library's blender.

    Driver(robot, stand, gaits, make_blender, source, bus=bus, config=..., drive=...).run()
    drive_from_library(robot, library, source, bus=bus, ...)   # the usual way in

The drive is a `Player` (`hardware.play.player`) with another streaming phase; everything
else is the player's, unchanged: the pre-flight (on every gait of the library: fingerprint,
joint speeds against the gate's enforced speed, sim verdict, supply margin; on the bus: ping,
model, health, present pose), the signal handlers from before pre-flight until after the
torque-off, the ramp-in, the one `SafetyGate` every goal passes through (limits, per-tick step
budget), the watchdog, the ramp to rest and torque off, the exit codes.

Timeline: pre-flight → torque on → ramp-in to the stand pose (the mean pose of the library's
all-feet-down gait; the ramp of the player's `gait_entry`) → drive: each tick polls the command
source (`hardware.play.command_sources`, never blocking), keeps the newest command in a
`CommandHold` (no command for `deadman_s`, or the input ended → (0, 0, 0)), and asks the
blender (`robots.blend.GaitBlender`) for the next joint targets at that command: it limits the
command's acceleration, clips it into the library's grid, enters walking from the stand and
decelerates back to it, at a continuous phase and within the joint speeds it is given
(`blend_speed_fraction` of the gate's). Ticks are "stand" while the blender stands, "drive"
otherwise. The drive ends — COMPLETED, then the usual ramp to rest and torque off — once the
input has ended (EOF, `{"end": true}`, the keyboard's X, a lost gamepad) or `max_drive_s` has
passed, and the blender has come to rest in the stand; any stop reason of `run` (signal,
watchdog, bus) ends it at once, through the same safe stop as `run`.

Attitude feedback (`attitude`, an `hardware.play.attitude.AttitudeCorrector`; `--imu PORT` or
the twin's body, as `run`): each drive tick the offsets of `robots.attitude.blended_offsets`
are added to the blender's targets before the SafetyGate, exactly where `run` adds them. The
blender plays q = Σ wₑ Sₑ(φ) at one phase φ; the reference roll/pitch and the stance-support
weights are blended with the same wₑ at the same φ, and faded by the blender's entry/exit weight
α (`GaitBlender.blend_weight`). Standing and the stand ↔ walk ramps (α = 0) get no correction:
`run` and the simulator's closed-loop validation apply none there either (their α is 0 before
the gait's blend-in and after its blend-out), so no verdict covers one; the ramps are not a
plan with a reference attitude. A stale or vanished IMU fades the correction to zero (the
corrector's), and the pre-flight refuses a library holding a gait validated closed loop when
the drive has no feedback, unless `force` — `run`'s rule, applied to every gait of the library.

Telemetry (one row per tick, as `run`) adds the commands beside the targets: requested (what the
hold gave the blender: the source's command, or 0 after the deadman), applied (the blender's
command after acceleration limits and clipping into the grid), the gait phase, and the running
count of malformed input lines.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from hardware.bus.servo_bus import ServoBus
from hardware.play.attitude import AttitudeCorrector
from hardware.play.calibration import Calibration
from hardware.play.clock import Clock
from hardware.play.command_sources import STOP, CommandHold, CommandSource
from hardware.play.errors import PreflightError, SpeedScaleError
from hardware.play.player import Player, PlayerConfig, PlayResult, TickHook
from hardware.play.preflight import _peak_torques_nm, check_offline, check_supply
from hardware.play.telemetry import TelemetryWriter
from hardware.play.thermal_watch import PredictedHeating, predicted_heating
from hardware.play.watchdog import StopReason
from robots.gait import Gait, Velocity
from robots.ramp import gait_mean_pose
from robots.robot import Robot
from robots.voltage import voltage_margin

if TYPE_CHECKING:
    from robots.library import GaitLibrary

TELEMETRY_COLUMNS = (
    "requested_vx_m_s", "requested_vy_m_s", "requested_yaw_rate_rad_s",
    "applied_vx_m_s", "applied_vy_m_s", "applied_yaw_rate_rad_s",
    "gait_phase", "malformed_lines",
)  # fmt: skip
MAX_ACCEL_M_S2 = 20.0
MAX_YAW_ACCEL_RAD_S2 = 50.0
MAX_DEADMAN_S = 60.0


class Blender(Protocol):
    """What the drive needs of `robots.blend.GaitBlender`."""

    def step(self, command: Velocity, dt_s: float) -> np.ndarray: ...

    @property
    def command(self) -> Velocity: ...

    @property
    def phase(self) -> float: ...

    @property
    def standing(self) -> bool: ...

    @property
    def blend_weight(self) -> float: ...

    @property
    def entry_weights(self) -> tuple[np.ndarray, np.ndarray]: ...


# (start pose [rad], joint speed limit [rad/s], DriveConfig) → a blender standing there
BlenderFactory = Callable[[np.ndarray, np.ndarray, "DriveConfig"], Blender]


@dataclass(frozen=True)
class DriveConfig:
    """Options of the drive phase (the rest is the `PlayerConfig`)."""

    deadman_s: float = 0.5  # no command for this long → decelerate to the stand
    accel_m_s2: float = 0.5  # |d vx/dt|, |d vy/dt| of the applied command
    yaw_accel_rad_s2: float = 1.5  # |d yaw rate/dt|
    blend_speed_fraction: float = 0.95  # of the gate's enforced joint speed, given the blender
    max_drive_s: float | None = None  # end (standing) after this long; None: when input ends

    def __post_init__(self) -> None:
        if not (math.isfinite(self.deadman_s) and 0 < self.deadman_s <= MAX_DEADMAN_S):
            raise ValueError(f"deadman_s must lie in (0, {MAX_DEADMAN_S:g}] s")
        if not (math.isfinite(self.accel_m_s2) and 0 < self.accel_m_s2 <= MAX_ACCEL_M_S2):
            raise ValueError(f"accel_m_s2 must lie in (0, {MAX_ACCEL_M_S2:g}] m/s²")
        if not (
            math.isfinite(self.yaw_accel_rad_s2)
            and 0 < self.yaw_accel_rad_s2 <= MAX_YAW_ACCEL_RAD_S2
        ):
            raise ValueError(f"yaw_accel_rad_s2 must lie in (0, {MAX_YAW_ACCEL_RAD_S2:g}] rad/s²")
        if not 0 < self.blend_speed_fraction <= 1.0:
            raise ValueError("blend_speed_fraction must lie in (0, 1]")
        if self.max_drive_s is not None and not (
            math.isfinite(self.max_drive_s) and self.max_drive_s > 0
        ):
            raise ValueError("max_drive_s must be a finite positive number (None: no limit)")


@dataclass(frozen=True)
class DriveResult:
    """How a drive went: the player's result plus what the command source delivered."""

    play: PlayResult
    source: str
    commands: int  # commands accepted from the source
    malformed: int  # input lines (or keys) refused
    last_problem: str | None  # why the last one was refused
    deadman_trips: int  # moving commands cut by the deadman
    drive_s: float  # time spent in the drive phase [s]
    walking_s: float  # of which not standing [s]
    notes: tuple[str, ...]  # the source's own remarks (a lost gamepad, a refused client)

    @property
    def exit_code(self) -> int:
        return self.play.exit_code

    def summary(self) -> str:
        text = (
            f"drive: {self.drive_s:.1f} s ({self.walking_s:.1f} s walking) from {self.source}: "
            f"{self.commands} command(s), {self.malformed} malformed, deadman cut "
            f"{self.deadman_trips} time(s)"
        )
        if self.last_problem:
            text += f"; last refused: {self.last_problem}"
        return text


def worst_heating(robot: Robot, gaits: Sequence[Gait]) -> dict[int, PredictedHeating]:
    """Per servo, the largest predicted heating over `gaits` (the drive may play any)."""
    out: dict[int, PredictedHeating] = {}
    for gait in gaits:
        for sid, pred in predicted_heating(robot, gait).items():
            if sid not in out or pred.mean_power_w > out[sid].mean_power_w:
                out[sid] = pred
    return out


class Driver(Player):
    """Drives `robot` from `source` through the blender `make_blender` builds (see above);
    `stand` is entered first, `gaits` are everything the blender may play (pre-flight), in
    the order its `entry_weights` index; `attitude`: IMU feedback on the blend (see above)."""

    def __init__(
        self,
        robot: Robot,
        stand: Gait,
        gaits: Sequence[Gait],
        make_blender: BlenderFactory,
        source: CommandSource,
        *,
        bus: ServoBus | None,
        calibration: Calibration | None = None,
        config: PlayerConfig | None = None,
        drive: DriveConfig | None = None,
        clock: Clock | None = None,
        telemetry: TelemetryWriter | None = None,
        on_tick: TickHook | None = None,
        attitude: AttitudeCorrector | None = None,
    ) -> None:
        cfg = config or PlayerConfig(cycles=None)
        if cfg.cycles is not None or cfg.speed_scale != 1.0:
            raise ValueError("a drive plays until its input ends: cycles None, speed_scale 1")
        self.stand = stand
        self.gaits = (stand, *gaits)
        super().__init__(
            robot, stand, bus=bus, calibration=calibration, config=cfg, clock=clock,
            telemetry=telemetry, on_tick=on_tick, heating=worst_heating(robot, self.gaits),
            attitude=attitude,
        )  # fmt: skip
        self.drive = drive or DriveConfig()
        self.make_blender = make_blender
        self.source = source
        self.hold = CommandHold(self.drive.deadman_s)
        self.blender: Blender | None = None
        self._drive_ticks = 0
        self._walking_ticks = 0

    # -- pre-flight over the whole library --------------------------------------------------
    def _check_offline(self) -> list[str]:
        cfg = self.config
        warnings: list[str] = []
        for gait in self.gaits:
            try:
                more, _ = check_offline(
                    self.robot, gait, self.calibration, 1.0, self.gate.enforced_speed_rad_s,
                    cfg.force, rate_hz=cfg.rate_hz, cycles=None,
                    attitude_gain=None if self.attitude is None else self.attitude.law.gain,
                )  # fmt: skip
            except PreflightError as exc:
                raise PreflightError(f"library {_label(gait)}: {exc.what}", exc.problem) from None
            except SpeedScaleError as exc:
                raise PreflightError(
                    f"library {_label(gait)}",
                    f"joint {exc.joint!r} would reach {exc.speed_rad_s:.2f} rad/s, above its "
                    f"allowed {exc.allowed_rad_s:.2f} rad/s at --rate {cfg.rate_hz:g}; re-plan "
                    "this entry slower or raise the rate",
                ) from None
            warnings += [f"{w} ({_label(gait)})" for w in more]
        return warnings

    def _check_supply(self, supply_v: float, source: str) -> tuple[str, list[str]]:
        """Every gait against the supply; the margin line of the most demanding one."""
        worst: tuple[float, str] = (-math.inf, "")
        warnings: list[str] = []
        for gait in self.gaits:
            line, more = check_supply(self.robot, gait, supply_v, source, self.config.force)
            warnings += [w for w in more if w not in warnings]
            peaks = _peak_torques_nm(self.robot, gait)
            frac = -1.0 if peaks is None else voltage_margin(
                self.robot, peaks, supply_v
            ).worst.fraction_at_supply
            if frac > worst[0]:
                worst = (frac, f"{line} (most demanding: {_label(gait)})")
        return worst[1], warnings

    def _planned_run_s(self) -> float | None:
        return self.drive.max_drive_s

    # -- the drive phase ------------------------------------------------------------------------
    def _play(self) -> None:
        # the ramp-in to the stand pose only: the blender treats the stand as a pose (its mean)
        plan = replace(self._entry_plan(self.stand, 1.0), n_blend=0)
        nothing = self._extra(STOP, STOP, math.nan)
        k = 0
        while self.watchdog.stop is None:
            step = self._entry_target(plan, k)
            if step is None:
                break
            k = self._tick(k, *step, watch=True, extra=nothing)
        if self.watchdog.stop is not None:
            return
        speeds = self.gate.enforced_speed_rad_s * self.drive.blend_speed_fraction
        blender = self.blender = self.make_blender(self._start_pose(), speeds, self.drive)
        k0 = k_prev = k
        while self.watchdog.stop is None:
            t_s = (k - k0) * self.period_s
            self.hold.update(self.source.poll(t_s))
            if self._finished(t_s, blender):
                break
            # the input ended (EOF, an end line): no command holds on for the deadman
            requested = STOP if self.source.ended else self.hold.requested(t_s)
            dt_s = max(1, k - k_prev) * self.period_s  # deadlines skipped after an overrun count
            target = self._corrected_blend(blender, blender.step(requested, dt_s))
            standing = blender.standing
            self._drive_ticks += max(1, k - k_prev)
            self._walking_ticks += 0 if standing else max(1, k - k_prev)
            k_prev = k
            extra = self._extra(requested, blender.command, blender.phase)
            k = self._tick(k, "stand" if standing else "drive", target, watch=True, extra=extra)

    def _corrected_blend(self, blender: Blender, target: np.ndarray) -> np.ndarray:
        """`target` plus the attitude feedback's offsets for the blend the blender played
        (`AttitudeCorrector.blended_offsets`: the reference roll/pitch and support weights of
        its entries at its phase, weighted like the joints; faded by its entry/exit weight α,
        which is 0 while it stands or ramps, so the stand gets no correction). The offsets go
        in before the SafetyGate, as `run`'s, and never into the blender's own state."""
        if self.attitude is None:
            return target
        idx, weights = blender.entry_weights
        gaits = [self.gaits[1 + int(i)] for i in idx]  # self.gaits = (stand, *entries)
        return target + self.attitude.blended_offsets(
            self.clock.now_s(), blender.blend_weight, gaits, weights, blender.phase)

    def _start_pose(self) -> np.ndarray:
        """Where the blender starts: the stand pose itself when the last goal is the stand to
        within the servos' resolution (one tick; the entry ended there), else the last goal."""
        last = self.gate.last_rad
        stand = gait_mean_pose(self.stand)
        tick_rad = np.array([1.0 / j.ticks_per_rad for j in self.calibration.joints])
        return stand if np.all(np.abs(last - stand) <= tick_rad + 1e-12) else last

    def _finished(self, t_s: float, blender: Blender) -> bool:
        """Request COMPLETED when the input has ended (or the time is up) and the robot stands."""
        ended = self.hold.ended or self.source.ended
        over = self.drive.max_drive_s is not None and t_s >= self.drive.max_drive_s - 1e-9
        if not ((ended or over) and blender.standing):
            return False
        why = f"drove {self.drive.max_drive_s:g} s" if over else f"{self.source.name} ended"
        self.watchdog.request(
            StopReason.COMPLETED, f"{why}; standing", self.ticks, self._now_rel()
        )
        return True

    def _extra(self, requested: Velocity, applied: Velocity, phase: float) -> Mapping[str, float]:
        values = (
            requested.vx_m_s, requested.vy_m_s, requested.yaw_rate_rad_s,
            applied.vx_m_s, applied.vy_m_s, applied.yaw_rate_rad_s,
            phase, float(self.source.stats.malformed),
        )  # fmt: skip
        return dict(zip(TELEMETRY_COLUMNS, values, strict=True))

    def drive_run(self) -> DriveResult:
        """`run()` (pre-flight, drive, safe stop) and what the source delivered; the source
        is closed on every path (the keyboard's terminal restored)."""
        try:
            play = self.run()
        finally:
            self.source.close()
        stats = self.source.stats
        return DriveResult(
            play=play,
            source=self.source.name,
            commands=stats.commands,
            malformed=stats.malformed,
            last_problem=stats.last_problem,
            deadman_trips=self.hold.trips,
            drive_s=self._drive_ticks * self.period_s,
            walking_s=self._walking_ticks * self.period_s,
            notes=tuple(stats.notes),
        )


def _label(gait: Gait) -> str:
    v = gait.velocity
    return (
        f"{gait.gait_label} at vx {v.vx_m_s:g}, vy {v.vy_m_s:g}, yaw rate {v.yaw_rate_rad_s:g}"
    )


def library_blender(library: GaitLibrary, robot: Robot) -> BlenderFactory:
    """A factory of `robots.blend.GaitBlender`s over `library`, clipping to `robot`'s joint
    limits and to the joint speeds the drive gives it."""
    from robots.blend import BlendLimits, GaitBlender

    lower = np.array([j.lower_rad for j in robot.joints])
    upper = np.array([j.upper_rad for j in robot.joints])

    def make(start_rad: np.ndarray, speeds_rad_s: np.ndarray, drive: DriveConfig) -> Blender:
        limits = BlendLimits(
            accel_m_s2=drive.accel_m_s2,
            yaw_accel_rad_s2=drive.yaw_accel_rad_s2,
            joint_speed_rad_s=np.asarray(speeds_rad_s, float),
            lower_rad=lower,
            upper_rad=upper,
        )
        return GaitBlender(library, limits, start_rad=np.asarray(start_rad, float))

    return make


def drive_from_library(
    robot: Robot, library: GaitLibrary, source: CommandSource, **kwargs: Any
) -> Driver:
    """A `Driver` over `library` (its stand, its walking entries, its `GaitBlender`); `kwargs`
    as `Driver`'s. The library must be for `robot` (`GaitLibrary.check_robot`)."""
    gaits = [e.gait for e in library.entries]
    return Driver(robot, library.stand, gaits, library_blender(library, robot), source, **kwargs)

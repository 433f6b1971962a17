"""The gait player: pre-flight, ramp-in, fixed-rate streaming, watchdog, safe stop.

    Player(robot, gait, bus=bus, config=PlayerConfig(...)).run() -> PlayResult

Timeline (all goal positions pass through one `SafetyGate`):

1. pre-flight (`hardware.play.preflight`): build, calibration, speed scale, sim verdict; on the bus:
   ping + model, voltage, temperature, flags, present pose within limits;
2. torque on (the servos hold their present pose), then the gait entry (`robots.ramp.gait_entry`,
   as `sim.validate` does): a min-jerk ramp from the present pose to the gait's mean pose, peak
   speed ≤ `ramp_speed_fraction` of the allowed speed and at least `ramp_s` long ("ramp_in"),
   then, with `stand_s` > 0, that pose held ("stand": the gait's stand, issue #14), then the
   gait blended in around that pose over whole cycles ("blend_in"), ending at phase 0
   (a straight ramp to the phase-0 pose turned a robot 7–15° before its first step, issue #12);
3. streaming at `rate_hz` with absolute deadlines t0 + k/rate (no drift). A tick whose work
   ends past the next deadline is an overrun: the latest passed deadline runs at once, late,
   and older passed deadlines are skipped (counted). The gait is sampled at
   gait time = `speed_scale` · (scheduled time since the gait began);
4. normal completion (`cycles` played) with `end_at_stand`: the gait blended *out* to its mean
   pose over whole cycles (`robots.ramp.gait_exit`, "blend_out"), the stand held `stand_s`
   ("stand"), then torque off or hold — no ramp to rest: a joint-space ramp from mid-stride
   drags the feet (it turned quad12's twin −7.7° in 0.5 s). The watchdog and the signals stay
   armed through both, and a stop there takes the safe-stop path below;
   stop (watchdog, a stop signal — SIGINT, SIGTERM, SIGHUP, SIGQUIT —, bus error, adapter
   lost, or completion without `end_at_stand`): ramp from the last goal to the rest pose
   (stance, or where the robot is) over ≥ `stop_ramp_s`, then torque off or hold. Any later
   signal skips what is left of the ramp, straight to step 5; a bus error or a lost adapter
   skips the ramp too;
5. torque off: one broadcast sync-write of Torque Enable = 0 (reaches servos whose replies are
   lost), then an acknowledged write per servo (failures reported), bounded in time; after an
   adapter failure only the broadcast is tried. Then the telemetry stop row.

The signal handlers stay installed from before pre-flight until after step 5 and never raise
(`hardware.play.watchdog.stop_on_signals`): no signal, however many, skips the torque-off; the first
stop reason is the one reported. A lost telemetry file (disk full) does not change any of this.

Allowed joint speed = `speed_margin` · the servo's no-load speed; the gate enforces exactly that
speed at every rate (a step budget with the fractional tick carried over, `SafetyGate`), and
pre-flight judges the gait against the same `SafetyGate.enforced_speed_rad_s`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from hardware.bus.servo_bus import ServoBus, ServoStatus
from hardware.errors import (
    AdapterLost,
    BusError,
    CorruptPacket,
    HardwareError,
    NoResponse,
    ServoFault,
)
from hardware.play.attitude import AttitudeCorrector
from hardware.play.calibration import Calibration
from hardware.play.clock import Clock, MonotonicClock, VirtualClock
from hardware.play.errors import PlayerError
from hardware.play.preflight import (
    check_bus,
    check_heating,
    check_offline,
    check_supply,
    measured_supply_v,
)
from hardware.play.safety_gate import GateCommand, SafetyGate
from hardware.play.telemetry import TelemetryWriter, TickRecord
from hardware.play.thermal_watch import PredictedHeating, predicted_heating
from hardware.play.watchdog import StopEvent, StopReason, Watchdog, WatchdogLimits, stop_on_signals
from robots.gait import Gait
from robots.ramp import GaitEntry, MinJerkRamp, gait_entry, gait_exit, min_jerk, ramp_to
from robots.robot import Robot

TickHook = Callable[[int, float], None]
try:  # pyserial's flush / reset on a vanished adapter raises termios.error, not an OSError
    from termios import error as _TermiosError

    _RAW_ADAPTER_ERRORS: tuple[type[BaseException], ...] = (OSError, _TermiosError)
except ImportError:  # pragma: no cover - no termios (Windows)
    _RAW_ADAPTER_ERRORS = (OSError,)
# what a failing adapter raises: AdapterLost once the drivers translate it, the raw errors until
ADAPTER_ERRORS: tuple[type[BaseException], ...] = (AdapterLost, *_RAW_ADAPTER_ERRORS)
BUS_FAILURES: tuple[type[BaseException], ...] = (BusError, *_RAW_ADAPTER_ERRORS)
MAX_RAMP_S = 60.0
TORQUE_OFF_BUDGET_S = 2.0  # the per-servo torque-off confirmations give up after this


def _os_text(exc: BaseException) -> str:
    """One line for an adapter failure: "[Errno 5] Input/output error", not a repr."""
    if isinstance(exc, OSError) and exc.strerror:
        return f"[Errno {exc.errno}] {exc.strerror}" if exc.errno else exc.strerror
    args: tuple[object, ...] = tuple(getattr(exc, "args", ()))
    if len(args) == 2 and isinstance(args[0], int) and isinstance(args[1], str):
        return f"[Errno {args[0]}] {args[1]}"  # termios.error(5, 'Input/output error')
    return str(exc) or type(exc).__name__


@dataclass(frozen=True)
class EntryPlan:
    """A gait entry (`robots.ramp.GaitEntry`) in ticks: ramp-in, the stand, then blend-in."""

    entry: GaitEntry
    n_ramp: int
    n_blend: int
    n_hold: int = 0  # at the stand (the gait's mean pose), between the ramp and the blend

    @property
    def ticks(self) -> int:
        return self.n_ramp + self.n_hold + self.n_blend


class RestPose(str, Enum):
    STANCE = "stance"
    PRESENT = "present"


class OnStop(str, Enum):
    TORQUE_OFF = "torque-off"
    HOLD = "hold"


@dataclass(frozen=True)
class PlayerConfig:
    """Options of one run (CLI flags map one to one)."""

    rate_hz: float = 100.0
    cycles: float | None = 1.0  # None: until stopped
    speed_scale: float = 1.0
    ramp_s: float = 2.0
    stop_ramp_s: float = 0.5
    rest: RestPose = RestPose.STANCE
    on_stop: OnStop = OnStop.TORQUE_OFF
    speed_margin: float = 0.9
    ramp_speed_fraction: float = 0.5
    stop_speed_fraction: float = 0.8
    dry_run: bool = False
    force: bool = False
    pose_tolerance_rad: float = 0.05
    limits: WatchdogLimits = field(default_factory=WatchdogLimits)
    supply_v: float | None = None  # the servos' supply [V]; None: measured at pre-flight
    stand_s: float = 0.0  # hold at the gait's stand (mean pose) after the ramp-in and at the end
    end_at_stand: bool = True  # a completed run blends out to the stand instead of ramping to rest

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and 1.0 <= self.rate_hz <= 1000.0):
            raise ValueError("rate_hz must lie in [1, 1000]")
        if self.cycles is not None and not (math.isfinite(self.cycles) and self.cycles > 0):
            raise ValueError("cycles must be a finite positive number (None: until stopped)")
        if not 0 < self.speed_margin <= 1.0:
            raise ValueError("speed_margin must lie in (0, 1]")
        if not (math.isfinite(self.speed_scale) and self.speed_scale > 0):
            raise ValueError("speed_scale must be a finite positive number")
        for name in ("ramp_s", "stop_ramp_s"):
            if not 0 < getattr(self, name) <= MAX_RAMP_S:
                raise ValueError(f"{name} must lie in (0, {MAX_RAMP_S:g}] s")
        if not (math.isfinite(self.stand_s) and 0 <= self.stand_s <= MAX_RAMP_S):
            raise ValueError(f"stand_s must lie in [0, {MAX_RAMP_S:g}] s")
        for name in ("ramp_speed_fraction", "stop_speed_fraction"):
            if not 0 < getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must lie in (0, 1]")


@dataclass(frozen=True)
class PlayResult:
    """How a run went (times [s] since the first deadline)."""

    stop: StopEvent
    ticks: int
    ticks_by_phase: Mapping[str, int]
    overruns: int  # ticks whose work ran past the next deadline
    skipped: int  # deadlines dropped to catch up after an overrun longer than a period
    misses: int
    max_consecutive_misses: int
    status_misses: int  # failed status reads (health unknown on those ticks)
    jitter_p50_s: float
    jitter_p99_s: float
    jitter_max_s: float
    achieved_rate_hz: float
    limit_clips: int
    step_clips: int
    safe_at_s: float  # when the rest pose was reached (before torque off / hold)
    torque_off_failures: tuple[int, ...]
    warnings: tuple[str, ...]
    dry_run: bool
    work_p99_s: float = 0.0  # p99 of one tick's work (send, read, check, log) [s]
    signals: int = 0  # stop signals received during the run
    telemetry_cut: str | None = None  # why the telemetry log was cut short (None: complete)
    supply_margin: str | None = None  # peak planned torque vs stall at the supply voltage

    @property
    def exit_code(self) -> int:
        return self.stop.reason.exit_code


class Player:
    """Plays `gait` on `bus` (None only with `dry_run`)."""

    def __init__(
        self,
        robot: Robot,
        gait: Gait,
        *,
        bus: ServoBus | None,
        calibration: Calibration | None = None,
        config: PlayerConfig | None = None,
        clock: Clock | None = None,
        telemetry: TelemetryWriter | None = None,
        on_tick: TickHook | None = None,
        heating: Mapping[int, PredictedHeating] | None = None,
        attitude: AttitudeCorrector | None = None,
    ) -> None:
        """`heating`: the predicted heating the watchdog compares against (default: `gait`'s;
        `hardware.play.drive` passes the worst over its library); `attitude`: IMU feedback
        added to the goals before the SafetyGate (`hardware.play.attitude`; None: open loop)."""
        self.robot, self.gait = robot, gait
        self.attitude = attitude
        self.config = cfg = config or PlayerConfig()
        if bus is None and not cfg.dry_run:
            raise PlayerError("no servo bus given (use --dry-run to play without one)")
        self.bus = bus
        self.calibration = calibration or Calibration.from_robot(robot)
        self.clock: Clock = clock or (VirtualClock() if cfg.dry_run else MonotonicClock())
        self.telemetry = telemetry
        self.on_tick = on_tick
        self.ids = [j.bus_id for j in robot.joints]
        self.allowed_speed_rad_s = np.array(
            [cfg.speed_margin * j.servo.no_load_speed_rad_s for j in robot.joints]
        )
        sink = None if cfg.dry_run or bus is None else bus.sync_write_positions
        self.gate = SafetyGate(self.calibration, self.allowed_speed_rad_s, cfg.rate_hz, sink)
        self.heating = predicted_heating(robot, gait) if heating is None else dict(heating)
        self.watchdog = Watchdog(
            cfg.limits,
            {j.bus_id: j.servo for j in robot.joints},
            {j.bus_id: j.name for j in robot.joints},
            heating=self.heating,
        )
        self.period_s = 1.0 / cfg.rate_hz
        self.ticks = 0
        self._t0 = self.clock.now_s()  # provisional: set again when the run starts
        self._jitter: list[float] = []
        self._work_s: list[float] = []
        self._overruns = 0
        self._skipped = 0
        self._phases: dict[str, int] = {}
        self._clips = [0, 0]
        self._last_present: tuple[int, np.ndarray] | None = None
        self._actual_span_s: list[float] = []  # first and last tick start [s]
        self._adapter_lost = False
        self._at_stand = False  # a completed run ended at the stand (no ramp to rest needed)
        self.supply_margin: str | None = None  # pre-flight's supply-voltage torque margin

    # -- public -----------------------------------------------------------------------------------
    def request_stop(self, reason: StopReason, message: str) -> None:
        self.watchdog.request(reason, message, self.ticks, self._now_rel())

    def run(self) -> PlayResult:
        """Pre-flight, then play until done or stopped; raises PlayerError if refused.

        The stop signals are caught from before pre-flight until the torque-off has been sent
        and the telemetry stop row written (see `hardware.play.watchdog`): whatever arrives, and
        however often, the run ends ramp to rest → torque off, never killed half-way."""
        with stop_on_signals(self.watchdog, lambda: (self.ticks, self._now_rel())):
            warnings, present = self._preflight()
            return self._play_accepted(present, warnings)

    def _check_offline(self) -> list[str]:
        """The checks that need no bus (`preflight.check_offline`); returns warnings."""
        cfg = self.config
        warnings, _ = check_offline(
            self.robot,
            self.gait,
            self.calibration,
            cfg.speed_scale,
            self.gate.enforced_speed_rad_s,
            cfg.force,
            rate_hz=cfg.rate_hz,
            cycles=cfg.cycles,
            attitude_gain=None if self.attitude is None else self.attitude.law.gain,
        )
        return warnings

    def _check_supply(self, supply_v: float, source: str) -> tuple[str, list[str]]:
        """The gait's peak torques at the supply voltage (`preflight.check_supply`)."""
        return check_supply(self.robot, self.gait, supply_v, source, self.config.force)

    def _planned_run_s(self) -> float | None:
        """How long the run will play [s] (None: until stopped), for the heating forecast."""
        cfg = self.config
        return None if cfg.cycles is None else cfg.cycles * self.gait.period_s / cfg.speed_scale

    def _preflight(self) -> tuple[list[str], np.ndarray | dict[int, int]]:
        cfg = self.config
        warnings = self._check_offline()
        statuses: dict[int, ServoStatus] = {}
        if self.bus is not None:
            try:
                present: np.ndarray | dict[int, int] = check_bus(
                    self.robot, self.calibration, self.bus, cfg.limits, cfg.pose_tolerance_rad,
                    on_status=statuses.update,
                )
            except ADAPTER_ERRORS as exc:
                raise PlayerError(f"pre-flight: serial adapter failed: {_os_text(exc)}") from None
        else:
            present = self.calibration.rad_to_ticks(self.robot.nominal_stance_rad)
        if cfg.supply_v is not None:
            supply = (cfg.supply_v, "--supply-v")
        elif statuses:
            supply = measured_supply_v(self.robot, statuses)
        else:
            supply = None
        if supply is not None:
            self.supply_margin, more = self._check_supply(*supply)
            warnings += more
        warnings += check_heating(
            self.robot, self.heating, statuses, cfg.limits, self._planned_run_s()
        )
        return warnings, present

    def _play_accepted(
        self, present: np.ndarray | dict[int, int], warnings: list[str]
    ) -> PlayResult:
        cfg = self.config
        self.gate.seed(present)
        safe_at = math.nan
        torque_failures: tuple[int, ...] = ()
        completed_cleanly = False
        try:
            self._start_clock()
            if not cfg.dry_run and self.bus is not None and self.watchdog.stop is None:
                try:
                    self.bus.torque_on(self.ids)
                except BUS_FAILURES as exc:
                    self._stop_for(exc, StopReason.BUS_ERROR)
            self._play()
            self._ramp_to_rest()
            safe_at = self._now_rel()
            completed_cleanly = True
        finally:
            if not cfg.dry_run and self.bus is not None:
                if cfg.on_stop is OnStop.TORQUE_OFF or not completed_cleanly:
                    torque_failures = self._torque_off()
            stop = self.watchdog.stop or StopEvent(
                StopReason.BUS_ERROR,
                "player aborted by an unexpected error",
                self.ticks,
                self._now_rel(),
            )
            if self.telemetry is not None:
                self.telemetry.finish(
                    stop.reason.value, stop.message, self.ticks, self._now_rel(), stop.t_s
                )
        return self._result(stop, safe_at, torque_failures, tuple(warnings))

    # -- the loop -------------------------------------------------------------------------------
    def _start_clock(self) -> None:
        """Times are relative to the first deadline; a stop requested before it (a signal
        during pre-flight) keeps its time, now negative."""
        t0 = self.clock.now_s() + self.period_s
        stop = self.watchdog.stop
        if stop is not None:
            self.watchdog.stop = replace(stop, t_s=stop.t_s - (t0 - self._t0))
        self._t0 = t0

    def _now_rel(self) -> float:
        return self.clock.now_s() - self._t0

    def _stop_for(self, exc: BaseException, reason: StopReason) -> None:
        """A bus call failed: an adapter failure (AdapterLost, or an OSError such as EIO
        escaping the driver) stops with ADAPTER_LOST, anything else with `reason`."""
        if isinstance(exc, ADAPTER_ERRORS):
            self._adapter_lost = True
            lost = isinstance(exc, AdapterLost)
            self.watchdog.request(
                StopReason.ADAPTER_LOST,
                str(exc) if lost else f"serial adapter lost: {_os_text(exc)}",
                self.ticks,
                self._now_rel(),
            )
            return
        self.watchdog.request(reason, f"bus: {exc}", self.ticks, self._now_rel())

    @property
    def _bus_dead(self) -> bool:
        stop = self.watchdog.stop
        return stop is not None and stop.reason in (StopReason.BUS_ERROR, StopReason.ADAPTER_LOST)

    def _entry_plan(self, gait: Gait, time_scale: float, hold_s: float = 0.0) -> EntryPlan:
        """How `gait` is entered from the last goal: ramp-in, `hold_s` at the stand, then
        blend-in (module docstring)."""
        cfg = self.config
        entry = gait_entry(
            gait,
            self.gate.last_rad,
            self.allowed_speed_rad_s * cfg.ramp_speed_fraction,
            cfg.ramp_s,
            time_scale=time_scale,
            hold_s=hold_s,
        )
        n_ramp = math.ceil(entry.ramp.duration_s * cfg.rate_hz - 1e-9)
        n_hold = round(hold_s * cfg.rate_hz)
        n_blend = max(1, round(entry.blend_s * cfg.rate_hz))  # its ticks span exactly blend_s
        return EntryPlan(entry, n_ramp, n_blend, n_hold)

    def _entry_target(self, plan: EntryPlan, k: int) -> tuple[str, np.ndarray] | None:
        """(phase, target) of deadline k of the entry; None once k is past it."""
        entry, ramp = plan.entry, plan.entry.ramp
        if k < plan.n_ramp:
            return "ramp_in", ramp.positions((k + 1) * self.period_s)
        if k < plan.n_ramp + plan.n_hold:
            return "stand", entry.mean_rad
        if k < plan.ticks:
            t_blend = (k - plan.n_ramp - plan.n_hold) * entry.blend_s / plan.n_blend  # → gait t=0
            return "blend_in", entry.positions(entry.blend_start_s + t_blend)
        return None

    @staticmethod
    def _entry_clock(plan: EntryPlan, k: int) -> tuple[float, float]:
        """(blend weight, gait time [s]) of entry deadline k, for the attitude feedback: 0
        during the ramp and the stand; in the blend the gait's clock runs from its start."""
        entry = plan.entry
        if k < plan.n_ramp + plan.n_hold:
            return 0.0, 0.0
        t_blend = (k - plan.n_ramp - plan.n_hold) * entry.blend_s / plan.n_blend
        alpha = float(entry.blend_weight(entry.blend_start_s + t_blend))
        return alpha, t_blend * entry.time_scale

    def _corrected(self, target: np.ndarray, blend: float, gait_time_s: float) -> np.ndarray:
        """`target` plus the attitude feedback's offsets (module `hardware.play.attitude`)."""
        if self.attitude is None:
            return target
        return target + self.attitude.offsets(self.clock.now_s(), blend, gait_time_s)

    def _play(self) -> None:
        cfg = self.config
        plan = self._entry_plan(self.gait, cfg.speed_scale, cfg.stand_s)
        n_gait: int | None = None
        if cfg.cycles is not None:
            n_gait = round(cfg.cycles * self.gait.period_s / cfg.speed_scale * cfg.rate_hz)
        k = 0
        while self.watchdog.stop is None:
            step = self._entry_target(plan, k)
            if step is not None:
                phase, target = step
                target = self._corrected(target, *self._entry_clock(plan, k))
            elif n_gait is not None and k - plan.ticks > n_gait:
                self._end_at_stand(k, (n_gait + 1) * self.period_s * cfg.speed_scale, plan.n_hold)
                break
            else:
                t_gait = (k - plan.ticks) * self.period_s * cfg.speed_scale
                phase = "gait"
                target = self._corrected(self.gait.joint_targets(t_gait), 1.0, t_gait)
            k = self._tick(k, phase, target, watch=True)

    def _end_at_stand(self, k: int, gait_s: float, n_hold: int) -> None:
        """The cycles are played: blend the gait out to its stand from gait time `gait_s`
        (`robots.ramp.gait_exit`), hold it `n_hold` ticks, then stop as completed. Watched like
        the gait: a fault or a signal on the way stops the run the safe way instead."""
        cfg = self.config
        if cfg.end_at_stand:
            exit_ = gait_exit(self.gait, gait_s, self.allowed_speed_rad_s * cfg.ramp_speed_fraction,
                              time_scale=cfg.speed_scale)
            n_exit = max(1, round(exit_.duration_s * cfg.rate_hz))
            for j in range(n_exit + n_hold):
                if self.watchdog.stop is not None:
                    return
                t_exit = min(j, n_exit) * exit_.duration_s / n_exit  # ends exactly at the stand
                phase = "blend_out" if j < n_exit else "stand"
                keep = 1.0 - float(min_jerk(t_exit / exit_.duration_s))
                target = self._corrected(exit_.positions(t_exit), keep,
                                         gait_s + cfg.speed_scale * t_exit)
                k = self._tick(k, phase, target, watch=True)
            if self.watchdog.stop is not None:
                return
            self._at_stand = True
        self.watchdog.request(
            StopReason.COMPLETED,
            f"played {cfg.cycles:g} cycle(s)" + (", ended at the stand" if self._at_stand else ""),
            self.ticks,
            self._now_rel(),
        )

    def _ramp_to_rest(self) -> None:
        cfg = self.config
        stop = self.watchdog.stop
        if stop is None or self._bus_dead or self.watchdog.urgent or self._at_stand:
            return
        start = self.gate.last_rad
        if cfg.rest is RestPose.STANCE:
            rest = np.asarray(self.robot.nominal_stance_rad, float)
        elif self._last_present is not None and self.ticks - self._last_present[0] <= 5:
            rest = self._last_present[1]
        else:
            rest = start
        ramp: MinJerkRamp = ramp_to(
            start, rest, self.allowed_speed_rad_s * cfg.stop_speed_fraction, cfg.stop_ramp_s
        )
        n = math.ceil(ramp.duration_s * cfg.rate_hz - 1e-9)
        k0 = self._next_k()
        k = k0
        while k - k0 < n and not self.watchdog.urgent:
            k = self._tick(k, "ramp_out", ramp.positions((k - k0 + 1) * self.period_s), watch=False)
            if self._bus_dead:
                return

    def _next_k(self) -> int:
        """Index of the next deadline not yet passed."""
        late = self._now_rel() / self.period_s
        return max(self.ticks, math.floor(late) + 1 if late > 0 else 0)

    def _tick(
        self,
        k: int,
        phase: str,
        target: np.ndarray,
        watch: bool,
        extra: Mapping[str, float] | None = None,
    ) -> int:
        """One tick at deadline k: send, read, check, log (`extra`: the telemetry's extra
        columns). Returns the next deadline index."""
        deadline = self._t0 + k * self.period_s
        self.clock.sleep_until(deadline)
        actual = self.clock.now_s()
        try:
            cmd = self.gate.command(target)
        except BUS_FAILURES as exc:
            self._stop_for(exc, StopReason.BUS_ERROR)
            return k + 1
        present, status = self._read(watch)
        t_rel = actual - self._t0
        self._account(cmd, phase, actual - deadline)
        self.ticks += 1
        if self.on_tick is not None:
            self.on_tick(self.ticks - 1, t_rel)  # instrumentation: part of the tick's work
        done = self.clock.now_s()
        self._work_s.append(done - actual)
        next_k = k + 1
        overrun = done > self._t0 + next_k * self.period_s
        if overrun:  # run the latest passed deadline now (late); skip older ones: no burst
            self._overruns += 1
            passed = math.floor((done - self._t0) / self.period_s)
            if passed > next_k:
                self._skipped += passed - next_k
                next_k = passed
        if self.telemetry is not None:
            self.telemetry.write(
                TickRecord(
                    self.ticks - 1,
                    phase,
                    k * self.period_s,
                    t_rel,
                    done - actual,
                    overrun,
                    cmd.target_rad,
                    cmd.target_ticks,
                    present,
                    status,
                    extra,
                )
            )
        return next_k

    def _account(self, cmd: GateCommand, phase: str, jitter_s: float) -> None:
        self._jitter.append(jitter_s)
        now = self._now_rel()
        self._actual_span_s[1:] = [now] if self._actual_span_s else []
        if not self._actual_span_s:
            self._actual_span_s.append(now)
        self._phases[phase] = self._phases.get(phase, 0) + 1
        self._clips[0] += cmd.limit_clipped
        self._clips[1] += cmd.step_clipped

    def _read(self, watch: bool) -> tuple[np.ndarray | None, Mapping[int, ServoStatus] | None]:
        """Present pose (None if missed) and, on status ticks, the servos' health."""
        if self.config.dry_run or self.bus is None:
            return None, None
        wd, t_rel = self.watchdog, self._now_rel()
        present: np.ndarray | None = None
        try:
            ticks = self.bus.sync_read_positions(self.ids)
            present = self.gate.ticks_to_rad([ticks[i] for i in self.ids])
            self._last_present = (self.ticks, present)
            if watch:
                wd.read_ok()
        except ServoFault as exc:
            if watch:
                wd.fault(exc, self.ticks, t_rel)
        except (NoResponse, CorruptPacket) as exc:
            if watch:
                wd.read_missed(exc, self.ticks, t_rel)
        except BUS_FAILURES as exc:
            self._stop_for(exc, StopReason.BUS_ERROR)
        status = None
        if self.ticks % self.config.limits.status_every_ticks == 0 and not self._bus_dead:
            try:
                status = self.bus.read_status(self.ids)
            except (NoResponse, CorruptPacket) as exc:
                # not a missed position read (the gait can go on), but health unseen for long
                # enough stops the run: an overheating servo must not go unnoticed
                if watch:
                    wd.status_missed(exc, self.ticks, t_rel)
            except BUS_FAILURES as exc:
                self._stop_for(exc, StopReason.BUS_ERROR)
            if status is not None and watch:
                wd.status(status, self.ticks, t_rel)
        return present, status

    def _torque_off(self) -> tuple[int, ...]:
        """Broadcast torque off, then confirm servo by servo; returns the ids not confirmed.

        Bounded: once the adapter has failed (now or during the run) only the broadcast is
        tried (best effort, one write), and the confirmations stop after
        `TORQUE_OFF_BUDGET_S` — every id not confirmed by then is reported."""
        assert self.bus is not None
        try:
            self.bus.sync_write("torque_enable", {i: 0 for i in self.ids})
        except BUS_FAILURES as exc:
            if isinstance(exc, ADAPTER_ERRORS):
                self._stop_for(exc, StopReason.BUS_ERROR)
        except HardwareError:
            pass  # not on the bus (cannot happen today): the confirmations below will tell
        if self._adapter_lost:
            return tuple(self.ids)
        failed = []
        give_up_at = self.clock.now_s() + TORQUE_OFF_BUDGET_S
        for n, i in enumerate(self.ids):
            if self.clock.now_s() > give_up_at:
                failed.extend(self.ids[n:])
                break
            try:
                self.bus.write(i, "torque_enable", 0)
            except ServoFault:
                continue  # it answered (with its error flags): the write arrived
            except ADAPTER_ERRORS as exc:
                self._stop_for(exc, StopReason.BUS_ERROR)
                failed.extend(self.ids[n:])
                break
            except HardwareError:
                failed.append(i)
        return tuple(failed)

    def _result(
        self,
        stop: StopEvent,
        safe_at: float,
        torque_failures: tuple[int, ...],
        warnings: tuple[str, ...],
    ) -> PlayResult:
        jit = np.asarray(self._jitter) if self._jitter else np.zeros(1)
        span = self._actual_span_s[-1] - self._actual_span_s[0] if self._actual_span_s else 0.0
        return PlayResult(
            stop=stop,
            ticks=self.ticks,
            ticks_by_phase=dict(self._phases),
            overruns=self._overruns,
            skipped=self._skipped,
            misses=self.watchdog.misses,
            max_consecutive_misses=self.watchdog.max_consecutive_misses,
            status_misses=self.watchdog.status_misses,
            jitter_p50_s=float(np.percentile(jit, 50)),
            jitter_p99_s=float(np.percentile(jit, 99)),
            jitter_max_s=float(np.max(jit)),
            achieved_rate_hz=(self.ticks - 1) / span if span > 0 else 0.0,
            limit_clips=self._clips[0],
            step_clips=self._clips[1],
            safe_at_s=safe_at,
            torque_off_failures=torque_failures,
            warnings=warnings + tuple(self.watchdog.warnings),
            dry_run=self.config.dry_run,
            work_p99_s=float(np.percentile(self._work_s, 99)) if self._work_s else 0.0,
            signals=self.watchdog.signals,
            telemetry_cut=None if self.telemetry is None else self.telemetry.cut,
            supply_margin=self.supply_margin,
        )

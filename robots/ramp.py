"""Ramp-in: move the joints smoothly from the present pose into a gait (numpy only).

The player (`hardware`) and the simulator (`sim.validate`) both start a gait this way, so the
simulator sees the same transient the servos will.

`ramp_to` is the building block: a minimum-jerk joint-space move (Flash & Hogan 1985, eq. 2:
s(u) = 10u³ − 15u⁴ + 6u⁵, u = t/T) from one pose to another. Velocity and acceleration are zero at
both ends; peak speed is 1.875·|Δq|/T (at u = ½). `ramp_duration_s` picks T: at least
`min_duration_s` (1 s by default), longer if the largest joint move would otherwise exceed
`max_speed_rad_s` at the mid-point.

`gait_entry` is how a gait is started (issue #12). Ramping straight to the gait's phase-0 pose
turned the robot before its first step: phase 0 of a trot or tripod has the swing groups at
opposite ends of their strides, so the joint-space path there is not symmetric — on quad12 the
FL/HR diagonal dipped 4 mm below FR/HL half-way through the ramp, FR and HL left the ground, and
the robot stood on one diagonal while those two feet moved 5–8 cm in the body frame along
different directions; sticking to the ground, they rotated the body by the change of direction
of the line between them (quad12 trot −14.5°, hex18 tripod −6.9°, a modified quad −13.2°).
A slower ramp does not help (3 s: −11.3°, −6.3°, −10.1°): the turn is kinematic, not dynamic.
Instead the entry ramps to the gait's *mean pose* — the cycle average of its joint samples,
which is left–right symmetric for a symmetric gait, so every foot moves by the mirror image of
its partner and all stay loaded — and then blends the gait in around that pose:

    q(τ) = m + α(τ)·(g(τ) − m),   α = s(τ / (k·T)),   0 ≤ τ ≤ k·T,

with g the gait's targets, m the mean pose, T the period and s the same minimum-jerk profile.
The strides and lifts grow from zero over k whole cycles, so the blend ends exactly at the
gait's phase 0 with its full motion, C² (α′ = α″ = 0 at both ends). k is the fewest cycles
(≥ `min_blend_cycles`) for which the blend's own contribution to joint speed, α′·|g − m| ≤
1.875·max|g − m|/(k·T), stays within the ramp's speed cap on top of the gait's planned speed.

A *run* (a gait with a planned flight phase: no foot down for part of the cycle) also needs its
speed built up: with k = 1 the built-in biped's 0.5 m/s run (duty 0.42, T = 0.48 s) fell
backwards 0.5 s after the blend (issue #14) — the strides reached full length in one cycle while
the body, starting from rest, had only reached 0.31 m/s, so it pitched back (−11° at phase 0,
−29° half a cycle later) and fell. A walk has a foot down at every instant and catches up; a
run cannot. So for a run k is also at least the cycles over which the body, accelerating
uniformly to the gait's speed v, stays within `RUN_ENTRY_ACCEL_G`·g (about what the open-loop
biped carried: 2 and 3 cycles, 0.54 and 0.36 m/s², stayed up but turned 7–16°; 4 cycles,
0.26 m/s², passed):

    k ≥ v / (a·T),   a = RUN_ENTRY_ACCEL_G · g   (runs only; walks keep the speed-cap k).

The exit uses the same k (it decelerates the same way). A blend that starts each leg at its own
touchdown phase (mirror legs then see the same weight at the same point of their strides) was
measured and is worse: the biped turned 28–34° during the entry, so it is not used.

A gait file may also ask for a longer blend: ``planner["entry_blend_cycles"]`` = K (written by
`gaitsmith plan --entry-cycles K`) makes k at least K, so the player and the simulator start it
the same way it was validated. A walking biped's one-cycle blend pitches the body back (the
strides reach full length before the body is up to speed) and the transient lasts several
cycles: humanoid20's template walk (docs/results/zoo_gaits.md, "Session 25") turns 11-13° in
that cycle and its knees peak at 0.83-0.85 of stall in cycles 2-4, against 0.75-0.76 in the
steady cycles; with K = 3 it walks straight. It is the gait's choice, not a rule: K = 3 makes
some of the built-in biped's walks fall (docs/results/biped_walk_robustness.md, item 7).

The mean pose is also where a run may rest between ramp and gait ("the stand", issue #14):
`gait_entry(..., hold_s=H)` holds it for H seconds before the blend. `gait_exit` is the same
blend run backwards, how a run that completes normally ends (instead of a joint-space ramp from
wherever the gait is to a rest pose, which drags the feet through the ground like the straight
ramp-in did and turned quad12's twin −7.7° in 0.5 s):

    q(t) = m + (1 − α(t))·(g(τ₀ + σ·t) − m),   α = s(t / (k·T/σ)),

from gait time τ₀ (where the gait was when it was told to stop, σ the time scale) on: the gait
keeps its phase while its strides and lifts shrink to zero over k whole cycles, and the run
ends still on all feet at the mean pose m, C² at both ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from robots.gait import ENTRY_CYCLES_KEY, MAX_ENTRY_CYCLES, Gait, valid_entry_cycles

MIN_JERK_PEAK_SPEED = 1.875  # max over u of ds/du for the quintic above
DEFAULT_RAMP_S = 1.0
DEFAULT_MIN_BLEND_CYCLES = 1
RUN_ENTRY_ACCEL_G = 0.03  # a run's mean forward acceleration over its blend ≤ this · g
STANDARD_GRAVITY_M_S2 = 9.80665
FLIGHT_SAMPLES = 1000  # phases at which a schedule is checked for a flight phase


def min_jerk(u: float | np.ndarray) -> np.ndarray:
    """Normalised minimum-jerk profile s(u) for u in [0, 1] (clipped outside)."""
    x = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    return x**3 * (10.0 + x * (-15.0 + 6.0 * x))


def min_jerk_rate(u: float | np.ndarray) -> np.ndarray:
    """ds/du of `min_jerk` (zero outside [0, 1])."""
    x = np.asarray(u, dtype=float)
    inside = (x >= 0.0) & (x <= 1.0)
    return np.where(inside, 30.0 * x**2 * (1.0 - x) ** 2, 0.0)


def ramp_duration_s(
    start_rad: np.ndarray,
    end_rad: np.ndarray,
    max_speed_rad_s: float | np.ndarray,
    min_duration_s: float = DEFAULT_RAMP_S,
) -> float:
    """Shortest ramp time ≥ `min_duration_s` whose peak joint speed stays ≤ `max_speed_rad_s`."""
    if min_duration_s <= 0:
        raise ValueError("min_duration_s must be positive")
    delta = np.abs(np.asarray(end_rad, dtype=float) - np.asarray(start_rad, dtype=float))
    speed = np.broadcast_to(np.asarray(max_speed_rad_s, dtype=float), delta.shape)
    if np.any(speed <= 0):
        raise ValueError("max_speed_rad_s must be positive")
    needed = float(np.max(MIN_JERK_PEAK_SPEED * delta / speed)) if delta.size else 0.0
    return max(float(min_duration_s), needed)


@dataclass(frozen=True, eq=False)
class MinJerkRamp:
    """Joint-space minimum-jerk move from `start_rad` to `end_rad` (J,) over `duration_s`."""

    start_rad: np.ndarray
    end_rad: np.ndarray
    duration_s: float

    def __post_init__(self) -> None:
        start = np.asarray(self.start_rad, dtype=float).reshape(-1)
        end = np.asarray(self.end_rad, dtype=float).reshape(-1)
        if start.shape != end.shape:
            raise ValueError(f"start {start.shape} and end {end.shape} poses differ in size")
        if not (np.all(np.isfinite(start)) and np.all(np.isfinite(end))):
            raise ValueError("ramp poses must be finite")
        if not self.duration_s > 0:
            raise ValueError("duration_s must be positive")
        object.__setattr__(self, "start_rad", start)
        object.__setattr__(self, "end_rad", end)

    def positions(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint targets at time(s) `t_s` since the ramp began ((J,) or (K, J)); held after T."""
        t = np.asarray(t_s, dtype=float)
        s = min_jerk(t / self.duration_s)
        out = self.start_rad + np.multiply.outer(s, self.end_rad - self.start_rad)
        return np.asarray(out)

    def velocities(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint speeds [rad/s] at time(s) `t_s` ((J,) or (K, J))."""
        t = np.asarray(t_s, dtype=float)
        ds = min_jerk_rate(t / self.duration_s) / self.duration_s
        return np.asarray(np.multiply.outer(ds, self.end_rad - self.start_rad))

    @property
    def peak_speed_rad_s(self) -> float:
        delta = np.abs(self.end_rad - self.start_rad)
        return float(MIN_JERK_PEAK_SPEED * np.max(delta) / self.duration_s) if delta.size else 0.0


def ramp_to(
    present_rad: np.ndarray,
    target_rad: np.ndarray,
    max_speed_rad_s: float | np.ndarray,
    min_duration_s: float = DEFAULT_RAMP_S,
) -> MinJerkRamp:
    """The ramp the player and the simulator use: min-jerk, ≥ `min_duration_s`, speed-capped."""
    duration = ramp_duration_s(present_rad, target_rad, max_speed_rad_s, min_duration_s)
    return MinJerkRamp(np.asarray(present_rad, float), np.asarray(target_rad, float), duration)


def gait_mean_pose(gait: Gait) -> np.ndarray:
    """Cycle average of `gait.joint_targets` (J,): exactly the mean of its N knots.

    For a uniform periodic cubic spline ∫S = h·Σyᵢ − (h³/24)·ΣMᵢ, and summing the spline's
    equations Mᵢ₋₁ + 4Mᵢ + Mᵢ₊₁ = 6/h²·(yᵢ₋₁ − 2yᵢ + yᵢ₊₁) over the cycle gives ΣMᵢ = 0.
    """
    return np.asarray(np.mean(gait.knots_rad, axis=0), dtype=float)


def blend_cycles(
    gait: Gait,
    max_speed_rad_s: float | np.ndarray,
    time_scale: float = 1.0,
    min_cycles: int = DEFAULT_MIN_BLEND_CYCLES,
) -> int:
    """Fewest whole cycles (≥ `min_cycles`) whose blend term stays within `max_speed_rad_s`."""
    if min_cycles < 1:
        raise ValueError("min_cycles must be at least 1")
    if not time_scale > 0:
        raise ValueError("time_scale must be positive")
    knots = gait.knots_rad
    amplitude = np.max(np.abs(knots - gait_mean_pose(gait)), axis=0)
    speed = np.broadcast_to(np.asarray(max_speed_rad_s, dtype=float), amplitude.shape)
    if np.any(speed <= 0):
        raise ValueError("max_speed_rad_s must be positive")
    # wall-clock blend term: time_scale · 1.875 · A / (k · T) ≤ cap
    needed = np.max(MIN_JERK_PEAK_SPEED * time_scale * amplitude / (gait.period_s * speed))
    return max(int(min_cycles), math.ceil(float(needed) - 1e-9), run_speed_up_cycles(gait),
               requested_cycles(gait))


def requested_cycles(gait: Gait) -> int:
    """The blend length the gait file asks for (``planner["entry_blend_cycles"]``; 1 if none)."""
    value = gait.planner.get(ENTRY_CYCLES_KEY, 1)  # a file's value was checked on loading
    if not valid_entry_cycles(value):
        raise ValueError(f"planner.{ENTRY_CYCLES_KEY} must be a whole number of cycles from 1 "
                         f"to {MAX_ENTRY_CYCLES}, got {value!r:.40}")
    return value


def has_flight(gait: Gait) -> bool:
    """True when the gait's schedule has a phase with no foot in stance (a run)."""
    in_stance = gait.schedule.contact_matrix(FLIGHT_SAMPLES)
    return bool(np.any(~np.any(in_stance, axis=1)))


def run_speed_up_cycles(gait: Gait, accel_g: float = RUN_ENTRY_ACCEL_G) -> int:
    """Cycles a run needs to reach its speed at ≤ `accel_g`·g (k ≥ v/(a·T), module docstring);
    1 for a gait without flight. At the planned speed and period (time scale 1)."""
    if not has_flight(gait):
        return 1
    v = math.hypot(gait.velocity.vx_m_s, gait.velocity.vy_m_s)
    return max(1, math.ceil(v / (accel_g * STANDARD_GRAVITY_M_S2 * gait.period_s) - 1e-9))


@dataclass(frozen=True, eq=False)
class GaitEntry:
    """Min-jerk `ramp` to the gait's mean pose, then the gait blended in (module docstring).

    `time_scale` is gait seconds per second of the clock (the player's speed scale). After
    `duration_s` the caller plays `gait.joint_targets(time_scale·(t − duration_s))`: the entry
    ends at the gait's phase 0.
    """

    ramp: MinJerkRamp
    gait: Gait
    cycles: int
    time_scale: float = 1.0
    hold_s: float = 0.0  # at the mean pose (the stand), between the ramp and the blend

    def __post_init__(self) -> None:
        if not (isinstance(self.cycles, int) and self.cycles >= 1):
            raise ValueError(f"blend cycles must be a positive integer, got {self.cycles!r}")
        if not self.time_scale > 0:
            raise ValueError("time_scale must be positive")
        if not (math.isfinite(self.hold_s) and self.hold_s >= 0):
            raise ValueError("hold_s must be a finite number ≥ 0")

    @property
    def mean_rad(self) -> np.ndarray:
        return self.ramp.end_rad

    @property
    def start_rad(self) -> np.ndarray:
        return self.ramp.start_rad

    @property
    def blend_s(self) -> float:
        return self.cycles * self.gait.period_s / self.time_scale

    @property
    def blend_start_s(self) -> float:
        """When the blend begins: after the ramp and the hold at the stand."""
        return self.ramp.duration_s + self.hold_s

    @property
    def duration_s(self) -> float:
        return self.blend_start_s + self.blend_s

    def blend_weight(self, t_s: float | np.ndarray) -> np.ndarray:
        """α at time(s) `t_s` since the entry began: 0 during the ramp and hold, 1 at the end."""
        t = np.asarray(t_s, dtype=float)
        return min_jerk((t - self.blend_start_s) / self.blend_s)

    def positions(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint targets at time(s) `t_s` since the entry began ((J,) or (K, J)); after
        `duration_s` the gait's phase-0 pose."""
        t = np.asarray(t_s, dtype=float)
        ramp = self.ramp.positions(np.minimum(t, self.ramp.duration_s))
        tau = np.clip(t - self.blend_start_s, 0.0, self.blend_s) * self.time_scale
        gait = self.gait.joint_targets(tau)
        alpha = np.asarray(self.blend_weight(t))[..., None]
        mean = self.mean_rad
        in_blend = np.asarray(t > self.ramp.duration_s)[..., None]
        return np.asarray(np.where(in_blend, mean + alpha * (gait - mean), ramp))


@dataclass(frozen=True, eq=False)
class GaitExit:
    """The gait blended out to its mean pose (the stand) from gait time `start_gait_s`, over
    `cycles` whole cycles (module docstring); after `duration_s` the mean pose."""

    gait: Gait
    start_gait_s: float
    cycles: int
    time_scale: float = 1.0
    mean_rad: np.ndarray = field(init=False, repr=False)  # the stand the exit ends at

    def __post_init__(self) -> None:
        if not (isinstance(self.cycles, int) and self.cycles >= 1):
            raise ValueError(f"blend cycles must be a positive integer, got {self.cycles!r}")
        if not (self.time_scale > 0 and math.isfinite(self.start_gait_s)):
            raise ValueError("time_scale must be positive and start_gait_s finite")
        object.__setattr__(self, "mean_rad", gait_mean_pose(self.gait))

    @property
    def duration_s(self) -> float:
        return self.cycles * self.gait.period_s / self.time_scale

    def positions(self, t_s: float | np.ndarray) -> np.ndarray:
        """Joint targets at time(s) `t_s` since the exit began ((J,) or (K, J))."""
        t = np.clip(np.asarray(t_s, dtype=float), 0.0, self.duration_s)
        gait = self.gait.joint_targets(self.start_gait_s + self.time_scale * t)
        keep = 1.0 - np.asarray(min_jerk(t / self.duration_s))[..., None]
        mean = self.mean_rad
        return np.asarray(mean + keep * (gait - mean))


def gait_entry(
    gait: Gait,
    present_rad: np.ndarray,
    max_speed_rad_s: float | np.ndarray,
    min_duration_s: float = DEFAULT_RAMP_S,
    *,
    time_scale: float = 1.0,
    min_blend_cycles: int = DEFAULT_MIN_BLEND_CYCLES,
    hold_s: float = 0.0,
) -> GaitEntry:
    """How the player and the simulator start `gait` from `present_rad` (module docstring);
    `hold_s`: seconds at the stand (the mean pose) between the ramp and the blend."""
    ramp = ramp_to(present_rad, gait_mean_pose(gait), max_speed_rad_s, min_duration_s)
    k = blend_cycles(gait, max_speed_rad_s, time_scale, min_blend_cycles)
    return GaitEntry(ramp, gait, k, float(time_scale), float(hold_s))


def gait_exit(
    gait: Gait,
    start_gait_s: float,
    max_speed_rad_s: float | np.ndarray,
    *,
    time_scale: float = 1.0,
    min_blend_cycles: int = DEFAULT_MIN_BLEND_CYCLES,
) -> GaitExit:
    """How a completed run ends: `gait` blended out to its stand from gait time `start_gait_s`
    over as many cycles as the entry's blend takes at the same speed cap (module docstring)."""
    k = blend_cycles(gait, max_speed_rad_s, time_scale, min_blend_cycles)
    return GaitExit(gait, float(start_gait_s), k, float(time_scale))

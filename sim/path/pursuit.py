"""Pure-pursuit path following on the measured base pose, inside a gait library's command box.

Each tick the controller (Coulter 1992, "Implementation of the pure pursuit path tracking
algorithm", CMU-RI-TR-92-01) projects the measured base position onto the path (a window around
its progress, so a figure-8's crossing is never confused with the other lobe), takes the goal
point a look-ahead distance further along the path, and steers on the arc through the robot and
the goal, tangent to its heading: curvature κ = 2·y_b / d² (y_b: the goal's lateral offset in
the body frame, d its distance; Coulter eq. 1), yaw rate ω = v·κ. The look-ahead is a multiple
of the robot's leg length (`lookahead_leg_lengths`): the base sways by a fraction of a leg
length within each cycle, and the look-ahead must be long against that sway yet short against
the path's bends. It is also at least `lookahead_s` seconds of travel at the cruise speed: the
command reaches the gait only through the blender's acceleration limits and a gait cycle, and a
goal closer than that lag makes the loop oscillate (hex18's default library, cruising at
0.19 m/s with a 0.21 m look-ahead — 1.1 s — swung between ±0.386 rad/s with a 7 s period and
6 cm mean cross-track error; at 2 s it holds the path to 0.9 cm). On a circle of radius R the
arc through the robot and a goal on the circle is the circle itself, so an ideal unicycle holds
it with no steady error (module test).

The forward speed v is the smallest of the cruise speed (the box's top vx unless set), the
curve limit — `yaw_fraction`·ω_max/|κ_path|, with κ_path the largest path curvature over the
next `preview_lookaheads` look-aheads, so the robot slows *before* a tight bend and keeps
(1 − `yaw_fraction`) of its yaw authority for corrections — the lateral-acceleration limit
v²|κ| ≤ a_lat, and, on the last stretch, √(2·a·(s_remaining − tolerance)) so it stops at the end.
If ω = v·κ falls outside the box the speed is lowered to keep the arc. A goal behind the robot
(|bearing| > 90°) turns it in place when the box allows vx = 0. When the box spans vy (the
library has side-steps), a lateral correction vy = −k·e (e: signed cross-track error, left +)
helps the arc. The command always lies inside the box.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robots.gait import Velocity
from sim.errors import SimConfigError
from sim.path.spec import PlannedPath

GRAVITY_M_S2 = 9.81


@dataclass(frozen=True)
class PursuitSettings:
    lookahead_leg_lengths: float = 2.0
    lookahead_s: float = 2.0  # … and at least this much travel at the cruise speed
    speed_m_s: float | None = None  # cruise speed; None: the top vx of the command box
    yaw_fraction: float = 0.8  # share of the box's yaw rate the speed plan may use in curves
    preview_lookaheads: float = 2.0  # how far ahead curvature slows the robot [look-aheads]
    lateral_accel_g: float = 0.05  # v²|κ| ≤ this·g (a walking robot's sway stays small)
    decel_m_s2: float = 0.05  # braking towards the end of the path
    goal_tolerance_leg_lengths: float = 0.25  # "arrived" within this distance along the path
    lateral_gain_per_s: float = 0.5  # vy = −k·e when the box spans vy

    def __post_init__(self) -> None:
        for name in ("lookahead_leg_lengths", "lookahead_s", "yaw_fraction", "preview_lookaheads",
                     "lateral_accel_g", "decel_m_s2", "goal_tolerance_leg_lengths"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise SimConfigError(f"pursuit {name} must be positive, got {v!r}")
        if self.yaw_fraction > 1.0:
            raise SimConfigError(f"pursuit yaw_fraction must be ≤ 1, got {self.yaw_fraction!r}")
        if not (math.isfinite(self.lateral_gain_per_s) and self.lateral_gain_per_s >= 0):
            raise SimConfigError("pursuit lateral_gain_per_s must be ≥ 0")
        if self.speed_m_s is not None and not (math.isfinite(self.speed_m_s)
                                               and self.speed_m_s > 0):
            raise SimConfigError(f"cruise speed must be positive, got {self.speed_m_s!r}")

    def lookahead_m(self, leg_length_m: float, cruise_m_s: float) -> float:
        """The look-ahead distance for this robot and cruise speed (module docstring)."""
        return max(self.lookahead_leg_lengths * leg_length_m, self.lookahead_s * cruise_m_s)


@dataclass(frozen=True)
class PursuitState:
    """What the controller saw and chose on one tick (for logs and metrics)."""

    progress_m: float  # arc length of the nearest path point (unwrapped over laps)
    cross_track_m: float  # signed distance from the path (robot left of it: +)
    heading_error_rad: float  # body yaw − path tangent, wrapped to (−π, π]
    goal_m: tuple[float, float]  # the pursued point, world frame
    command: Velocity
    finished: bool


def wrap_angle(a: float | np.ndarray) -> np.ndarray:
    """Angle(s) wrapped to (−π, π]."""
    return np.asarray(np.angle(np.exp(1j * np.asarray(a, dtype=float))))


def _clip(v: float, lo: float, hi: float) -> float:
    return float(min(max(v, lo), hi))


class PurePursuit:
    """Pure pursuit along `path` for `laps` laps (closed paths) or once (open paths)."""

    def __init__(
        self,
        path: PlannedPath,
        bounds: tuple[Velocity, Velocity],
        leg_length_m: float,
        settings: PursuitSettings = PursuitSettings(),
        laps: int = 1,
    ) -> None:
        if not (isinstance(laps, int) and laps >= 1):
            raise SimConfigError(f"laps must be a positive integer, got {laps!r}")
        if laps > 1 and not path.closed:
            raise SimConfigError(f"{path.spec!r} is an open path: it has no laps (use --laps 1)")
        lo, hi = bounds
        if hi.vx_m_s <= 0.0:
            raise SimConfigError(
                f"the command box has no forward speed (vx ≤ {hi.vx_m_s:g} m/s): "
                "it cannot follow a path")
        if lo.yaw_rate_rad_s >= 0.0 or hi.yaw_rate_rad_s <= 0.0:
            raise SimConfigError(
                f"the command box has no turning both ways (yaw rate in "
                f"[{lo.yaw_rate_rad_s:g}, {hi.yaw_rate_rad_s:g}] rad/s): it cannot follow a path")
        self.path = path
        self.lo, self.hi = lo, hi
        self.settings = settings
        self.laps = laps
        self.tolerance_m = settings.goal_tolerance_leg_lengths * leg_length_m
        self.total_m = path.length_m * laps
        cruise = hi.vx_m_s if settings.speed_m_s is None else min(settings.speed_m_s, hi.vx_m_s)
        self.cruise_m_s = cruise
        self.lookahead_m = settings.lookahead_m(leg_length_m, cruise)
        self.progress_m = 0.0
        self.finished = False

    def _curve_speed(self, s_m: float) -> float:
        kappa = self.path.max_abs_curvature(
            s_m, s_m + self.settings.preview_lookaheads * self.lookahead_m)
        if kappa <= 1e-9:
            return math.inf
        w_max = min(-self.lo.yaw_rate_rad_s, self.hi.yaw_rate_rad_s)
        v_yaw = self.settings.yaw_fraction * w_max / kappa
        v_lat = math.sqrt(self.settings.lateral_accel_g * GRAVITY_M_S2 / kappa)
        return min(v_yaw, v_lat)

    def step(self, x_m: float, y_m: float, yaw_rad: float) -> PursuitState:
        """The command for the measured base pose (world frame)."""
        p = np.array([x_m, y_m], dtype=float)
        back, ahead = 0.5 * self.lookahead_m, 2.0 * self.lookahead_m
        s_near, e = self.path.nearest(p, self.progress_m - back, self.progress_m + ahead)
        self.progress_m = max(self.progress_m, min(s_near, self.total_m))
        s = self.progress_m
        heading_err = float(wrap_angle(yaw_rad - float(self.path.heading_at(s))))
        remaining = self.total_m - s
        goal_s = s + self.lookahead_m
        goal = self.path.point_at(goal_s)
        if self.finished or remaining <= self.tolerance_m:
            self.finished = True
            return PursuitState(s, e, heading_err, (float(goal[0]), float(goal[1])),
                                Velocity(), True)
        c, sn = math.cos(yaw_rad), math.sin(yaw_rad)
        rel = goal - p
        gx, gy = c * rel[0] + sn * rel[1], -sn * rel[0] + c * rel[1]
        d2 = max(gx * gx + gy * gy, 1e-12)
        kappa = 2.0 * gy / d2  # Coulter 1992 eq. 1
        v = min(self.cruise_m_s, self._curve_speed(s),
                math.sqrt(2.0 * self.settings.decel_m_s2 * max(remaining - self.tolerance_m, 0.0)))
        w_lo, w_hi = self.lo.yaw_rate_rad_s, self.hi.yaw_rate_rad_s
        if gx <= 0.0 and self.lo.vx_m_s <= 0.0:  # goal behind: turn towards it on the spot
            v = 0.0
            w = self.settings.yaw_fraction * (w_hi if gy >= 0 else w_lo)
        else:
            v = max(v, self.lo.vx_m_s)
            w = v * kappa
            if w > w_hi or w < w_lo:  # keep the arc: slow down until ω fits the box
                w = _clip(w, w_lo, w_hi)
                v = max(abs(w / kappa), self.lo.vx_m_s) if kappa != 0.0 else v
        vy = 0.0
        if self.lo.vy_m_s < 0.0 < self.hi.vy_m_s:
            vy = _clip(-self.settings.lateral_gain_per_s * e, self.lo.vy_m_s, self.hi.vy_m_s)
        cmd = Velocity(_clip(v, self.lo.vx_m_s, self.hi.vx_m_s), vy, _clip(w, w_lo, w_hi))
        return PursuitState(s, e, heading_err, (float(goal[0]), float(goal[1])), cmd, False)

"""Live blending of a gait library: joint targets for any command inside the grid (numpy only).

Issue #15 item 3. `hardware.play` (drive) and `sim.path` call `GaitBlender.step` every tick.

Interpolation. The library's walking entries lie on (part of) a tensor grid of commands
c = (vx, vy, yaw rate). For a command inside the grid's box the blender finds the grid cell
around it and its multilinear weights wₑ (the product of the per-axis linear weights over the
2³ cell corners; an axis with one value has weight 1). The entries share one schedule and one
knot count, so they are blended *at the same phase* φ:

    q(φ, c) = Σₑ wₑ(c) · Sₑ(φ),        T(c) = Σₑ wₑ(c) · Tₑ,

with Sₑ the periodic cubic spline of entry e's knots (`robots.spline`) and T the period law
(the entries' periods interpolated with the same weights; constant when they are equal). One
phase variable advances at dφ/dt = 1/T(c), so φ stays continuous when the command changes. A
grid node without an entry (it failed at build time) stands in as the linear interpolation of
its two neighbours along each axis that has both, else as the nearest entry (`_Grid`).

Command. The requested command is clipped into the grid's box (`command_clipped` says when),
then the current command moves towards it at most `accel_m_s2`·dt per tick in vx and vy and
`yaw_accel_rad_s2`·dt in yaw rate — and less when that change would move the targets faster
than the joint speed left over by the gait's own motion allows
(`BlendLimits.command_speed_share`: entries that differ a lot per grid step turn a fast command
change into fast joint motion, which the per-tick clip would otherwise cut, distorting the
gait). A zero request sends the command to the rest
point (the box point nearest to zero), then blends out to the stand.

Stand ↔ walk, with `robots.ramp`'s entry blend (`gait_entry`'s pieces, reused, not copied):
from the stand (or any start pose) a minimum-jerk ramp (`ramp_to`) moves to the mean pose m of
the gait at the rest point, then the gait grows in around m,

    q = m + α(u)·(q(φ, c) − m),     α = `min_jerk`(u),   du/dφ = 1/k,

over k whole cycles from phase 0 (k = the largest `blend_cycles` of the entries). A zero request
runs the same blend backwards (u from 1 to 0, once the command has reached the rest point),
then ramps from m to the stand pose. A new request during the exit reverses it where it is.

Every tick the result is clipped to `joint_speed_rad_s`·dt around the previous target and to the
joint limits (`BlendLimits.lower_rad/upper_rad`), so no target ever jumps.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robots.errors import RobotsError
from robots.gait import Velocity
from robots.library import GaitLibrary, velocity_tuple
from robots.ramp import (
    DEFAULT_MIN_BLEND_CYCLES,
    DEFAULT_RAMP_S,
    MinJerkRamp,
    blend_cycles,
    gait_mean_pose,
    min_jerk,
    ramp_to,
)
from robots.spline import PeriodicSpline

if TYPE_CHECKING:
    from robots.robot import Robot

DEFAULT_COMMAND_SPEED_SHARE = 0.95  # command changes may use the joint speed up to this share
MIN_COMMAND_STEP = 0.05  # of the acceleration-limited step, however little speed is left
ZERO_COMMAND_EPS = 1e-9  # |component| below this counts as a zero (stop) request
DEFAULT_RAMP_SPEED_FRACTION = 0.5  # ramps at half the joint speed limit, as sim and player do


class BlendError(RobotsError, ValueError):
    """Bad blender input: limits that do not fit the library, a non-finite command or dt."""


@dataclass(frozen=True, eq=False)
class BlendLimits:
    accel_m_s2: float  # |d vx/dt|, |d vy/dt| limit of the commanded velocity
    yaw_accel_rad_s2: float
    joint_speed_rad_s: np.ndarray  # (J,) targets never move faster than this (clipped per tick)
    lower_rad: np.ndarray | None = None  # (J,) joint limits the targets are clipped to
    upper_rad: np.ndarray | None = None
    ramp_speed_fraction: float = DEFAULT_RAMP_SPEED_FRACTION  # of joint_speed, ramps and blends
    min_ramp_s: float = DEFAULT_RAMP_S
    min_blend_cycles: int = DEFAULT_MIN_BLEND_CYCLES
    #: command changes may use the joint speed up to this share (with the gait's own motion);
    #: None: only the acceleration limits bound them (the per-tick clip still bounds the result)
    command_speed_share: float | None = DEFAULT_COMMAND_SPEED_SHARE

    def __post_init__(self) -> None:
        for name in ("accel_m_s2", "yaw_accel_rad_s2", "min_ramp_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise BlendError(f"BlendLimits.{name} must be a positive number, got {v!r}")
        share = self.command_speed_share
        if share is not None and not (isinstance(share, (int, float)) and 0 < share <= 1):
            raise BlendError("BlendLimits.command_speed_share must be in (0, 1] or None")
        if not 0 < self.ramp_speed_fraction <= 1:
            raise BlendError("BlendLimits.ramp_speed_fraction must be in (0, 1]")
        speed = np.asarray(self.joint_speed_rad_s, dtype=float).reshape(-1)
        if speed.size == 0 or not np.all(np.isfinite(speed) & (speed > 0)):
            raise BlendError("BlendLimits.joint_speed_rad_s must be positive and finite")
        object.__setattr__(self, "joint_speed_rad_s", speed)
        for name in ("lower_rad", "upper_rad"):
            v = getattr(self, name)
            if v is not None:
                a = np.asarray(v, dtype=float).reshape(-1)
                if a.shape != speed.shape or not np.all(np.isfinite(a)):
                    raise BlendError(f"BlendLimits.{name} must be {speed.size} finite angles")
                object.__setattr__(self, name, a)
        if (self.lower_rad is None) != (self.upper_rad is None):
            raise BlendError("BlendLimits: give both lower_rad and upper_rad, or neither")

    @staticmethod
    def for_robot(
        robot: Robot,
        accel_m_s2: float,
        yaw_accel_rad_s2: float,
        speed_fraction: float = 1.0,
    ) -> BlendLimits:
        """Limits from the robot's servos (no-load speed × `speed_fraction`) and joint limits."""
        if not 0 < speed_fraction <= 1:
            raise BlendError("speed_fraction must be in (0, 1]")
        return BlendLimits(
            accel_m_s2,
            yaw_accel_rad_s2,
            speed_fraction * np.array([j.servo.no_load_speed_rad_s for j in robot.joints]),
            np.array([j.lower_rad for j in robot.joints]),
            np.array([j.upper_rad for j in robot.joints]),
        )


@dataclass(frozen=True, eq=False)
class _Grid:
    """The entries' commands as a tensor grid: per-axis values and, per grid node, the entries
    that stand for it with their weights — the entry itself, or for a node with no entry (a
    hole: that entry failed at build time) the linear interpolation of its two neighbours along
    every axis that has both (averaged over those axes), else the nearest entry."""

    axes: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]
    nodes: dict[tuple[int, int, int], tuple[tuple[int, float], ...]]

    @staticmethod
    def of(library: GaitLibrary) -> _Grid:
        c = np.array([velocity_tuple(e.command) for e in library.entries])
        axes = tuple(tuple(float(x) for x in np.unique(c[:, a])) for a in range(3))
        shape = tuple(len(a) for a in axes)
        index = -np.ones(shape, dtype=int)
        for e, row in enumerate(c):
            index[tuple(ax.index(float(x)) for ax, x in zip(axes, row, strict=True))] = e
        span = np.ptp(c, axis=0)
        scale = np.where(span > 0, span, 1.0)
        nodes: dict[tuple[int, int, int], tuple[tuple[int, float], ...]] = {}
        for node in np.ndindex(*shape):
            e = int(index[node])
            if e >= 0:
                nodes[node] = ((e, 1.0),)  # type: ignore[index]
                continue
            acc: dict[int, float] = {}
            n_axes = 0
            for a in range(3):
                i = node[a]
                if i == 0 or i == shape[a] - 1:
                    continue
                lo_n, hi_n = list(node), list(node)
                lo_n[a], hi_n[a] = i - 1, i + 1
                lo_e, hi_e = int(index[tuple(lo_n)]), int(index[tuple(hi_n)])
                if lo_e < 0 or hi_e < 0:
                    continue
                v = axes[a]
                t = (v[i] - v[i - 1]) / (v[i + 1] - v[i - 1])
                acc[lo_e] = acc.get(lo_e, 0.0) + 1.0 - t
                acc[hi_e] = acc.get(hi_e, 0.0) + t
                n_axes += 1
            if n_axes:
                nodes[node] = tuple((k, w / n_axes) for k, w in acc.items())  # type: ignore[index]
            else:
                at = np.array([axes[a][node[a]] for a in range(3)])
                d = np.sum(((c - at) / scale) ** 2, axis=1)
                nodes[node] = ((int(np.argmin(d)), 1.0),)  # type: ignore[index]
        return _Grid(axes, nodes)  # type: ignore[arg-type]

    @staticmethod
    def _axis(values: tuple[float, ...], x: float) -> tuple[tuple[int, float], ...]:
        if len(values) == 1:
            return ((0, 1.0),)
        i = min(max(bisect.bisect_right(values, x) - 1, 0), len(values) - 2)
        t = (x - values[i]) / (values[i + 1] - values[i])
        t = min(max(t, 0.0), 1.0)
        return ((i, 1.0 - t), (i + 1, t))

    def weights(self, c: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
        """(entry indices, multilinear weights summing to 1) for the command `c` in the box."""
        acc: dict[int, float] = {}
        ax, ay, aw = (self._axis(v, x) for v, x in zip(self.axes, c, strict=True))
        for i, wi in ax:
            for j, wj in ay:
                for k, wk in aw:
                    weight = wi * wj * wk
                    if weight > 0.0:
                        for e, we in self.nodes[(i, j, k)]:
                            acc[e] = acc.get(e, 0.0) + weight * we
        return np.fromiter(acc.keys(), int, len(acc)), np.fromiter(acc.values(), float, len(acc))


def _toward(x: float, target: float, step: float) -> float:
    return target if abs(target - x) <= step else x + math.copysign(step, target - x)


class GaitBlender:
    """Joint targets tick by tick for a velocity command (see the module docstring)."""

    def __init__(
        self, library: GaitLibrary, limits: BlendLimits, start_rad: np.ndarray | None = None
    ) -> None:
        n_j = len(library.joint_names)
        if limits.joint_speed_rad_s.shape != (n_j,):
            raise BlendError(
                f"BlendLimits.joint_speed_rad_s has {limits.joint_speed_rad_s.size} values; the "
                f"library has {n_j} joints"
            )
        self.library = library
        self.limits = limits
        self._grid = _Grid.of(library)
        splines = [PeriodicSpline(e.gait.knots_rad) for e in library.entries]
        self._n = splines[0].values.shape[0]
        y = np.stack([s.values for s in splines])  # (E, N, J)
        m = np.stack([s.second for s in splines])
        # per knot interval [i, i+1]: y_i, y_{i+1}, M_i, M_{i+1} → one gather per tick
        self._blocks = np.stack([y, np.roll(y, -1, axis=1), m, np.roll(m, -1, axis=1)], axis=2)
        self._periods = np.array([e.gait.period_s for e in library.entries])
        self._means = np.stack([gait_mean_pose(e.gait) for e in library.entries])
        self._stand = gait_mean_pose(library.stand)
        lo, hi = library.command_bounds()
        self._lo, self._hi = velocity_tuple(lo), velocity_tuple(hi)
        self._rest = tuple(min(max(0.0, a), b) for a, b in zip(self._lo, self._hi, strict=True))
        self._ramp_speed = limits.ramp_speed_fraction * limits.joint_speed_rad_s
        self._cycles = max(
            blend_cycles(e.gait, self._ramp_speed, 1.0, limits.min_blend_cycles)
            for e in library.entries
        )
        ridx, rw = self._grid.weights(self._rest)  # type: ignore[arg-type]
        self._rest_mean = rw @ self._means[ridx]
        self._cmd: tuple[float, float, float] = self._rest  # type: ignore[assignment]
        self._cached_cmd: tuple[float, float, float] | None = None
        self._cached: tuple[np.ndarray, np.ndarray, float] = (ridx, rw, 0.0)
        self._clipped = False
        self._speed_clipped = False
        self._phase = 0.0
        self._u = 0.0  # gait blend progress (α = min_jerk(u))
        self._state = "standing"
        self._ramp: MinJerkRamp | None = None
        self._ramp_t = 0.0
        if start_rad is None:
            self._q = self._stand.copy()
        else:
            q = np.asarray(start_rad, dtype=float).reshape(-1)
            if q.shape != (n_j,) or not np.all(np.isfinite(q)):
                raise BlendError(f"start_rad must be {n_j} finite joint angles")
            self._q = self._clip_limits(q)
            if not np.allclose(self._q, self._stand, atol=1e-9):
                self._start_ramp(self._stand, "stand_ramp")

    # -- public state --------------------------------------------------------------------------

    @property
    def command(self) -> Velocity:
        """The command in use after acceleration limits and clipping into the grid box; zero
        while the blender ramps or stands."""
        if self._state != "gait":
            return Velocity()
        return Velocity(*self._cmd)

    @property
    def command_clipped(self) -> bool:
        """Whether the last requested command was outside the grid's box (and was clipped)."""
        return self._clipped

    @property
    def speed_clipped(self) -> bool:
        """Whether the last step's joint speed clip changed the targets (they lag the blend)."""
        return self._speed_clipped

    @property
    def phase(self) -> float:
        """Gait phase in [0, 1), continuous across command changes (0 while not walking)."""
        return self._phase

    @property
    def standing(self) -> bool:
        """True when at rest in the stand (command 0 and settled)."""
        return self._state == "standing"

    @property
    def state(self) -> str:
        """"standing", "stand_ramp" (to the stand), "entry_ramp" (to the gait) or "gait"."""
        return self._state

    @property
    def blend_weight(self) -> float:
        """α: 0 at the mean pose, 1 in the full gait."""
        return float(min_jerk(self._u)) if self._state == "gait" else 0.0

    @property
    def entry_weights(self) -> tuple[np.ndarray, np.ndarray]:
        """(indices into `library.entries`, weights summing to 1) of the blend at the command in
        use: the weights wₑ of the last `step`'s q = Σ wₑ Sₑ(φ) (the rest point's while not
        walking). The attitude feedback blends its reference with them
        (`robots.attitude.blended_offsets`)."""
        idx, w, _ = self._weights(self._cmd)
        return idx.copy(), w.copy()

    @property
    def targets_rad(self) -> np.ndarray:
        """The last targets returned by `step` (the start pose before the first step)."""
        return self._q.copy()

    def period_s(self, command: Velocity | None = None) -> float:
        """The period law T(c) at `command` (default: the command in use), clipped to the box."""
        c = self._cmd if command is None else self._clip(velocity_tuple(command))
        return self._weights(c)[2]

    # -- the tick ------------------------------------------------------------------------------

    def step(self, command: Velocity, dt_s: float) -> np.ndarray:
        """(J,) joint targets for the next tick, `dt_s` after the previous one."""
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise BlendError(f"dt_s must be a positive number of seconds, got {dt_s!r}")
        req = velocity_tuple(command)
        if not all(math.isfinite(x) for x in req):
            raise BlendError(f"command {req} is not finite")
        walk = any(abs(x) > ZERO_COMMAND_EPS for x in req)
        target = self._clip(req)
        self._clipped = walk and target != req
        if not walk:
            target = self._rest  # type: ignore[assignment]
        if self._state in ("standing", "stand_ramp"):
            if walk:
                self._start_ramp(self._rest_mean, "entry_ramp")
            q = self._advance_ramp(dt_s)
        elif self._state == "entry_ramp":
            if not walk:
                self._start_ramp(self._stand, "stand_ramp")
            q = self._advance_ramp(dt_s)
        else:
            q = self._advance_gait(target, walk, dt_s)
        step = self.limits.joint_speed_rad_s * dt_s
        clipped = np.clip(q, self._q - step, self._q + step)
        self._speed_clipped = not np.array_equal(clipped, q)
        self._q = self._clip_limits(clipped)
        return self._q.copy()

    # -- internals -----------------------------------------------------------------------------

    def _clip(self, c: tuple[float, ...]) -> tuple[float, float, float]:
        x, y, w = (min(max(v, a), b) for v, a, b in zip(c, self._lo, self._hi, strict=True))
        return (x, y, w)

    def _clip_limits(self, q: np.ndarray) -> np.ndarray:
        if self.limits.lower_rad is None or self.limits.upper_rad is None:
            return q
        return np.clip(q, self.limits.lower_rad, self.limits.upper_rad)

    def _start_ramp(self, end_rad: np.ndarray, state: str) -> None:
        self._ramp = ramp_to(self._q, end_rad, self._ramp_speed, self.limits.min_ramp_s)
        self._ramp_t = 0.0
        self._state = state
        self._phase = 0.0
        self._u = 0.0
        self._cmd = self._rest  # type: ignore[assignment]

    def _advance_ramp(self, dt_s: float) -> np.ndarray:
        if self._state == "standing" or self._ramp is None:
            return self._stand
        self._ramp_t += dt_s
        q = self._ramp.positions(min(self._ramp_t, self._ramp.duration_s))
        if self._ramp_t >= self._ramp.duration_s:
            self._state = "gait" if self._state == "entry_ramp" else "standing"
            self._ramp = None
        return np.asarray(q)

    def _advance_gait(self, target: tuple[float, float, float], walk: bool,
                      dt_s: float) -> np.ndarray:
        lim = self.limits
        dv, dw = lim.accel_m_s2 * dt_s, lim.yaw_accel_rad_s2 * dt_s
        c0 = self._cmd
        c1 = (_toward(c0[0], target[0], dv), _toward(c0[1], target[1], dv),
              _toward(c0[2], target[2], dw))
        if c1 != c0 and lim.command_speed_share is not None:
            c1 = self._speed_budgeted(c0, c1, lim.command_speed_share, dt_s)
        self._cmd = c1
        idx, w, period = self._weights(self._cmd)
        dphase = dt_s / period
        self._phase = (self._phase + dphase) % 1.0
        if walk:
            self._u = min(1.0, self._u + dphase / self._cycles)
        elif self._cmd == self._rest:
            self._u = max(0.0, self._u - dphase / self._cycles)
        g = self._targets(idx, w, self._phase)
        if self._u >= 1.0:
            q = g
        else:
            m = self._rest_mean
            q = m + float(min_jerk(self._u)) * (g - m)
        if not walk and self._u <= 0.0:
            self._state = "stand_ramp"
            self._ramp = ramp_to(q, self._stand, self._ramp_speed, lim.min_ramp_s)
            self._ramp_t = 0.0
            self._phase = 0.0
        return q

    def _speed_budgeted(self, c0: tuple[float, float, float], c1: tuple[float, float, float],
                        share_of_limit: float, dt_s: float) -> tuple[float, float, float]:
        """The command step c0 → c1 shortened so that the targets' change it causes fits in
        the joint speed left over by the gait's own motion (`share_of_limit` of the limit in
        all): a fast command change across entries that differ a lot would otherwise
        be cut by the per-tick clip, distorting the gait. At least `MIN_COMMAND_STEP` of the
        step is always taken, so the command keeps moving (the clip still bounds the result)."""
        idx0, w0 = self._grid.weights(c0)
        idx1, w1 = self._grid.weights(c1)
        phase = (self._phase + dt_s / float(w0 @ self._periods[idx0])) % 1.0
        alpha = float(min_jerk(self._u))
        m = self._rest_mean
        q0 = m + alpha * (self._targets(idx0, w0, phase) - m)
        q1 = m + alpha * (self._targets(idx1, w1, phase) - m)
        budget = share_of_limit * self.limits.joint_speed_rad_s * dt_s - np.abs(q0 - self._q)
        change = np.abs(q1 - q0)
        over = change > np.maximum(budget, 0.0)
        if not np.any(over):
            return c1
        share = float(np.min(np.maximum(budget[over], 0.0) / change[over]))
        s = min(1.0, max(MIN_COMMAND_STEP, share))
        return (c0[0] + s * (c1[0] - c0[0]), c0[1] + s * (c1[1] - c0[1]),
                c0[2] + s * (c1[2] - c0[2]))

    def _weights(self, c: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray, float]:
        """Grid weights and period law at `c`, cached for the last command (steady driving
        repeats it tick after tick)."""
        if c != self._cached_cmd:
            idx, w = self._grid.weights(c)
            self._cached = (idx, w, float(w @ self._periods[idx]))
            self._cached_cmd = c
        return self._cached

    def _targets(self, idx: np.ndarray, w: np.ndarray, phase: float) -> np.ndarray:
        """Σ wₑ Sₑ(phase): the periodic cubic spline (`robots.spline`) of the blended knots."""
        n = self._n
        s = phase * n
        i = min(int(s), n - 1)
        u = s - i
        a = 1.0 - u
        h2 = 1.0 / (6.0 * n * n)
        coef = np.array([a, u, h2 * (a * a * a - a), h2 * (u * u * u - u)])
        block = self._blocks[idx, i]  # (K, 4, J)
        return np.asarray(np.outer(w, coef).reshape(-1) @ block.reshape(-1, block.shape[-1]))

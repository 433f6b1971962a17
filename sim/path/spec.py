"""Path specs for `gaitsmith drive-sim --path SPEC`, turned into arc-length parametrised paths.

Specs (lengths in metres, world frame, z up; the robot is placed at the path's start, facing
along it):

- ``circle:R`` — a circle of radius |R| starting at the origin heading +x; R > 0 turns left
  (counter-clockwise, centre (0, R)), R < 0 turns right.
- ``figure8:R`` — two circles of radius |R| touching at the origin: the first lobe turns left
  (centre (0, R)), the second right (centre (0, −R)); the heading is continuous where they meet
  (both are tangent to the x axis there), the curvature flips from +1/R to −1/R.
- ``x,y;x,y;...`` — waypoints, or a ``.json`` file (a list of ``[x, y]`` pairs, or
  ``{"waypoints": [...]}``) or a ``.csv`` file (one ``x,y`` per line, an optional header line).
  A centripetal Catmull-Rom spline (α = ½) goes through them: the parametrisation of Yuksel,
  Schaefer & Keyser 2011, which never forms cusps or self-intersections inside a segment — the
  curves Torkos & van de Panne 1998 §3.4 place footprints along. A path whose last waypoint
  repeats the first is closed (it can be driven for several laps).

Every path is sampled densely and resampled at equal arc-length steps, so `point_at(s)` etc.
take the distance along the path `s` [m]. Sizes are bounded against the robot (its leg length
L): radii ≥ `MIN_RADIUS_LEG_LENGTHS`·L, waypoints at least `MIN_WAYPOINT_GAP_LEG_LENGTHS`·L apart,
at most `MAX_WAYPOINTS`, within `MAX_EXTENT_LEG_LENGTHS`·L of the origin, total length ≤
`MAX_LENGTH_LEG_LENGTHS`·L.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from sim.path.errors import PathSpecError

#: a circle/figure-8 lobe tighter than two leg lengths has the feet on the far side crossing
#: the turning centre: that is a turn in place, not a path
MIN_RADIUS_LEG_LENGTHS = 2.0
#: waypoints closer than this are duplicates (a centripetal spline kinks at near-coincident points)
MIN_WAYPOINT_GAP_LEG_LENGTHS = 0.25
MAX_WAYPOINTS = 1000
MAX_EXTENT_LEG_LENGTHS = 1000.0  # every waypoint (and a circle's far side) this close to the origin
MAX_LENGTH_LEG_LENGTHS = 5000.0  # ≈ 0.9 km for an 18 cm leg: hours of simulated walking
MAX_SPEC_CHARS = 100_000
MAX_FILE_BYTES = 1 << 20
#: equal arc-length resampling step [m] (the path is a polyline this fine)
SAMPLE_STEP_M = 0.002
MAX_SAMPLES = 400_000
CATMULL_ROM_ALPHA = 0.5  # centripetal
SAMPLES_PER_SEGMENT = 256  # dense parameter samples per spline segment, before resampling
CLOSED_TOL_M = 1e-6

EXAMPLES = "circle:1.0, figure8:0.75, '0,0;1,0;1,1' or a .json/.csv file of x,y waypoints"


@dataclass(frozen=True, eq=False)
class PlannedPath:
    """A planar path sampled at equal arc-length steps (`points_m[k]` at `s = k·step_m`)."""

    spec: str  # as given on the command line
    points_m: np.ndarray  # (N, 2); closed paths do not repeat the first point at the end
    step_m: float
    closed: bool
    waypoints_m: np.ndarray  # (W, 2) the points the user gave (circle/figure-8: key points)
    waypoint_s_m: np.ndarray  # (W,) arc length of each waypoint

    @property
    def length_m(self) -> float:
        n = len(self.points_m)
        return self.step_m * (n if self.closed else n - 1)

    @property
    def n_points(self) -> int:
        return len(self.points_m)

    def _index(self, s_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sample indices (i, i+1) around `s_m` and the fraction between them."""
        n = self.n_points
        u = np.asarray(s_m, dtype=float) / self.step_m
        if self.closed:
            u = np.mod(u, n)
            i = np.minimum(np.floor(u).astype(int), n - 1)
            return i, (i + 1) % n, u - i
        u = np.clip(u, 0.0, n - 1)
        i = np.minimum(np.floor(u).astype(int), n - 2)
        return i, i + 1, u - i

    def point_at(self, s_m: float | np.ndarray) -> np.ndarray:
        """Position(s) at arc length `s_m` ((2,) or (K, 2)). Closed paths wrap (laps); open paths
        continue straight along their end tangents beyond either end (look-ahead targets)."""
        s = np.asarray(s_m, dtype=float)
        i, j, f = self._index(s)
        p = self.points_m[i] + f[..., None] * (self.points_m[j] - self.points_m[i])
        if not self.closed:
            over = np.maximum(s - self.length_m, 0.0)[..., None]
            under = np.minimum(s, 0.0)[..., None]
            p = p + over * self._end_unit(-1) + under * self._end_unit(0)
        return np.asarray(p)

    def _end_unit(self, end: int) -> np.ndarray:
        """Unit tangent of the first (0) or last (−1) segment."""
        pts = self.points_m
        d = pts[1] - pts[0] if end == 0 else pts[-1] - pts[-2]
        return np.asarray(d / max(float(np.linalg.norm(d)), 1e-12))

    def heading_at(self, s_m: float | np.ndarray) -> np.ndarray:
        """Tangent direction [rad] at arc length `s_m` (central differences of the samples)."""
        s = np.asarray(s_m, dtype=float)
        if not self.closed:
            s = np.clip(s, 0.5 * self.step_m, self.length_m - 0.5 * self.step_m)
        d = self.point_at(s + 0.5 * self.step_m) - self.point_at(s - 0.5 * self.step_m)
        return np.asarray(np.arctan2(d[..., 1], d[..., 0]))

    def curvature_at(self, s_m: float | np.ndarray, window_m: float | None = None) -> np.ndarray:
        """Signed curvature [1/m] (left positive): heading change over `window_m` (default four
        sample steps) divided by it."""
        w = 4.0 * self.step_m if window_m is None else float(window_m)
        s = np.asarray(s_m, dtype=float)
        if not self.closed:
            s = np.clip(s, 0.5 * w, max(0.5 * w, self.length_m - 0.5 * w))
        dh = self.heading_at(s + 0.5 * w) - self.heading_at(s - 0.5 * w)
        return np.asarray(np.angle(np.exp(1j * dh)) / w)

    @cached_property
    def abs_curvature_samples(self) -> np.ndarray:
        """|curvature| at every sample (N,), for `max_abs_curvature`."""
        return np.abs(self.curvature_at(np.arange(self.n_points) * self.step_m))

    def max_abs_curvature(self, s_from_m: float, s_to_m: float) -> float:
        """Largest |curvature| at the samples between two arc lengths (closed: unwrapped)."""
        k0 = math.floor(s_from_m / self.step_m)
        k1 = max(k0, math.ceil(s_to_m / self.step_m))
        ks = np.arange(k0, k1 + 1)
        ks = ks % self.n_points if self.closed else np.clip(ks, 0, self.n_points - 1)
        return float(np.max(self.abs_curvature_samples[ks]))

    def nearest(self, p_m: np.ndarray, s_lo_m: float, s_hi_m: float) -> tuple[float, float]:
        """Arc length of the point nearest `p_m` with s in [s_lo, s_hi] (closed paths: unwrapped
        s, any number of laps) and the signed cross-track distance (path to the robot's left
        of the path direction positive, i.e. the robot is left of the path)."""
        p = np.asarray(p_m, dtype=float)
        lo, hi = float(s_lo_m), float(s_hi_m)
        if not self.closed:
            lo, hi = max(lo, 0.0), min(hi, self.length_m)
            if hi < lo:
                lo = hi = min(max(lo, 0.0), self.length_m)
        k0 = math.floor(lo / self.step_m)
        k1 = max(k0 + 1, math.ceil(hi / self.step_m))
        ks = np.arange(k0, k1 + 1)
        if not self.closed:
            ks = np.clip(ks, 0, self.n_points - 1)
        a = self.points_m[ks[:-1] % self.n_points]
        b = self.points_m[ks[1:] % self.n_points]
        ab = b - a
        seg2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18)
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / seg2, 0.0, 1.0)
        foot = a + t[:, None] * ab
        d2 = np.einsum("ij,ij->i", p - foot, p - foot)
        best = int(np.argmin(d2))
        s = float(np.clip((ks[best] + t[best]) * self.step_m, lo, hi))
        tangent = ab[best] / math.sqrt(seg2[best])
        rel = p - foot[best]
        side = float(tangent[0] * rel[1] - tangent[1] * rel[0])
        return s, math.copysign(math.sqrt(float(d2[best])), side if side != 0 else 1.0)


def _fail(option: str, spec: str, why: str) -> PathSpecError:
    shown = spec if len(spec) <= 60 else spec[:57] + "..."
    return PathSpecError(f"{option} {shown!r}: {why} (write {EXAMPLES})")


def _resample(dense: np.ndarray, closed: bool, step_m: float
              ) -> tuple[np.ndarray, np.ndarray, float]:
    """Equal arc-length samples of a dense polyline: (points, cumulative s of the dense points,
    the step actually used: it divides the length exactly, ≥ `step_m`, ≤ `MAX_SAMPLES` points)."""
    pts = np.vstack([dense, dense[:1]]) if closed else dense
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    length = float(s[-1])
    n = max(2, min(MAX_SAMPLES, math.ceil(length / step_m)))
    step = length / n
    si = np.arange(n if closed else n + 1) * step
    out = np.stack([np.interp(si, s, pts[:, 0]), np.interp(si, s, pts[:, 1])], axis=1)
    return out, s, step


def catmull_rom(waypoints_m: np.ndarray, closed: bool,
                samples_per_segment: int = SAMPLES_PER_SEGMENT) -> tuple[np.ndarray, np.ndarray]:
    """Dense samples of the centripetal Catmull-Rom spline through `waypoints_m` (W, 2), and the
    index of each waypoint in them. Barry & Goldman's pyramidal form (Yuksel et al. 2011 eq. 1)
    with knot spacing tᵢ₊₁ − tᵢ = |Pᵢ₊₁ − Pᵢ|^α. Open splines get phantom end points mirrored
    through the ends (P₋₁ = 2P₀ − P₁), so the curve starts and ends at the first/last waypoint."""
    w = np.asarray(waypoints_m, dtype=float)
    if closed:
        ext = np.vstack([w[-1:], w, w[:2]])
        n_seg = len(w)
    else:
        ext = np.vstack([2 * w[0] - w[1], w, 2 * w[-1] - w[-2]])
        n_seg = len(w) - 1
    u = np.linspace(0.0, 1.0, samples_per_segment, endpoint=False)
    parts = []
    for k in range(n_seg):
        p0, p1, p2, p3 = ext[k], ext[k + 1], ext[k + 2], ext[k + 3]
        d = [max(float(np.linalg.norm(b - a)) ** CATMULL_ROM_ALPHA, 1e-12)
             for a, b in ((p0, p1), (p1, p2), (p2, p3))]
        t0, t1 = 0.0, d[0]
        t2, t3 = t1 + d[1], t1 + d[1] + d[2]
        t = (t1 + u * (t2 - t1))[:, None]
        a1 = (t1 - t) / (t1 - t0) * p0 + (t - t0) / (t1 - t0) * p1
        a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2
        a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3
        b1 = (t2 - t) / (t2 - t0) * a1 + (t - t0) / (t2 - t0) * a2
        b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3
        parts.append((t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2)
    if not closed:
        parts.append(w[-1:])
    index = np.arange(len(w)) * samples_per_segment
    return np.vstack(parts), index


def _circle_points(radius_m: float, centre_y_m: float, n: int) -> np.ndarray:
    """A full circle from the origin heading +x: centre (0, centre_y), turning towards it."""
    turn = math.copysign(1.0, centre_y_m)
    a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    return np.stack([radius_m * np.sin(a), centre_y_m - turn * radius_m * np.cos(a)], axis=1)


def _parse_radius(option: str, spec: str, text: str) -> float:
    try:
        r = float(text)
    except ValueError:
        raise _fail(option, spec, f"radius {text!r} is not a number of metres") from None
    if not math.isfinite(r) or r == 0.0:
        raise _fail(option, spec, "radius must be a finite, non-zero number of metres")
    return r


def _parse_pairs(option: str, spec: str, rows: list[list[str]]) -> np.ndarray:
    pts = []
    for k, row in enumerate(rows, start=1):
        cells = [c.strip() for c in row if c.strip()]
        if len(cells) != 2:
            raise _fail(option, spec, f"waypoint {k} has {len(cells)} numbers, expected x,y")
        try:
            x, y = float(cells[0]), float(cells[1])
        except ValueError:
            raise _fail(option, spec, f"waypoint {k} ({','.join(cells)}) is not two numbers") \
                from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise _fail(option, spec, f"waypoint {k} is not finite")
        pts.append((x, y))
    return np.array(pts, dtype=float).reshape(-1, 2)


def _read_file(option: str, spec: str, file: Path) -> np.ndarray:
    try:
        raw = file.read_bytes()[: MAX_FILE_BYTES + 1]
    except OSError as exc:
        raise _fail(option, spec, f"cannot read the waypoint file: {exc.strerror}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise _fail(option, spec, f"waypoint file larger than {MAX_FILE_BYTES >> 10} KiB")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise _fail(option, spec, "waypoint file is not UTF-8 text") from None
    if file.suffix.lower() == ".json":
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise _fail(option, spec, f"invalid JSON at line {exc.lineno}: {exc.msg}") from None
        if isinstance(doc, dict):
            doc = doc.get("waypoints")
        if not isinstance(doc, list) or not all(
            isinstance(p, list) and all(isinstance(c, (int, float)) and not isinstance(c, bool)
                                        for c in p) for p in doc
        ):
            raise _fail(option, spec, 'JSON must be a list of [x, y] pairs or {"waypoints": [...]}')
        return _parse_pairs(option, spec, [[repr(float(c)) for c in p] for p in doc])
    rows = [r for r in csv.reader(io.StringIO(text)) if any(c.strip() for c in r)]
    if rows:
        try:
            [float(c) for c in rows[0] if c.strip()]
        except ValueError:
            rows = rows[1:]  # a header line
    return _parse_pairs(option, spec, rows)


def _check_waypoints(option: str, spec: str, w: np.ndarray, leg_length_m: float) -> bool:
    """Bounds of a waypoint list; returns whether it is closed (last repeats first)."""
    if len(w) > MAX_WAYPOINTS + 1:
        raise _fail(option, spec, f"{len(w)} waypoints, at most {MAX_WAYPOINTS}")
    closed = len(w) >= 2 and float(np.linalg.norm(w[-1] - w[0])) <= CLOSED_TOL_M
    core = w[:-1] if closed else w
    if len(core) < (3 if closed else 2):
        raise _fail(option, spec, "needs at least 2 distinct waypoints (3 for a closed loop)")
    extent = MAX_EXTENT_LEG_LENGTHS * leg_length_m
    far = float(np.max(np.abs(core)))
    if far > extent:
        raise _fail(option, spec, f"waypoint {far:g} m from the origin, at most {extent:.0f} m "
                    f"({MAX_EXTENT_LEG_LENGTHS:g} leg lengths)")
    ring = np.vstack([core, core[:1]]) if closed else core
    gaps = np.linalg.norm(np.diff(ring, axis=0), axis=1)
    k = int(np.argmin(gaps))
    gap_min = MIN_WAYPOINT_GAP_LEG_LENGTHS * leg_length_m
    if gaps[k] < gap_min:
        raise _fail(option, spec, f"waypoints {k + 1} and {k + 2} are {gaps[k]:.3g} m apart, "
                    f"at least {gap_min:.3g} m ({MIN_WAYPOINT_GAP_LEG_LENGTHS:g} leg lengths)")
    return closed


def parse_path(spec: str, leg_length_m: float, option: str = "--path") -> PlannedPath:
    """The path of `spec` (module docstring), bounded against a robot of `leg_length_m` legs;
    `PathSpecError` naming `option` otherwise."""
    if not (math.isfinite(leg_length_m) and leg_length_m > 0):
        raise PathSpecError(f"leg length must be positive, got {leg_length_m!r}")
    text = spec.strip()
    if not text:
        raise _fail(option, spec, "empty path")
    if len(text) > MAX_SPEC_CHARS:
        raise _fail(option, spec, f"longer than {MAX_SPEC_CHARS} characters; use a file")
    head, _, rest = text.partition(":")
    kind = head.strip().lower()
    r_min = MIN_RADIUS_LEG_LENGTHS * leg_length_m
    if kind in ("circle", "figure8"):
        r = _parse_radius(option, spec, rest.strip())
        if abs(r) < r_min:
            raise _fail(option, spec, f"radius {abs(r):g} m is below {r_min:.3g} m "
                        f"({MIN_RADIUS_LEG_LENGTHS:g} leg lengths of this robot)")
        if 2 * abs(r) > MAX_EXTENT_LEG_LENGTHS * leg_length_m:
            raise _fail(option, spec, f"radius {abs(r):g} m is beyond "
                        f"{MAX_EXTENT_LEG_LENGTHS * leg_length_m / 2:.0f} m")
        n = max(64, min(MAX_SAMPLES // 2, math.ceil(2 * math.pi * abs(r) / SAMPLE_STEP_M)))
        if kind == "circle":
            dense = _circle_points(abs(r), r, n)
            key = dense[:: max(1, n // 4)][:4]
        else:
            first = _circle_points(abs(r), r, n)
            second = _circle_points(abs(r), -r, n)
            dense = np.vstack([first, second])
            key = np.vstack([first[:: max(1, n // 4)][:4], second[:: max(1, n // 4)][:4]])
        points, _, step = _resample(dense, True, SAMPLE_STEP_M)
        key_s = _arc_length_of(points, step, key)
        return _bounded(option, spec, PlannedPath(text, points, step, True, key, key_s),
                        leg_length_m)
    if Path(text).suffix.lower() in (".json", ".csv"):
        w = _read_file(option, spec, Path(text))
    elif ":" in text:
        raise _fail(option, spec, f"unknown path kind {head.strip()!r}")
    else:
        rows = [r.split(",") for r in text.split(";") if r.strip()]
        w = _parse_pairs(option, spec, rows)
    closed = _check_waypoints(option, spec, w, leg_length_m)
    core = w[:-1] if closed else w
    dense, index = catmull_rom(core, closed)
    points, s_dense, step = _resample(dense, closed, SAMPLE_STEP_M)
    return _bounded(option, spec,
                    PlannedPath(text, points, step, closed, core, s_dense[index]), leg_length_m)


def _arc_length_of(points: np.ndarray, step_m: float, key: np.ndarray) -> np.ndarray:
    """Arc length of the sample nearest each key point (for circles: exact to a step)."""
    d = np.linalg.norm(points[None, :, :] - key[:, None, :], axis=2)
    return np.argmin(d, axis=1) * step_m


def _bounded(option: str, spec: str, path: PlannedPath, leg_length_m: float) -> PlannedPath:
    cap = MAX_LENGTH_LEG_LENGTHS * leg_length_m
    if path.length_m > cap:
        raise _fail(option, spec, f"path is {path.length_m:.1f} m long, at most {cap:.0f} m "
                    f"({MAX_LENGTH_LEG_LENGTHS:g} leg lengths of this robot)")
    return path

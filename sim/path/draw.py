"""Pictures of a drive-sim run: the planned vs driven path as a PNG, and the video with the path
and the footprints drawn on the floor.

The video reuses `sim.render` (lighting, headless GL, the atomic MP4/GIF writer); the path is a
chain of thin flat boxes and every touchdown so far a small flat square, added to the `mjvScene`
as user geoms after `update_scene` (visual only). The camera follows the base (smoothed over
about a gait cycle) from above, far enough to show the path around the robot.
"""

from __future__ import annotations

import io
import itertools
from collections.abc import Iterator
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mujoco
import numpy as np
from matplotlib.figure import Figure

from robots.files import atomic_write_bytes
from sim.errors import RenderError, ReportError
from sim.model import SimModel
from sim.path.follow import FollowLog
from sim.render import (
    _ensure_offscreen_gl,
    _light_the_scene,
    _moving_average,
    write_video,
)

PATH_SEGMENTS = 300  # boxes drawn for the path
MAX_FOOTPRINTS_DRAWN = 1500  # the newest ones, when a long run has more
PATH_RGBA = np.array([1.0, 1.0, 1.0, 0.9])  # white: reads on any floor, unlike a body colour
FOOT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")
CAMERA_SMOOTHING_S = 1.0


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()


def _rgba(hex_colour: str, alpha: float) -> np.ndarray:
    h = hex_colour.lstrip("#")
    return np.array([int(h[i:i + 2], 16) / 255.0 for i in (0, 2, 4)] + [alpha])


def path_plot(log: FollowLog, foot_names: tuple[str, ...], title: str = "") -> bytes:
    """PNG: planned path, driven base path and footprints (top view); cross-track error and the
    commands over time."""
    fig = plt.figure(figsize=(12, 6))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.2, 1.0))
    ax = fig.add_subplot(grid[:, 0])
    p = log.path.points_m
    closed = np.vstack([p, p[:1]]) if log.path.closed else p
    ax.plot(closed[:, 0], closed[:, 1], "k--", lw=1.2, label="planned path")
    ax.plot(log.base_pos_m[:, 0], log.base_pos_m[:, 1], color="#c0392b", lw=1.0,
            label="driven (base)")
    prints = log.footprints()
    if prints:
        arr = np.array([(f, x, y) for _, f, x, y in prints])
        for f, name in enumerate(foot_names):
            sel = arr[:, 0] == f
            ax.scatter(arr[sel, 1], arr[sel, 2], s=4, color=FOOT_COLOURS[f % len(FOOT_COLOURS)],
                       alpha=0.5, label=f"footprints {name}" if len(foot_names) <= 6 else None)
    w = log.path.waypoints_m
    if not log.path.spec.startswith(("circle", "figure8")):
        ax.plot(w[:, 0], w[:, 1], "ko", ms=4, label="waypoints")
    ax.plot(*log.base_pos_m[0, :2], "g^", ms=8, label="start")
    ax.plot(*log.base_pos_m[-1, :2], "bs", ms=7, label="end")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    ax.set_title(title or log.path.spec)
    t = log.time_s
    ax1 = fig.add_subplot(grid[0, 1])
    e = np.where(log.driving, log.cross_track_m, np.nan) * 100.0
    ax1.plot(t, e, color="#c0392b", lw=0.8)
    ax1.axhline(0.0, color="k", lw=0.5)
    ax1.set_ylabel("cross-track [cm] (left +)")
    ax1.grid(alpha=0.3)
    ax2 = fig.add_subplot(grid[1, 1], sharex=ax1)
    ax2.plot(t, log.commanded[:, 0], label="vx [m/s] (blended)")
    ax2.plot(t, log.commanded[:, 1], label="vy [m/s]")
    ax2.plot(t, log.commanded[:, 2], label="yaw rate [rad/s]")
    ax2.plot(t, log.requested[:, 2], lw=0.6, alpha=0.6, label="yaw rate requested")
    ax2.set_xlabel("time [s]")
    ax2.legend(fontsize=7, loc="best")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    return _png(fig)


def write_path_plot(path: str | Path, log: FollowLog, foot_names: tuple[str, ...],
                    title: str = "") -> Path:
    p = Path(path)
    try:
        png = path_plot(log, foot_names, title)
    except Exception as exc:  # matplotlib errors are not user errors, but must not be tracebacks
        raise ReportError(f"cannot draw the path plot: {exc}") from exc
    atomic_write_bytes(p, png)
    return p


def _path_extent_m(log: FollowLog) -> float:
    p = log.path.points_m
    return float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))


def _draw_path(scene: mujoco.MjvScene, points: np.ndarray, width_m: float) -> None:
    """Thin flat boxes along the path (boxes: a capsule costs ~4× more to draw in software GL)."""
    for a, b in itertools.pairwise(points):
        if scene.ngeom >= scene.maxgeom:
            return
        d = b - a
        length = float(np.hypot(d[0], d[1]))
        if length <= 0.0:
            continue
        c, s = d / length
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        centre = np.array([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.001])
        mujoco.mjv_initGeom(scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_BOX,
                            np.array([0.5 * length + 0.5 * width_m, 0.5 * width_m, 0.0005]),
                            centre, rot.ravel(), PATH_RGBA)
        scene.ngeom += 1


def _draw_footprints(scene: mujoco.MjvScene, prints: list[tuple[float, int, float, float]],
                     radius_m: float) -> None:
    for _, f, x, y in prints:
        if scene.ngeom >= scene.maxgeom:
            return
        colour = _rgba(FOOT_COLOURS[f % len(FOOT_COLOURS)], 0.85)
        mujoco.mjv_initGeom(scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_BOX,
                            np.array([radius_m, radius_m, 0.0008]), np.array([x, y, 0.0012]),
                            np.eye(3).ravel(), colour)
        scene.ngeom += 1


def iter_frames(sim: SimModel, log: FollowLog, *, fps: float = 30.0, width: int = 640,
                height: int = 480, speed: float = 1.0) -> Iterator[np.ndarray]:
    """RGB frames of the whole run with the path and the footprints so far on the floor, played
    `speed` times faster than simulated time."""
    if not (width > 0 and height > 0 and fps > 0 and speed > 0):
        raise RenderError("video width, height, fps and speed must be positive")
    model = sim.model
    model.vis.global_.offwidth = max(width, model.vis.global_.offwidth)
    model.vis.global_.offheight = max(height, model.vis.global_.offheight)
    _light_the_scene(model)
    model.vis.quality.offsamples = 0
    model.light_castshadow[:] = 0
    model.mat_reflectance[:] = 0.0
    times = np.arange(log.time_s[0], log.time_s[-1] + 1e-9, speed / fps)
    idx = np.clip(np.searchsorted(log.time_s, times), 0, log.n_ticks - 1)
    _ensure_offscreen_gl()
    try:
        renderer = mujoco.Renderer(model, height=height, width=width, max_geom=10_000)
    except Exception as exc:
        raise RenderError(f"cannot create an offscreen OpenGL context: {exc}") from None
    robot = sim.robot
    leg = robot.leg_length_m
    window = max(1, round(CAMERA_SMOOTHING_S * fps / speed))
    look_x = _moving_average(log.base_pos_m[idx, 0], window)
    look_y = _moving_average(log.base_pos_m[idx, 1], window)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance = float(np.clip(0.9 * _path_extent_m(log), 7.0 * leg, 40.0 * leg))
    cam.azimuth = 240.0
    cam.elevation = -50.0
    step = max(1, log.path.n_points // PATH_SEGMENTS)
    pts = log.path.points_m[::step]
    if log.path.closed:
        pts = np.vstack([pts, log.path.points_m[:1]])
    else:
        pts = np.vstack([pts, log.path.points_m[-1:]])
    width_m = max(0.004, 0.05 * leg)
    prints = log.footprints()
    print_t = np.array([p[0] for p in prints])
    foot_r = max(robot.foot_radius_m, 0.1 * leg)
    data = mujoco.MjData(model)
    try:
        for frame, i in enumerate(idx):
            data.qpos[:] = log.qpos[i]
            mujoco.mj_forward(model, data)
            cam.lookat[:] = (look_x[frame], look_y[frame], robot.stance_base_height_m)
            renderer.update_scene(data, camera=cam)
            _draw_path(renderer.scene, pts, width_m)
            n = int(np.searchsorted(print_t, log.time_s[i], side="right"))
            _draw_footprints(renderer.scene, prints[max(0, n - MAX_FOOTPRINTS_DRAWN):n], foot_r)
            yield renderer.render().copy()
    finally:
        renderer.close()


def render_drive_video(path: str | Path, sim: SimModel, log: FollowLog, *,
                       fps: float = 30.0, width: int = 640, height: int = 480,
                       speed: float = 1.0) -> Path:
    """Write the run as MP4 or GIF (by suffix), atomically, `speed` × real time."""
    frames = iter_frames(sim, log, fps=fps, width=width, height=height, speed=speed)
    return write_video(path, frames, fps)

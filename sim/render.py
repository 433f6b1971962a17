"""Offscreen video of a run (MP4 or GIF): a camera gliding along with the robot at its walking
speed (smoothed, fixed height) over the lit floor grid, so its progress over the ground shows.

Rendering is headless: `MUJOCO_GL=egl` (set by `sim/__init__` before mujoco is imported). If
mujoco was imported earlier without it and there is no display, `_offscreen_context_class`
switches MuJoCo's renderer to EGL (then OSMesa) itself. Files are written atomically.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import imageio.v2 as imageio
import mujoco
import numpy as np

from robots.errors import OutputWriteError
from robots.files import atomic_path
from robots.mujoco_gl import load_gl_backend
from sim.errors import RenderError
from sim.model import SimModel
from sim.rollout import Trajectory

VIDEO_SUFFIXES = (".mp4", ".gif")


def _ensure_offscreen_gl() -> None:
    """Make mujoco.Renderer use a headless context when no display is available."""
    load_gl_backend()  # if `gaitsmith.cli` imported mujoco without it (`robots.mujoco_gl`)
    from mujoco.rendering.classic import gl_context

    chosen = getattr(gl_context, "_MUJOCO_GL", "")
    if chosen in ("egl", "osmesa") or os.environ.get("DISPLAY"):
        return
    for module in ("mujoco.egl", "mujoco.osmesa"):
        try:
            ctx = __import__(module, fromlist=["GLContext"]).GLContext
        except Exception:  # backend library missing: try the next one
            continue
        gl_context.GLContext = ctx  # the renderer looks the class up when it is constructed
        return


#: how much of the body's forward motion the camera's smoothing averages out [s]: about a gait
#: cycle, so the camera glides along at the walking speed while steps and sway stay visible
CAMERA_SMOOTHING_S = 1.0

#: headlight (a light at the camera) that keeps any robot and floor readable whatever its MJCF
#: lights; visual only, physics is unaffected
HEADLIGHT_AMBIENT = 0.45
HEADLIGHT_DIFFUSE = 0.6
HEADLIGHT_SPECULAR = 0.15


#: self-illumination given to the materials of ground planes, so a dark floor texture's grid
#: still reads in the video (visual only)
FLOOR_EMISSION = 0.35


def _light_the_scene(model: mujoco.MjModel) -> None:
    """Brighten the render: the MJCF's own lights stay, the headlight is switched on and made
    brighter (MuJoCo's default 0.1 ambient / 0.4 diffuse left most models very dark), and the
    ground planes' materials glow a little so the floor grid shows."""
    planes = model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE
    for mat in set(model.geom_matid[planes].tolist()) - {-1}:
        model.mat_emission[mat] = max(float(model.mat_emission[mat]), FLOOR_EMISSION)
    light = model.vis.headlight
    light.active = 1
    light.ambient[:] = np.maximum(light.ambient, HEADLIGHT_AMBIENT)
    light.diffuse[:] = np.maximum(light.diffuse, HEADLIGHT_DIFFUSE)
    light.specular[:] = np.maximum(light.specular, HEADLIGHT_SPECULAR)


def _moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Centred moving average with the ends held (no shrink towards zero at the edges)."""
    if window <= 1 or values.size == 0:
        return values.astype(float)
    pad = window // 2
    head, tail = np.full(pad, values[0]), np.full(window - 1 - pad, values[-1])
    padded = np.concatenate([head, values, tail])
    return np.convolve(padded, np.ones(window) / window, mode="valid")


def camera_lookat(sim: SimModel, traj: Trajectory, idx: np.ndarray, fps: float) -> np.ndarray:
    """Per-frame camera target (F × 3): the body's x and y smoothed over `CAMERA_SMOOTHING_S`,
    z at the stance height — the camera glides at the walking speed and does not copy the body's
    bobbing or sway, so the floor grid shows the robot's progress; a robot drifting sideways or
    turning stays in the frame (the distance marks show the drift)."""
    adr = int(sim.model.jnt_qposadr[0])  # the root (free) joint: x, y, z, quaternion
    x = traj.qpos[idx, adr]
    y = traj.qpos[idx, adr + 1]
    window = max(1, round(CAMERA_SMOOTHING_S * fps))
    lookat = np.empty((len(idx), 3))
    lookat[:, 0] = _moving_average(x, window)
    lookat[:, 1] = _moving_average(y, window)
    lookat[:, 2] = sim.robot.stance_base_height_m
    return lookat


#: spacing of the distance marks drawn on the floor from where the clip starts [m]
DISTANCE_MARK_M = 0.25


def distance_marks(start_x_m: float, end_x_m: float, spacing_m: float = DISTANCE_MARK_M
                   ) -> list[tuple[float, str]]:
    """(x, label) of lines across the path every `spacing_m` from the clip's start x."""
    lo, hi = sorted((start_x_m, end_x_m))
    n_back = int(np.floor((lo - start_x_m) / spacing_m)) - 1
    n_ahead = int(np.ceil((hi - start_x_m) / spacing_m)) + 1
    return [(start_x_m + k * spacing_m, f"{k * spacing_m:g} m") for k in range(n_back, n_ahead + 1)]


def _draw_marks(scene: mujoco.MjvScene, marks: list[tuple[float, str]], y_m: float,
                half_width_m: float) -> None:
    """Thin light lines on the floor (z = 0) across the walking direction, labelled."""
    for x, label in marks:
        if scene.ngeom + 2 > scene.maxgeom:
            return
        mujoco.mjv_initGeom(
            scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_BOX,
            np.array([0.004, half_width_m, 0.0005]), np.array([x, y_m, 0.0005]),
            np.eye(3).ravel(), np.array([1.0, 1.0, 1.0, 0.7]))
        # the label at the line's camera end (the camera looks from −y), clear of the robot
        label_geom = scene.geoms[scene.ngeom + 1]
        mujoco.mjv_initGeom(
            label_geom, mujoco.mjtGeom.mjGEOM_SPHERE, np.array([0.001, 0.0, 0.0]),
            np.array([x, y_m - 0.9 * half_width_m, 0.001]), np.eye(3).ravel(),
            np.array([0.0, 0.0, 0.0, 0.0]))
        label_geom.label = label
        scene.ngeom += 2


def _camera(sim: SimModel) -> mujoco.MjvCamera:
    """A free camera three-quarters from the side, slightly above (targets set per frame)."""
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    robot = sim.robot
    cam.distance = float(max(7.0 * robot.leg_length_m, 3.0 * sim.model.stat.extent * 0.5, 0.5))
    cam.azimuth = 120.0
    cam.elevation = -25.0
    cam.lookat[:] = (0.0, 0.0, robot.stance_base_height_m)
    return cam


def render_frames(sim: SimModel, traj: Trajectory, **kwargs: Any) -> list[np.ndarray]:
    """All frames as a list (see `iter_frames`)."""
    return list(iter_frames(sim, traj, **kwargs))


def iter_frames(
    sim: SimModel,
    traj: Trajectory,
    *,
    fps: float = 30.0,
    width: int = 640,
    height: int = 480,
    start_s: float = 0.0,
    duration_s: float | None = None,
    high_quality: bool = False,
) -> Iterator[np.ndarray]:
    """RGB frames (H, W, 3) at `fps` of the logged run between `start_s` and `+duration_s`.

    Headless machines render with software GL (Mesa llvmpipe), slow with MuJoCo's defaults:
    unless `high_quality`, frames are drawn without multisampling, floor reflections or shadows
    (≈ 10× faster: ~12 ms instead of ~120 ms per 640×480 frame on one llvmpipe core pair).
    """
    if not (width > 0 and height > 0 and fps > 0):
        raise RenderError("video width, height and fps must be positive")
    model = sim.model
    if width > model.vis.global_.offwidth or height > model.vis.global_.offheight:
        model.vis.global_.offwidth = max(width, model.vis.global_.offwidth)
        model.vis.global_.offheight = max(height, model.vis.global_.offheight)
    _light_the_scene(model)
    if not high_quality:  # visual-only fields; physics is unaffected
        model.vis.quality.offsamples = 0
        model.light_castshadow[:] = 0
        model.mat_reflectance[:] = 0.0
    end = traj.time_s[-1] if duration_s is None else min(traj.time_s[-1], start_s + duration_s)
    times = np.arange(start_s, end + 1e-9, 1.0 / fps)
    idx = np.clip(np.searchsorted(traj.time_s, times), 0, traj.n_steps - 1)
    _ensure_offscreen_gl()
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:
        raise RenderError(
            f"cannot create an offscreen OpenGL context (MUJOCO_GL="
            f"{os.environ.get('MUJOCO_GL', '')!r}): {exc}"
        ) from None
    data = mujoco.MjData(model)
    cam = _camera(sim)
    lookat = camera_lookat(sim, traj, idx, fps)
    adr = int(model.jnt_qposadr[0])
    marks = distance_marks(float(traj.qpos[idx[0], adr]), float(traj.qpos[idx[-1], adr])) \
        if len(idx) else []
    try:
        for frame, i in enumerate(idx):
            data.qpos[:] = traj.qpos[i]
            mujoco.mj_forward(model, data)
            cam.lookat[:] = lookat[frame]
            renderer.update_scene(data, camera=cam)
            _draw_marks(renderer.scene, marks, float(lookat[frame, 1]), 2.0 * cam.distance / 7.0)
            yield renderer.render().copy()
    finally:
        renderer.close()


def _check_mp4(tmp: Path, n_frames: int, target: Path) -> None:
    """ffmpeg's exit status is not checked by imageio: a full disk or a killed encoder leaves a
    truncated file. Decode it and count the frames before it may replace `target`."""
    import imageio_ffmpeg

    try:
        decoded, _ = imageio_ffmpeg.count_frames_and_secs(str(tmp))
    except Exception:  # ffmpeg cannot read it at all
        decoded = 0
    if decoded != n_frames:
        free_kib = shutil.disk_usage(tmp.parent).free // 1024
        raise RenderError(
            f"{target}: the video encoder wrote {decoded} of {n_frames} frames (disk full? "
            f"{free_kib} KiB free); no video written")


def write_video(path: str | Path, frames: Iterable[np.ndarray], fps: float = 30.0) -> Path:
    """Write frames as MP4 (H.264 via imageio-ffmpeg) or GIF, chosen by suffix; atomic.

    MP4 frames are piped to ffmpeg as they come, so encoding overlaps rendering.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise RenderError(f"{p}: video must end in {' or '.join(VIDEO_SUFFIXES)}")
    with atomic_path(p) as tmp:  # an OSError of our own (folder, rename) is OutputWriteError
        try:
            if suffix == ".gif":
                frames = list(frames)
                if not frames:
                    raise RenderError(f"{p}: no frames to write")
                imageio.mimsave(tmp, frames, format="GIF", duration=1.0 / fps, loop=0)  # type: ignore[arg-type]
            else:
                count = 0
                with imageio.get_writer(
                    tmp,
                    format="FFMPEG",
                    fps=fps,
                    codec="libx264",  # type: ignore[arg-type]
                    quality=7,
                    macro_block_size=1,
                    pixelformat="yuv420p",
                    ffmpeg_params=["-preset", "veryfast"],
                ) as writer:
                    for f in frames:
                        writer.append_data(f)  # type: ignore[attr-defined]
                        count += 1
                if not count:
                    raise RenderError(f"{p}: no frames to write")
                _check_mp4(tmp, count, p)
        except (RenderError, OutputWriteError):
            raise
        except Exception as exc:  # imageio/ffmpeg: the first line says what failed
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            if "Broken pipe" in first:  # ffmpeg died: usually it could not write its output
                free_kib = shutil.disk_usage(tmp.parent).free // 1024
                first = f"the encoder (ffmpeg) stopped; disk full? {free_kib} KiB free"
            raise RenderError(f"{p}: cannot write video: {first}") from None
    return p


def render_video(
    path: str | Path,
    sim: SimModel,
    traj: Trajectory,
    *,
    fps: float = 30.0,
    width: int = 640,
    height: int = 480,
    start_s: float = 0.0,
    duration_s: float | None = None,
    high_quality: bool = False,
) -> Path:
    """Render the run and write it to `path` (.mp4 or .gif)."""
    frames = iter_frames(
        sim,
        traj,
        fps=fps,
        width=width,
        height=height,
        start_s=start_s,
        duration_s=duration_s,
        high_quality=high_quality,
    )
    return write_video(path, frames, fps)

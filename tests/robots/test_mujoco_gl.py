"""`robots.mujoco_gl`: mujoco imported without its GL backend, which rendering loads later."""

from __future__ import annotations

import os
import subprocess
import sys

CODE = r"""
import os, sys
from robots.mujoco_gl import defer_gl_backend, load_gl_backend
defer_gl_backend()
import mujoco
from mujoco.rendering.classic import gl_context
print(os.environ.get("MUJOCO_GL"), "mujoco.egl" in sys.modules, hasattr(gl_context, "GLContext"))
load_gl_backend()
print(gl_context._MUJOCO_GL, "mujoco.egl" in sys.modules, mujoco.GLContext.__module__)
model = mujoco.MjModel.from_xml_string(
    "<mujoco><worldbody><light pos='0 0 1'/><geom type='sphere' size='0.1' rgba='1 0 0 1'/>"
    "</worldbody></mujoco>")
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
renderer = mujoco.Renderer(model, height=32, width=32)
renderer.update_scene(data)
print(renderer.render().max() > 0)
"""


def test_mujoco_renders_after_a_deferred_gl_import() -> None:
    env = {**os.environ, "MUJOCO_GL": "egl"}
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True,
                         check=True, timeout=120, env=env)
    lines = out.stdout.strip().splitlines()
    assert lines[0] == "egl False False"  # the variable is the user's again; no EGL yet
    assert lines[1] == "egl True mujoco.egl"
    assert lines[2] == "True"


def test_the_gaitsmith_cli_defers_it() -> None:
    code = ("import sys, gaitsmith.cli, mujoco\n"
            "print('mujoco.egl' in sys.modules, 'OpenGL' in sys.modules)\n")
    env = {**os.environ, "MUJOCO_GL": "egl"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120, env=env)
    assert out.stdout.strip() == "False False"


def test_sim_render_loads_the_deferred_backend_before_rendering() -> None:
    """`sim.render` (videos) loads the backend itself before creating a renderer."""
    code = (
        "import sys\n"
        "from robots.mujoco_gl import defer_gl_backend\n"
        "defer_gl_backend()\n"
        "import mujoco\n"
        "from sim.render import _ensure_offscreen_gl\n"
        "before = 'mujoco.egl' in sys.modules\n"
        "_ensure_offscreen_gl()\n"
        "print(before, 'mujoco.egl' in sys.modules, mujoco.GLContext.__module__)\n"
    )
    env = {**os.environ, "MUJOCO_GL": "egl"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120, env=env)
    assert out.stdout.strip() == "False True mujoco.egl"

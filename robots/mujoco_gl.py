"""MuJoCo imported without its OpenGL backend until something renders (issue #16: start-up time).

`import mujoco` also imports the OpenGL backend that ``MUJOCO_GL`` names
(`mujoco.rendering.classic.gl_context`): with ``MUJOCO_GL=egl``, the EGL context and PyOpenGL,
≈ 0.05 s of every command, though planning and simulating never render. `defer_gl_backend`
(called by `gaitsmith.cli` before anything imports mujoco) makes the first ``import mujoco`` see
``MUJOCO_GL=disable`` — the value mujoco itself offers for "no rendering" — and restores the
variable right after; `load_gl_backend` (called by `sim.render` before it creates a
`mujoco.Renderer`) then imports the backend that ``MUJOCO_GL`` named at that first import,
as mujoco's import would have. Nothing changes where mujoco was imported before
`defer_gl_backend`, or where no `defer_gl_backend` was called.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import os
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import Any

_VARIABLE = "MUJOCO_GL"
_DISABLED = "disable"

#: whether mujoco was imported with its GL backend left out (`load_gl_backend` has work to do),
#: and the ``MUJOCO_GL`` it would have seen then (None: unset)
_deferred: dict[str, bool] = {"mujoco": False}
_seen: dict[str, str | None] = {_VARIABLE: None}


class _Loader(importlib.abc.Loader):
    """mujoco's own loader, run with ``MUJOCO_GL=disable`` in the environment."""

    def __init__(self, loader: Any) -> None:
        self._loader = loader

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        module: ModuleType | None = self._loader.create_module(spec)
        return module

    def exec_module(self, module: ModuleType) -> None:
        chosen = os.environ.get(_VARIABLE)
        _seen[_VARIABLE] = chosen
        _set_variable(_DISABLED)
        try:
            self._loader.exec_module(module)
        finally:
            _set_variable(chosen)
        _deferred["mujoco"] = True

    def __getattr__(self, name: str) -> Any:  # resource readers etc.: mujoco's loader's
        return getattr(self._loader, name)


class _Finder(importlib.abc.MetaPathFinder):
    """Finds mujoco once (the first import), with `_Loader` around its loader."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname != "mujoco":
            return None
        sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None:
            return spec
        spec.loader = _Loader(spec.loader)
        return spec


def _set_variable(value: str | None) -> None:
    if value is None:
        os.environ.pop(_VARIABLE, None)
    else:
        os.environ[_VARIABLE] = value


def defer_gl_backend() -> None:
    """Make the first ``import mujoco`` leave the GL backend out (no effect if mujoco is
    imported already, or the variable disables rendering anyway)."""
    if "mujoco" in sys.modules or any(isinstance(f, _Finder) for f in sys.meta_path):
        return
    sys.meta_path.insert(0, _Finder())


def load_gl_backend() -> None:
    """Import the GL backend that ``MUJOCO_GL`` named when mujoco was imported, if
    `defer_gl_backend` left it out: what mujoco's import would have imported then."""
    if not _deferred["mujoco"]:
        return
    from mujoco.rendering.classic import gl_context

    if getattr(gl_context, "_MUJOCO_GL", None) != _DISABLED:
        _deferred["mujoco"] = False
        return
    now = os.environ.get(_VARIABLE)
    _set_variable(_seen[_VARIABLE])
    try:
        importlib.reload(gl_context)  # mujoco's own choice, from the variable as it was
    finally:
        _set_variable(now)
    _deferred["mujoco"] = False
    context = getattr(gl_context, "GLContext", None)
    if context is not None:
        import mujoco

        mujoco.GLContext = context  # what `from …gl_context import *` in mujoco gives
        renderer = sys.modules.get("mujoco.rendering.classic.renderer")
        if renderer is not None:
            renderer.GLContext = context  # type: ignore[attr-defined]

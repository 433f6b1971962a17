"""Plain option values converted without pydantic (issue #16: a command's start-up time).

typer 0.29 converts every option's value — the defaults too — with a pydantic ``TypeAdapter``
built per option (`typer._coercion.build_runtime_param`); importing pydantic for that costs
≈ 0.1 s of every `gaitsmith` command. `install` makes typer convert the plain cases itself —
a ``str``, ``bool``, ``int``, ``float`` or ``Path`` option without parser, range or choices,
given an unambiguous value — to the value pydantic returns for them, and hand every other value (a
typo, ``1_000``, ``inf``, an option with a range…) to typer's own pydantic conversion, so
results and error messages stay typer's. `tests/gaitsmith/test_option_coercion.py` checks the
fast path against typer's adapters.

If typer's internals are not the ones this was written for, `install` leaves typer alone.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: decimal numbers that Python's ``float`` and pydantic's lax float parse to the same value
_FLOAT = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
#: decimal integers that Python's ``int`` and pydantic's lax int parse to the same value
_INT = re.compile(r"[+-]?\d{1,100}")

_NO_FAST_PATH = object()


def fast_value(annotation: Any, value: Any) -> Any:
    """`value` converted as typer's pydantic adapter would, or `_NO_FAST_PATH` when unsure.

    Only for ``str``, ``bool``, ``int`` and ``float`` annotations (no parser, range or choices)."""
    kind = type(value)
    if annotation is str:
        return value if kind is str else _NO_FAST_PATH
    if annotation is bool:
        return value if kind is bool else _NO_FAST_PATH
    if annotation is int:
        if kind is int:
            return value
        if kind is str and _INT.fullmatch(value):
            return int(value)
        return _NO_FAST_PATH
    if annotation is float:
        if kind is float:
            return value
        if kind is int:
            return float(value)
        if kind is str and _FLOAT.fullmatch(value):
            return float(value)
        return _NO_FAST_PATH
    return _NO_FAST_PATH


def install() -> bool:
    """Make typer convert plain option values without pydantic; False if typer's internals
    differ from typer 0.29's (then nothing is changed)."""
    try:
        from typer import _coercion, core
        from typer._param_types import coerce_cli_path, routes_to_path
    except ImportError:
        return False
    parameter = getattr(core, "_TyperParameter", None)
    needed = ("get_runtime_param", "type_descriptor", "_runtime_param")
    if parameter is None or not all(
        hasattr(parameter, name) or name in getattr(parameter, "__annotations__", {})
        for name in needed
    ) or not hasattr(_coercion, "RuntimeParam") or not hasattr(_coercion, "build_runtime_param"):
        return False
    if getattr(parameter.get_runtime_param, "_gaitsmith_fast", False):
        return True

    @dataclass(frozen=True)
    class FastRuntimeParam(_coercion.RuntimeParam):  # type: ignore[misc, name-defined]
        """A plain option: its common values converted here, the rest by typer's adapter."""

        descriptor: Any = None
        is_path: bool = False
        _typer: list[Any] = field(default_factory=list)  # typer's own, built when needed

        def _coerce_value(self, value: Any, param: Any, ctx: Any) -> Any:
            if self.is_path:
                if isinstance(value, str) and value:
                    value = Path(value)  # what pydantic makes of a non-empty string
                if isinstance(value, Path):  # typer's path adapter: this call on the Path
                    return coerce_cli_path(
                        value, self.parameter_info, path_type=self.annotation, param=param,
                        ctx=ctx,
                    )
            else:
                result = fast_value(self.annotation, value)
                if result is not _NO_FAST_PATH:
                    return result
            if not self._typer:
                self._typer.append(_coercion.build_runtime_param(self.descriptor))
            return self._typer[0]._coerce_value(value, param=param, ctx=ctx)

    def plain(descriptor: Any) -> tuple[bool, bool]:
        """(fast path applies, it is a path option)."""
        info = descriptor.parameter_info
        if (
            descriptor.file_annotation is not None
            or info.parser is not None
            or descriptor.is_list
            or descriptor.is_tuple
            or descriptor.choices is not None
        ):
            return False, False
        annotation = descriptor.annotation
        if annotation is bool:
            return True, False
        if annotation in (str, int, float):
            unranged = info.min is None and info.max is None and not info.clamp
            return unranged, False
        if annotation is Path and routes_to_path(annotation, info) and info.path_type is None:
            return True, True
        return False, False

    def get_runtime_param(self: Any) -> Any:
        if self._runtime_param is None:
            descriptor = self.type_descriptor
            fast, is_path = plain(descriptor)
            if fast:
                self._runtime_param = FastRuntimeParam(
                    parameter_info=descriptor.parameter_info, annotation=descriptor.annotation,
                    descriptor=descriptor, is_path=is_path,
                )
            else:
                self._runtime_param = _coercion.build_runtime_param(descriptor)
        return self._runtime_param

    get_runtime_param._gaitsmith_fast = True  # type: ignore[attr-defined]
    parameter.get_runtime_param = get_runtime_param
    return True

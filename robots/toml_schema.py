"""Bounded, typed reading of the robot folder's TOML files (robot.toml, servo catalogues).

Every value a loader takes goes through one of these checks, so a fuzzed or hand-mangled file
fails with a `RobotConfigError` naming the file, the full field path and what to do — never an
OverflowError, RecursionError, MemoryError or a value that is silently absurd (issue #12).
"""

from __future__ import annotations

import math
import sys
from typing import Any

from robots.errors import RobotConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

MAX_TOML_BYTES = 1 << 20  # 1 MiB: a robot.toml for a 100-joint robot is ~15 kB
MAX_TOML_DEPTH = 8  # robot.toml nests [joints.NAME].limits_deg: depth 3
MAX_TABLE_ENTRIES = 512  # joints, legs or servo models in one file
MAX_STRING_CHARS = 256  # names and descriptions
MAX_INT = 10**9  # larger than any tick, baud or id a servo uses, far below float overflow


def read_toml(text: str, file: str) -> dict[str, Any]:
    """Parse TOML text that must be a small, shallow document."""
    if len(text) > MAX_TOML_BYTES:
        raise RobotConfigError(
            file, "<file>", f"is {len(text)} characters; a robot's TOML is at most {MAX_TOML_BYTES}"
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RobotConfigError(file, "<toml>", f"not valid TOML: {exc}") from None
    except RecursionError:
        raise RobotConfigError(
            file, "<toml>", f"nested too deeply (at most {MAX_TOML_DEPTH} levels)"
        ) from None
    except ValueError as exc:  # e.g. an integer beyond Python's 4300-digit conversion limit
        raise RobotConfigError(file, "<toml>", f"not valid TOML: {exc}") from None
    _check_depth(file, data, "<top>", 0)
    return data


def _check_depth(file: str, node: Any, where: str, depth: int) -> None:
    if depth > MAX_TOML_DEPTH:
        raise RobotConfigError(file, where, f"nested too deeply (at most {MAX_TOML_DEPTH} levels)")
    if isinstance(node, dict):
        if len(node) > MAX_TABLE_ENTRIES:
            raise RobotConfigError(
                file, where, f"has {len(node)} entries; at most {MAX_TABLE_ENTRIES}"
            )
        for k, v in node.items():
            _check_depth(file, v, k if where == "<top>" else f"{where}.{k}", depth + 1)
    elif isinstance(node, list):
        if len(node) > MAX_TABLE_ENTRIES:
            raise RobotConfigError(
                file, where, f"has {len(node)} items; at most {MAX_TABLE_ENTRIES}"
            )
        for i, v in enumerate(node):
            _check_depth(file, v, f"{where}[{i}]", depth + 1)


def check_keys(file: str, where: str, table: dict[str, Any], allowed: set[str]) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        if where == "<top>":
            path, what = f"[{unknown[0]}]", "table"
            shown = ", ".join(f"[{a}]" for a in sorted(allowed))
        else:
            path, what, shown = f"{where}.{unknown[0]}", "field", ", ".join(sorted(allowed))
        raise RobotConfigError(file, path, f"unknown {what}; allowed: {shown} (check spelling)")


def number(
    file: str,
    where: str,
    value: Any,
    lo: float,
    hi: float,
    *,
    lo_open: bool = False,
    unit: str = "",
) -> float:
    """A TOML integer or float in [lo, hi] ((lo, hi] with `lo_open`), as a float."""
    rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]{' ' + unit if unit else ''}"
    if value is None:
        raise RobotConfigError(file, where, f"missing; give a number in {rng}")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RobotConfigError(
            file, where, f"must be a number in {rng}, got {type(value).__name__} {value!r:.40}"
        )
    if isinstance(value, int) and abs(value) > 10**15:
        raise RobotConfigError(file, where, f"must be a number in {rng}, got a huge integer")
    v = float(value)
    if not math.isfinite(v) or v > hi or v < lo or (lo_open and v <= lo):
        raise RobotConfigError(file, where, f"must be a number in {rng}, got {value!r}")
    return v


def integer(file: str, where: str, value: Any, lo: int, hi: int) -> int:
    """A TOML integer in [lo, hi] (floats, even 1.0, are refused: ticks and ids are counts)."""
    if value is None:
        raise RobotConfigError(file, where, f"missing; give an integer in [{lo}, {hi}]")
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        shown = "a huge integer" if isinstance(value, int) and abs(value) > MAX_INT else repr(value)
        raise RobotConfigError(file, where, f"must be an integer in [{lo}, {hi}], got {shown:.60}")
    return value


def string(file: str, where: str, value: Any, *, allow_empty: bool = False) -> str:
    if value is None:
        raise RobotConfigError(file, where, "missing; give a string")
    if not isinstance(value, str):
        raise RobotConfigError(file, where, f"must be a string, got {type(value).__name__}")
    if not allow_empty and not value.strip():
        raise RobotConfigError(file, where, "must not be empty")
    if len(value) > MAX_STRING_CHARS:
        raise RobotConfigError(file, where, f"longer than {MAX_STRING_CHARS} characters")
    return value


def table(file: str, where: str, value: Any, *, required: bool = True) -> dict[str, Any]:
    if value is None and not required:
        return {}
    if not isinstance(value, dict):
        raise RobotConfigError(
            file, where, "missing; add the table" if value is None else "must be a table"
        )
    if required and not value:
        raise RobotConfigError(file, where, "is empty")
    return value

"""Atomic output files: write to a temp file in the same folder, then rename over the target.

A crash, a full disk or an exception mid-write leaves the old file (or none), never a
half-written one. Temp files get the permissions a plain `open(path, "w")` would (0666 minus the
umask) instead of mkstemp's private 0600, so outputs stay readable by the user's other tools.

Temp files are named `.<target name>.<pid>.<random>.tmp<suffix>` beside their target. A process
killed mid-write (SIGKILL, power loss) cannot remove its own; the next write of the same target
removes those left by processes that no longer run and that predate this one
(`remove_stale_temps`). Every failure is an `OutputWriteError` naming the file.
"""

from __future__ import annotations

import errno
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from robots.errors import OutputWriteError

#: when this process started writing outputs: temp files older than this are not its own
_RUN_STARTED_S = time.time()

#: below this much free space an output folder counts as full (checked before long runs)
MIN_FREE_BYTES = 1 << 20


def _default_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def _temp_prefix(target: Path) -> str:
    return f".{target.name}."


def _temp_suffix(target: Path) -> str:
    return f".tmp{target.suffix}"


def _pid_running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return True


def _owner_pid(temp_name: str, target: Path) -> int | None:
    middle = temp_name[len(_temp_prefix(target)) : -len(_temp_suffix(target))]
    pid, _, _ = middle.partition(".")
    return int(pid) if pid.isdigit() else None


def remove_stale_temps(path: str | Path) -> list[Path]:
    """Remove the temp files of `path` left behind by killed writers; returns those removed.

    A temp file is stale when it is older than this process and its writer (the pid in its
    name) no longer runs; temp files without a pid (older gaitsmith versions) only need to be
    older than this process.
    """
    target = Path(path)
    removed: list[Path] = []
    if not target.parent.is_dir():
        return removed
    prefix, suffix = _temp_prefix(target), _temp_suffix(target)
    for candidate in target.parent.iterdir():
        name = candidate.name
        if not (name.startswith(prefix) and name.endswith(suffix)) or name == target.name:
            continue
        try:
            if candidate.stat().st_mtime >= _RUN_STARTED_S or not candidate.is_file():
                continue
            pid = _owner_pid(name, target)
            if pid is not None and pid != os.getpid() and _pid_running(pid):
                continue
            candidate.unlink()
        except OSError:  # gone meanwhile, or not ours to remove: leave it
            continue
        removed.append(candidate)
    return removed


def _cannot_write(path: Path, exc: OSError) -> OutputWriteError:
    reason = exc.strerror or str(exc)
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        reason += " (free some space or write elsewhere)"
    return OutputWriteError(f"{path}: cannot write: {reason}")


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temp path beside `path` (same suffix); on success it replaces `path`.

    The folder is created if needed; an `OSError` while creating, writing (in the `with` body)
    or renaming becomes an `OutputWriteError`, and the temp file is removed in every case.
    """
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        blocked = f"{p}: cannot create folder {p.parent}: a file is in the way"
        raise OutputWriteError(blocked) from None
    except OSError as exc:
        raise _cannot_write(p, exc) from None
    try:
        remove_stale_temps(p)
        fd, tmp_name = tempfile.mkstemp(
            prefix=f"{_temp_prefix(p)}{os.getpid()}.", suffix=_temp_suffix(p), dir=p.parent
        )
        os.close(fd)
    except OSError as exc:
        raise _cannot_write(p, exc) from None
    tmp = Path(tmp_name)
    try:
        os.chmod(tmp, _default_mode())
        yield tmp
        os.replace(tmp, p)
    except OutputWriteError:
        raise
    except OSError as exc:
        raise _cannot_write(p, exc) from None
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write `data` to `path` via a temp file + fsync + os.replace: never a half-written file."""
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write `text` to `path` via a temp file + fsync + os.replace: never a half-written file."""
    atomic_write_bytes(path, text.encode("utf-8"))


def check_writable(path: str | Path, *, directory: bool = False,
                   min_free_bytes: int = MIN_FREE_BYTES) -> Path:
    """Fail now, before a long run, if `path` could not be written later.

    `path` is an output file (or, with `directory`, an output folder). Its folder must exist or
    be creatable below the nearest existing ancestor, which must be a folder where a file can
    be created (probed with a temp file: root passes permission bits, not read-only mounts),
    with at least `min_free_bytes` free. Nothing is created except the removed probe.
    """
    p = Path(path)
    if p.exists() and not directory and p.is_dir():
        raise OutputWriteError(f"{p}: is a folder, expected a file name")
    if directory and p.exists() and not p.is_dir():
        raise OutputWriteError(f"{p}: is a file, expected a folder")
    folder = p if directory else p.parent
    existing = folder.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise OutputWriteError(f"{p}: cannot create folder {folder}: {existing} is a file")
    try:
        fd, probe = tempfile.mkstemp(prefix=".gaitsmith-probe.", suffix=".tmp", dir=existing)
        try:
            os.write(fd, b"\n")
        finally:
            os.close(fd)
            os.unlink(probe)
        free = shutil.disk_usage(existing).free
    except OSError as exc:
        raise OutputWriteError(
            f"{p}: cannot create files in {existing}: {exc.strerror or exc}"
        ) from None
    if free < min_free_bytes:
        raise OutputWriteError(
            f"{p}: the disk holding {existing} is full ({free // 1024} KiB free, need "
            f"{min_free_bytes // 1024} KiB); free some space or write elsewhere"
        )
    return p

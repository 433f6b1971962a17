"""Atomic output files: temp + rename, typed errors, no litter, stale temps of killed writers."""

from __future__ import annotations

import errno
import os
import time
from pathlib import Path

import pytest

from robots import files
from robots.errors import OutputWriteError, RobotsError
from robots.files import atomic_path, atomic_write_text, check_writable, remove_stale_temps


def _old(path: Path) -> Path:
    past = time.time() - 3600
    os.utime(path, (past, past))
    return path


def _dead_pid() -> int:
    pid = 4_000_000  # above Linux's pid_max default: no such process
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    return pid


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "g.json"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("crash mid-write")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.json"]


def test_full_disk_is_an_output_write_error_naming_the_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files.os, "fsync", full)  # what a full disk reports on write-back
    target = tmp_path / "g.json"
    target.write_text("old")
    with pytest.raises(OutputWriteError, match=r"g\.json: cannot write: No space left") as err:
        atomic_write_text(target, "new")
    assert isinstance(err.value, RobotsError) and isinstance(err.value, OSError)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.json"]


def test_temp_names_are_recognisable(tmp_path: Path) -> None:
    with atomic_path(tmp_path / "v.mp4") as tmp:
        assert tmp.parent == tmp_path
        assert tmp.name.startswith(f".v.mp4.{os.getpid()}.") and tmp.name.endswith(".tmp.mp4")
        tmp.write_bytes(b"x")


def test_stale_temps_of_killed_writers_are_removed(tmp_path: Path) -> None:
    dead = _dead_pid()
    killed = tmp_path / f".v.mp4.{dead}.abcd1234.tmp.mp4"  # SIGKILLed writer
    legacy = tmp_path / ".v.mp4.k2j3h4g5.tmp.mp4"  # an older gaitsmith's temp (no pid)
    alive = tmp_path / f".v.mp4.{os.getppid()}.zzzz.tmp.mp4"  # a writer still running
    fresh = tmp_path / f".v.mp4.{dead}.new.tmp.mp4"  # newer than this run: not ours to judge
    other = tmp_path / f".w.mp4.{dead}.abcd.tmp.mp4"  # another target's temp
    for p in (killed, legacy, alive, other):
        p.write_bytes(b"junk")
        _old(p)
    fresh.write_bytes(b"junk")
    os.utime(fresh, (time.time() + 60, time.time() + 60))
    atomic_write_text(tmp_path / "v.mp4", "video")
    assert not killed.exists() and not legacy.exists()
    assert alive.exists() and fresh.exists() and other.exists()
    assert remove_stale_temps(tmp_path / "v.mp4") == []


def test_check_writable_as_root_too(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Root ignores permission bits (chmod 0o555 does not stop it): what does fail for root is a
    file where a folder should be, a pseudo file system, and a full disk."""
    blocker = tmp_path / "notadir"
    blocker.write_text("")
    with pytest.raises(OutputWriteError, match="is a file"):
        check_writable(blocker / "out" / "g.json")
    with pytest.raises(OutputWriteError, match="cannot create files in /proc"):
        check_writable(Path("/proc/gaitsmith-test/g.json"))
    with pytest.raises(OutputWriteError, match="is a folder"):
        check_writable(tmp_path)
    with pytest.raises(OutputWriteError, match="is a file, expected a folder"):
        check_writable(blocker, directory=True)
    assert check_writable(tmp_path / "new" / "deeper" / "g.json")  # creatable: fine
    assert not (tmp_path / "new").exists()  # … and nothing was created
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notadir"]  # probe removed

    class Usage:
        free = 10_000

    monkeypatch.setattr(files.shutil, "disk_usage", lambda path: Usage())
    with pytest.raises(OutputWriteError, match="is full"):
        check_writable(tmp_path / "g.json")

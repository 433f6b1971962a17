"""The background compile of a robot's knot derivatives (`planner.nlp.background_compile`): a
"knot" build that finds no compiled entry starts one detached compile per key, guarded by a lock
across processes, bounded by a record of its attempts, off by a switch, silent without a C
compiler; the next build (and a search's workers) load the library it leaves.

The suite runs with the switch off (tests/conftest.py); these tests turn it on and compile the toy
knot (a 20 KB library, well under a second) with gcc behind a fake compiler script
(``$GAITSMITH_CC``) that can wait, fail or be killed."""

from __future__ import annotations

import fcntl
import json
import os
import signal
import stat
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from gaitsmith.cli import main
from planner.nlp import background_compile, compiled_knot
from planner.nlp.solver_cache import (
    CacheOutcome,
    knot_compiled_entry,
    knot_jacobian_and_hessian,
)
from planner.search.executors import ProcessExecutor
from tests.planner.nlp.toy_knot import toy_knot

#: the fake compiler: answers --version, waits $FAKECC_SLEEP s, then fails with $FAKECC_FAIL or
#: hands the arguments to gcc (the real one compiles the toy knot in well under a second)
FAKE_CC = """#!/bin/sh
if [ "$1" = --version ]; then echo fakecc 1.0; exit 0; fi
sleep "${FAKECC_SLEEP:-0}"
if [ -n "$FAKECC_FAIL" ]; then echo "fatal error: $FAKECC_FAIL" >&2; exit 4; fi
exec gcc "$@"
"""


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder, the switch on, the fake compiler as `$GAITSMITH_CC`."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("GAITSMITH_CACHE", str(folder))
    monkeypatch.setenv(background_compile.ENV_SWITCH, "1")
    script = tmp_path / "fakecc"
    script.write_text(FAKE_CC)
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv("GAITSMITH_CC", str(script))
    monkeypatch.setenv("FAKECC_SLEEP", "0")
    monkeypatch.delenv("FAKECC_FAIL", raising=False)
    return folder


@pytest.fixture(autouse=True)
def _reap() -> Iterator[None]:
    """Every compile a test started has ended when it ends (killed if it still runs)."""
    yield
    while background_compile._started:
        process = background_compile._started.pop()
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=30)


def _entry() -> compiled_knot.CompiledEntry:
    compiler = compiled_knot.find_compiler()
    assert compiler is not None
    return knot_compiled_entry(toy_knot(), compiler)


def _knot_build(capsys: pytest.CaptureFixture[str]) -> tuple[CacheOutcome, list[str]]:
    """A "knot" build of the toy knot: what it loaded and the lines it printed on stderr."""
    _, _, outcome = knot_jacobian_and_hessian(toy_knot(), "knot", label="toy")
    return outcome, capsys.readouterr().err.splitlines()


def _finish(started: int) -> int:
    """Wait for the compiles started so far beyond the first `started`: their exit codes' max."""
    codes = [p.wait(timeout=60) for p in background_compile._started[started:]]
    return max(codes)


def _wait_until(condition: Callable[[], bool], timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def _hold_lock(path: Path, with_pid: bool) -> subprocess.Popen[str]:
    """Another process holding `path`'s ``flock`` (and, `with_pid`, writing its pid into it as a
    compile does), returned once it holds it; the caller kills it."""
    record = ("os.write(fd, b'{\"pid\": %d, \"label\": \"toy\", \"started_utc\": \"x\"}' "
              "% os.getpid()); " if with_pid else "")
    holder = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, os, sys, time; fd = os.open(sys.argv[1], os.O_RDWR "
         f"| os.O_CREAT); fcntl.flock(fd, fcntl.LOCK_EX); {record}print('held', flush=True); "
         "time.sleep(60)", str(path)],
        stdout=subprocess.PIPE, text=True)
    assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
    return holder


def test_a_knot_build_starts_one_compile_and_the_next_build_loads_it(
    cache: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FAKECC_SLEEP", "2")  # still compiling when the second build looks
    outcome, lines = _knot_build(capsys)
    assert not outcome.compiled  # this build plans on the SX J and H
    entry = _entry()
    log = background_compile.log_path(entry)
    assert len(lines) == 1 and "in the background" in lines[0] and str(log) in lines[0]
    assert "toy's" in lines[0]
    assert len(background_compile._started) == 1
    now = background_compile.running(entry)
    assert now is not None and now.pid == background_compile._started[0].pid
    assert now.label == "toy" and now.log == log
    again, lines = _knot_build(capsys)  # the lock is held: no second compile, nothing said
    assert not again.compiled and lines == [] and len(background_compile._started) == 1
    assert _finish(0) == 0
    assert background_compile.running(entry) is None
    assert "done:" in log.read_text()
    assert not background_compile.attempts_path(entry).exists()  # a library: record cleared
    assert not [p for p in cache.iterdir() if p.name.startswith(".")]  # no temp folder
    assert not list(cache.glob("*.input.casadi")) and not list(cache.glob("*.job.json"))
    loaded, lines = _knot_build(capsys)
    assert loaded.compiled and loaded.status == "hit" and loaded.path == entry.library
    assert lines == [] and len(background_compile._started) == 1
    manifest = json.loads(entry.manifest.read_text())
    assert manifest["label"] == "toy"


def test_a_lock_held_by_another_process_stops_a_second_compile(
    cache: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    entry = _entry()
    entry.library.parent.mkdir(parents=True)
    # another process holding the key's lock, as a compile does
    holder = _hold_lock(background_compile.lock_path(entry), with_pid=True)
    try:
        outcome, lines = _knot_build(capsys)
        assert not outcome.compiled and lines == [] and background_compile._started == []
        now = background_compile.running(entry)
        assert now is not None and now.pid == holder.pid
        assert not entry.library.exists() and not list(cache.glob("*.job.json"))
    finally:
        holder.kill()
        holder.wait()
    # its holder gone (killed), the lock is free and taken over by the next build
    assert background_compile.running(entry) is None
    _, lines = _knot_build(capsys)
    assert len(lines) == 1 and len(background_compile._started) == 1
    assert _finish(0) == 0 and compiled_knot.load_compiled(entry) is not None


def test_another_robots_compile_holding_the_slot_stops_a_second_one(
    cache: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """One background compile per cache folder: while one runs (another key's, here a process
    holding the slot lock as a compile does), a build starts none and says nothing; once it
    has ended the next build starts its own, and a compile holds the slot while it runs."""
    entry = _entry()
    entry.library.parent.mkdir(parents=True)
    holder = _hold_lock(background_compile.slot_path(entry), with_pid=False)
    try:
        outcome, lines = _knot_build(capsys)
        assert not outcome.compiled and lines == [] and background_compile._started == []
        assert background_compile.running(entry) is None  # its own key's lock is free again
        assert not background_compile.attempts_path(entry).exists()  # no attempt counted
    finally:
        holder.kill()
        holder.wait()
    monkeypatch.setenv("FAKECC_SLEEP", "2")
    _, lines = _knot_build(capsys)
    assert len(lines) == 1 and len(background_compile._started) == 1
    slot = os.open(background_compile.slot_path(entry), os.O_RDWR)
    try:  # the running compile holds the slot
        with pytest.raises(BlockingIOError):
            fcntl.flock(slot, fcntl.LOCK_EX | fcntl.LOCK_NB)
    finally:
        os.close(slot)
    assert _finish(0) == 0 and compiled_knot.load_compiled(entry) is not None


def test_a_stale_lock_file_of_a_dead_process_is_taken_over(
    cache: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    entry = _entry()
    dead = subprocess.Popen(["true"])
    dead.wait()
    entry.library.parent.mkdir(parents=True)
    background_compile.lock_path(entry).write_text(json.dumps(
        {"pid": dead.pid, "label": "toy", "started_utc": "2026-01-01T00:00:00Z"}))
    assert background_compile.running(entry) is None  # a file, but no process holds it
    _, lines = _knot_build(capsys)
    assert len(lines) == 1 and len(background_compile._started) == 1
    lock = json.loads(background_compile.lock_path(entry).read_text())
    assert lock["pid"] == background_compile._started[0].pid != dead.pid
    assert _finish(0) == 0 and compiled_knot.load_compiled(entry) is not None


def test_a_failing_compile_is_recorded_and_not_retried_after_the_second_failure(
    cache: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FAKECC_FAIL", "out of memory")
    entry = _entry()
    record_path = background_compile.attempts_path(entry)
    for failures in range(1, background_compile.MAX_FAILURES + 1):
        _, lines = _knot_build(capsys)
        assert len(lines) == 1 and len(background_compile._started) == failures
        assert _finish(failures - 1) == 1
        record = background_compile.read_attempts(record_path)
        assert (record.attempts, record.failures, record.label) == (failures, failures, "toy")
        assert "exit 4" in record.last_error and "out of memory" in record.last_error
        assert not entry.library.exists() and not entry.manifest.exists()
        assert "FAILED" in background_compile.log_path(entry).read_text()
    assert record.gave_up
    _, lines = _knot_build(capsys)  # gave up: nothing starts, nothing is said
    assert lines == [] and len(background_compile._started) == background_compile.MAX_FAILURES
    assert main(["cache"]) == 0
    out = capsys.readouterr().out
    assert "not compiling again: toy" in out and "out of memory" in out
    # the foreground compile still compiles (the compiler works again) and clears the record
    monkeypatch.delenv("FAKECC_FAIL")
    _, _, outcome = knot_jacobian_and_hessian(toy_knot(), "compiled", label="toy")
    assert outcome.compiled and outcome.status == "built" and not record_path.exists()


def test_a_killed_compile_leaves_no_entry_and_is_retried_a_bounded_number_of_times(
    cache: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FAKECC_SLEEP", "60")
    entry = _entry()
    for attempt in range(1, background_compile.MAX_ATTEMPTS + 1):
        _, lines = _knot_build(capsys)
        assert len(lines) == 1 and len(background_compile._started) == attempt
        process = background_compile._started[-1]
        _wait_until(lambda: "generating C" in background_compile.log_path(entry).read_text())
        os.killpg(process.pid, signal.SIGKILL)  # the compile and its compiler (own session)
        process.wait(timeout=30)
        assert background_compile.running(entry) is None
        assert not entry.library.exists() and not entry.manifest.exists()
        record = background_compile.read_attempts(background_compile.attempts_path(entry))
        assert (record.attempts, record.failures) == (attempt, 0)
    assert record.gave_up
    _, lines = _knot_build(capsys)
    assert lines == [] and len(background_compile._started) == background_compile.MAX_ATTEMPTS


@pytest.mark.parametrize("value", ["0", "off", "maybe"])
def test_the_switch_turns_it_off(cache: Path, capsys: pytest.CaptureFixture[str],
                                 monkeypatch: pytest.MonkeyPatch, value: str) -> None:
    monkeypatch.setenv(background_compile.ENV_SWITCH, value)
    monkeypatch.setattr(background_compile, "_warned_switch", [])
    outcome, lines = _knot_build(capsys)
    _, again = _knot_build(capsys)
    assert not outcome.compiled and background_compile._started == []
    assert not cache.exists() or not list(cache.iterdir())
    if value == "maybe":  # an unknown value: off, said once per process
        assert len(lines) == 1 and "GAITSMITH_BACKGROUND_COMPILE" in lines[0]
        assert again == []
    else:
        assert lines == [] and again == []


def test_short_memory_starts_nothing_and_says_so_once(
    cache: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(background_compile, "available_memory_bytes", lambda: 512 * 1024**2)
    monkeypatch.setattr(background_compile, "_warned_memory", [])
    outcome, lines = _knot_build(capsys)
    _, again = _knot_build(capsys)
    assert not outcome.compiled and background_compile._started == []
    assert len(lines) == 1 and "0.5 GB of memory available" in lines[0]
    assert "gaitsmith cache build" in lines[0] and again == []


def test_available_memory_is_read_from_the_kernel() -> None:
    free = background_compile.available_memory_bytes()
    assert free is None or free > 0


def test_the_suite_itself_runs_with_the_switch_off() -> None:
    assert os.environ[background_compile.ENV_SWITCH] == "0"
    assert not background_compile.enabled()


def test_no_c_compiler_starts_nothing_and_says_nothing(
    cache: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("GAITSMITH_CC", str(tmp_path / "no-such-cc"))
    outcome, lines = _knot_build(capsys)
    assert not outcome.compiled and lines == [] and background_compile._started == []
    assert main(["cache"]) == 0
    assert "C compiler: none found" in capsys.readouterr().out


def test_cache_status_shows_a_running_compile_and_its_log(
    cache: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FAKECC_SLEEP", "60")
    _knot_build(capsys)
    entry = _entry()
    assert main(["cache", "status"]) == 0
    out = capsys.readouterr().out
    pid = background_compile._started[0].pid
    assert f"compiling: toy (pid {pid}" in out and str(background_compile.log_path(entry)) in out
    assert "unfinished" not in out  # the running compile's own attempt is not listed again


class ToyKnotWorker:
    """Picklable factory: a spawn worker's "knot" build of the toy knot, as a search's worker
    builds its planner; its local solve answers what that build loaded."""

    def __call__(self) -> Callable[[int], tuple[bool, int]]:
        _, _, outcome = knot_jacobian_and_hessian(toy_knot(), "knot", label="toy")
        started = len(background_compile._started)
        return lambda _: (outcome.compiled, started)


def test_workers_load_the_compiled_entry_and_start_no_compile_beside_a_running_one(
    cache: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    entry = _entry()
    entry.library.parent.mkdir(parents=True)
    # a compile running (this process holds the key's lock): the workers start none
    fd = os.open(background_compile.lock_path(entry), os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        with ProcessExecutor(ToyKnotWorker(), workers=2) as pool:
            got = pool.map(pool.local_solve, [0, 1, 2, 3])
    finally:
        os.close(fd)
    assert all(not compiled and started == 0 for compiled, started in got)
    assert not entry.library.exists() and not list(cache.glob("*.job.json"))
    # compiled (the foreground path): the workers load it
    knot_jacobian_and_hessian(toy_knot(), "compiled", label="toy")
    with ProcessExecutor(ToyKnotWorker(), workers=2) as pool:
        got = pool.map(pool.local_solve, [0, 1, 2, 3])
    assert all(compiled and started == 0 for compiled, started in got)


def test_a_build_told_not_to_starts_no_compile(
    cache: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`start_compile=False` (a `GaitPlanner(..., background_compile=False)`: a design sample, a
    retargeting hybrid): no compile, nothing said, no attempt recorded; the next build may."""
    _, _, outcome = knot_jacobian_and_hessian(toy_knot(), "knot", label="toy", start_compile=False)
    assert not outcome.compiled and capsys.readouterr().err == ""
    assert background_compile._started == []
    assert not background_compile.attempts_path(_entry()).exists()
    _, lines = _knot_build(capsys)
    assert len(lines) == 1 and len(background_compile._started) == 1
    assert _finish(0) == 0


def test_a_planner_of_a_one_off_body_starts_no_compile(
    cache: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import robots
    from planner.nlp.spacetime import GaitPlanner

    monkeypatch.setenv("FAKECC_SLEEP", "30")  # whatever starts is killed by `_reap`
    GaitPlanner(robots.load("quad12"), 8, background_compile=False)
    assert background_compile._started == [] and "background" not in capsys.readouterr().err
    GaitPlanner(robots.load("quad12"), 8)
    assert len(background_compile._started) == 1

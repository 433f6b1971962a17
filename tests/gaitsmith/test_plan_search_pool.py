"""`gaitsmith plan --search` starts the search's process pool once its options are checked, so
the workers start up while the command prepares the search (`gaitsmith.plan_search.search_pool`);
bad input fails before any worker starts, and an error or Ctrl-C leaves no worker behind."""

from __future__ import annotations

import multiprocessing as mp
import signal
import threading
import time
from pathlib import Path
from typing import Any

import pytest

import planner.search.gait_search
from gaitsmith.cli import main
from planner.search.executors import ProcessExecutor
from tests.gaitsmith.capture import captured_kwargs


def _children_after(deadline_s: float) -> list[str]:
    """This process's children still alive after up to `deadline_s` (a terminated worker is
    reaped by the pool's manager thread or by the executor, whichever comes first)."""
    t_end = time.perf_counter() + deadline_s
    while mp.active_children() and time.perf_counter() < t_end:
        time.sleep(0.1)
    return [f"{c.name} pid {c.pid}" for c in mp.active_children()]


def _argv(tmp_path: Path, *extra: str) -> list[str]:
    return ["plan", "quad12", "--speed", "0.25", "--search", "-o", str(tmp_path / "g.json"),
            *extra]


def test_the_search_gets_the_pool_started_before_it(monkeypatch: pytest.MonkeyPatch,
                                                    tmp_path: Path) -> None:
    """The search is given the started pool (its workers already spawned, with the worker
    count of --workers) instead of making one; the error the search raises (here: the
    stand-in's) terminates them."""
    kw = captured_kwargs(monkeypatch, planner.search.gait_search, "search_gait",
                         _argv(tmp_path, "--workers", "2"))
    pool = kw["executor"]
    assert isinstance(pool, ProcessExecutor) and pool.workers == 2
    assert kw["workers"] is None and kw["address"] is None  # the pool's own
    procs = list(pool._context.processes)
    assert len(procs) == 2  # started before the search was called
    assert not any(p.is_alive() for p in procs)
    assert _children_after(5.0) == []


def test_serial_and_ray_searches_make_their_own_executor(monkeypatch: pytest.MonkeyPatch,
                                                         tmp_path: Path) -> None:
    kw = captured_kwargs(monkeypatch, planner.search.gait_search, "search_gait",
                         _argv(tmp_path, "--executor", "serial"))
    assert kw["executor"] == "serial" and mp.active_children() == []


@pytest.mark.parametrize("bad", [
    ["--generations", "0"],  # a search option
    ["--knots", "3"],  # an NLP option
    ["--vy", "0.1"],  # refused with --search
])
def test_bad_input_fails_before_any_worker_starts(bad: list[str], monkeypatch: pytest.MonkeyPatch,
                                                  tmp_path: Path) -> None:
    started: list[ProcessExecutor] = []

    def record(self: ProcessExecutor) -> ProcessExecutor:
        started.append(self)
        return self

    monkeypatch.setattr(ProcessExecutor, "start", record)
    assert main(_argv(tmp_path, *bad)) == 2
    assert main(["plan", "no_such_robot", "--search", "-o", str(tmp_path / "g.json")]) == 2
    assert started == [] and mp.active_children() == []


@pytest.fixture
def ctrl_c_reaches_python() -> Any:
    """Python's own SIGINT handler (a background process may inherit SIGINT ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.usefixtures("ctrl_c_reaches_python")
def test_ctrl_c_while_the_workers_start_leaves_none(monkeypatch: pytest.MonkeyPatch,
                                                   tmp_path: Path) -> None:
    """SIGINT reaches the command while it prepares the search (the workers still importing):
    an interruption (exit 130), and the started workers are gone."""
    seen: dict[str, Any] = {}
    main_thread = threading.main_thread().ident
    assert main_thread is not None

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        seen.update(kwargs)
        signal.pthread_kill(main_thread, signal.SIGINT)
        time.sleep(30.0)  # the KeyboardInterrupt arrives first
        raise AssertionError("no KeyboardInterrupt")

    monkeypatch.setattr(planner.search.gait_search, "search_gait", interrupted)
    t0 = time.perf_counter()
    assert main(_argv(tmp_path)) == 130
    assert time.perf_counter() - t0 < 25.0
    procs = list(seen["executor"]._context.processes)
    assert procs and not any(p.is_alive() for p in procs)
    assert _children_after(5.0) == []


def test_an_error_preparing_the_search_leaves_no_worker(monkeypatch: pytest.MonkeyPatch,
                                                        tmp_path: Path) -> None:
    """A user error raised after the pool started (here: a seed schedule the symmetric search
    cannot represent, found by the search before it uses the pool) is one line, exit 2."""
    made: list[ProcessExecutor] = []
    start = ProcessExecutor.start

    def recording_start(self: ProcessExecutor) -> ProcessExecutor:
        made.append(self)
        return start(self)

    monkeypatch.setattr(ProcessExecutor, "start", recording_start)
    assert main(_argv(tmp_path, "--phases", "0,0.1,0.2,0.3", "--duty", "0.6")) == 2
    assert len(made) == 1
    assert not any(p.is_alive() for p in made[0]._context.processes)
    assert _children_after(5.0) == []

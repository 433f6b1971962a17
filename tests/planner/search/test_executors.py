"""Executors: order, build-once-per-worker, error reporting, equivalence with serial runs."""

from __future__ import annotations

import os
import sys
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import planner.search.executors as ex_mod
from planner.search.basin_cma import basin_cma
from planner.search.cec2006 import CecSolverFactory, get_problem, initial_search
from planner.search.executors import (
    Executor,
    ExecutorError,
    OrderedResults,
    ProcessExecutor,
    SerialExecutor,
    make_executor,
    worker_local_solve,
)


@dataclass(frozen=True)
class CountingFactory:
    """Records every build as a file ``<pid>-<uuid>`` in ``directory``; the built solver
    returns ``(pid, x²)`` so the test can see which worker handled which sample."""

    directory: str

    def __call__(self) -> Callable[[float], tuple[int, float]]:
        Path(self.directory, f"{os.getpid()}-{uuid.uuid4().hex}").touch()

        def solve(x: float) -> tuple[int, float]:
            return os.getpid(), x * x
        return solve


@dataclass(frozen=True)
class FailingFactory:
    def __call__(self) -> Callable[[float], float]:
        raise RuntimeError("cannot build the NLP")


def test_serial_executor_builds_once_and_keeps_order(tmp_path: Path) -> None:
    ex = SerialExecutor(CountingFactory(str(tmp_path)))
    assert isinstance(ex, Executor)
    out = ex.map(ex.local_solve, [1.0, 2.0, 3.0])
    assert [v for _, v in out] == [1.0, 4.0, 9.0]
    assert len(list(tmp_path.iterdir())) == 1
    assert ex.map(lambda x: x + 1, [1, 2]) == [2, 3]


def _first_two(results: OrderedResults) -> list[Any]:
    """Read two results through the protocol, then close the run (leaving ``with``)."""
    with results as out:
        return [next(out), next(out)]


def test_serial_ordered_evaluates_only_what_is_read() -> None:
    calls: list[int] = []

    def double(x: int) -> int:
        calls.append(x)
        return 2 * x

    results = SerialExecutor().ordered(double, [1, 2, 3, 4])
    assert calls == []  # nothing before the first read
    assert _first_two(results) == [2, 4] and calls == [1, 2]
    assert list(results) == [] and calls == [1, 2]  # closed: the rest is never evaluated
    assert list(SerialExecutor().ordered(double, [5, 6])) == [10, 12]


def test_pool_ordered_reads_in_order_through_the_protocol() -> None:
    with ProcessExecutor(None, workers=2) as ex:
        assert _first_two(ex.ordered(abs, [-3, -1, -2])) == [3, 1]
        assert list(ex.ordered(abs, [-5, 6])) == [5, 6]


def test_process_executor_builds_once_per_worker(tmp_path: Path) -> None:
    workers, n = 2, 60
    with make_executor("process", CountingFactory(str(tmp_path)), workers=workers) as ex:
        xs = [float(i) for i in range(n)]
        first = ex.map(ex.local_solve, xs)
        second = ex.map(worker_local_solve, xs)
    builds = list(tmp_path.iterdir())
    assert 1 <= len(builds) <= workers                     # not once per sample
    build_pids = {int(b.name.split("-")[0]) for b in builds}
    worker_pids = {pid for pid, _ in first + second}
    assert worker_pids <= build_pids and os.getpid() not in worker_pids
    assert [v for _, v in first] == [x * x for x in xs]   # order preserved


def test_process_executor_matches_serial_basin_cma() -> None:
    p = get_problem("g06")
    x0, s0 = initial_search(p)
    kw: dict[str, Any] = {"seed": 5, "max_generations": 3, "restarts": 0}
    serial = basin_cma(CecSolverFactory("g06")(), x0, s0, (p.lb, p.ub), **kw)
    with ProcessExecutor(CecSolverFactory("g06"), workers=2) as ex:
        par = basin_cma(ex.local_solve, x0, s0, (p.lb, p.ub), executor=ex, **kw)
    assert np.array_equal(serial.x, par.x) and serial.cost == par.cost
    assert serial.n_fevals == par.n_fevals > 0


def test_factory_errors_are_typed(tmp_path: Path) -> None:
    with pytest.raises(ExecutorError, match="picklable"):
        ProcessExecutor(lambda: (lambda x: x))   # spawn cannot ship a lambda
    with ProcessExecutor(FailingFactory(), workers=1) as ex, \
            pytest.raises(ExecutorError, match="factory"):
        ex.map(ex.local_solve, [1.0])
    with pytest.raises(ExecutorError, match="fork"):
        ProcessExecutor(CountingFactory(str(tmp_path)), start_method="fork")  # type: ignore[arg-type]
    with pytest.raises(ExecutorError, match="unknown executor kind"):
        make_executor("threads", None)  # type: ignore[arg-type]


def test_worker_local_solve_without_factory(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(ex_mod, "_WORKER_SOLVE", None)
    with pytest.raises(ExecutorError, match="no factory"):
        worker_local_solve(1.0)


def test_ray_executor_builds_once_per_actor(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="ray is the optional extra gaitsmith[ray]; not installed")
    from ray import cloudpickle

    # this test module is not importable inside Ray workers: ship CountingFactory by value
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    try:
        with make_executor("ray", CountingFactory(str(tmp_path)), workers=2) as ex:
            xs = [float(i) for i in range(20)]
            out = ex.map(ex.local_solve, xs)
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    assert [v for _, v in out] == [x * x for x in xs]
    assert 1 <= len(list(tmp_path.iterdir())) <= 2

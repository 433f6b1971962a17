"""Executors that evaluate a generation's local solves (W&P §5 ran them "in parallel on a
cluster").

All executors implement ``map(fn, xs) -> list`` (order preserved).  The expensive part of a
local solve — building the CasADi NLP — must happen *once per worker*, not once per sample.
Hence the factory pattern: ``ProcessExecutor(factory)`` / ``RayExecutor(factory)`` call
``factory()`` once in every worker (pool initializer / actor constructor) and keep the built
``local_solve`` in the module global ``_WORKER_SOLVE``.  The picklable module-level function
:func:`worker_local_solve` calls it, so a sample ships only ``x`` (plus a by-name reference to
that function)::

    with make_executor("process", CecSolverFactory("g07"), workers=4) as ex:
        res = basin_cma(ex.local_solve, x0, sigma0, bounds, executor=ex)

Besides ``map`` (a batch, all results), every executor has ``ordered(fn, xs)``: the results in
order, one at a time, for a caller that stops at the first one it likes (the gait search's final
phase: the first candidate in rank order that passes wins). The parallel executors evaluate up to
``workers`` items ahead of the one the caller waits for (speculatively, so a later item may
finish first; its result is still returned after the earlier ones), the serial one only the item
asked for. Closing the run (``with ex.ordered(...) as results``) cancels the items not started;
items still running are ignored, and closing the executor then stops their workers instead of
waiting for them (a process pool terminates them; Ray kills its actors anyway).
``idle_task = (fn, arg)`` on the process pool queues ``fn(arg)`` once per worker behind every
``map`` batch: a worker with no sample left runs it while the batch's last samples finish (the
generation barrier's idle time), e.g. to build what a later phase needs.

Start method: workers are started with ``spawn`` by default.  ``fork`` copies a parent that may
already run threads (CasADi/IPOPT's linear solvers, OpenMP/BLAS pools, Ray's IO threads); a
forked child inherits their locks in whatever state they were and can deadlock.  ``spawn``
starts a clean interpreter, so ``factory`` must be picklable (a module-level function, a
``functools.partial`` of one, or an instance of a module-level class); ``forkserver`` is also
accepted (faster start on Linux, same requirement).

Threads: CasADi's IPOPT plugin loads its own OpenBLAS and libgomp, which by default start one
thread per core *in every worker*; with ``workers = cores`` that oversubscribes the machine
(measured in ``benchmarks/basin_cma_bench.py`` on 2 cores: the process pool ran 0.7× the speed
of the serial loop).  Workers therefore set ``OMP_NUM_THREADS``/``OPENBLAS_NUM_THREADS``/
``MKL_NUM_THREADS`` to ``threads_per_worker`` (default 1) *before* unpickling the factory and
calling it — those libraries read the variables when they are loaded, which for CasADi's
plugins is when the first ``nlpsol`` is built.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import pickle
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from functools import partial
from multiprocessing.context import BaseContext
from multiprocessing.process import BaseProcess
from types import TracebackType
from typing import Any, Literal, Protocol, TypeVar, cast, runtime_checkable

from planner.search.basin_cma import BasinCmaError

SolverFactory = Callable[[], Callable[[Any], Any]]
ExecutorKind = Literal["serial", "process", "ray"]

_WORKER_SOLVE: Callable[[Any], Any] | None = None
_E = TypeVar("_E", bound="_Closable")
_R = TypeVar("_R", bound="OrderedResults")


class ExecutorError(BasinCmaError):
    """An executor could not be created or a worker failed to build its solver."""


@runtime_checkable
class Executor(Protocol):
    def map(self, fn: Callable[[Any], Any], xs: Iterable[Any]) -> list[Any]:
        """``[fn(x) for x in xs]``, possibly in parallel, order preserved."""
        ...


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _init_worker(factory: SolverFactory) -> None:
    """Build this process's local solve once."""
    global _WORKER_SOLVE
    _WORKER_SOLVE = factory()


#: glibc mallopt parameters for worker processes: no mmap'd chunks (M_MMAP_MAX = 0) and keep up
#: to 1 GiB of freed heap (M_TRIM_THRESHOLD). MUMPS allocates its factorisation workspace (tens
#: of MB, above glibc's mmap threshold) afresh in every IPOPT iteration; served by mmap, every page
#: is faulted in and zeroed by the kernel again (≈ 8 % of a solve's `perf` samples). Reusing heap
#: pages: quad12 cold solves in a fresh process 103 → 97 ms per iteration at 30 knots and
#: 39.5 → 37.0 ms at 12 knots, bit-identical results, peak RSS 755 → 769 MB. Applied only in
#: pool/Ray workers, which exist to run local solves; a library should not retune the allocator
#: of a user's own process.
_WORKER_MALLOPT = ((-4, 0), (-1, 1 << 30))


def _tune_worker_malloc() -> None:
    """Apply `_WORKER_MALLOPT` (glibc only; elsewhere a no-op)."""
    import ctypes
    import ctypes.util

    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c")).mallopt
    except (OSError, AttributeError, TypeError):  # not glibc (musl, macOS, Windows)
        return
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    for param, value in _WORKER_MALLOPT:
        mallopt(param, value)


def _init_remote_worker(payload: bytes, threads_per_worker: int | None) -> None:
    """Pool initializer / actor constructor: cap native thread pools, tune the allocator, then
    unpickle the factory (which may import casadi) and build the local solve once."""
    if threads_per_worker is not None:
        for var in _THREAD_VARS:
            os.environ[var] = str(threads_per_worker)
    _tune_worker_malloc()
    _init_worker(pickle.loads(payload))


def worker_local_solve(x: Any) -> Any:
    """Call the local solve built by this worker's factory (picklable by reference)."""
    if _WORKER_SOLVE is None:
        raise ExecutorError("worker_local_solve called in a process whose executor has no "
                            "factory (pass factory= to the executor)")
    return _WORKER_SOLVE(x)


def _call(fn: Callable[[Any], Any], x: Any) -> Any:
    return fn(x)


IdleTask = tuple[Callable[[Any], Any], Any]


class OrderedResults(Protocol):
    """``fn(x)`` for each item, returned in order, one at a time (``ordered(fn, xs)`` of every
    executor). Iterate it; `close` (or leaving ``with``) stops evaluating the items not read.
    Two implementations: `LazyResults` (evaluates an item when it is asked for) and
    `AheadResults` (evaluates up to `ahead` items ahead on the workers)."""

    def __next__(self) -> Any:
        """The next item's result (StopIteration after the last one, or once closed)."""
        ...

    def close(self) -> None:
        """Evaluate nothing more; an item still running is left to the executor's `close`."""
        ...

    def __iter__(self) -> Iterator[Any]:
        return self

    def __enter__(self: _R) -> _R:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


class LazyResults(OrderedResults):
    """`OrderedResults` of the serial executor: ``fn(x)`` of an item, in this process, when it
    is asked for (nothing speculative)."""

    def __init__(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> None:
        self._fn, self._items = fn, list(items)
        self._head = 0
        self._closed = False

    def __next__(self) -> Any:
        if self._closed or self._head == len(self._items):
            raise StopIteration
        self._head += 1
        return self._fn(self._items[self._head - 1])

    def close(self) -> None:
        self._closed = True


class AheadResults(OrderedResults):
    """`OrderedResults` of the parallel executors: evaluated up to `ahead` items ahead of the one
    asked for (`submit(x, slot)` starts one on the free worker slot ``slot`` and returns its
    future). `close` cancels what has not started and hands the futures still running, which
    nobody will read, to `on_close`."""

    def __init__(self, submit: Callable[[Any, int], Future[Any]], items: Iterable[Any],
                 ahead: int, on_close: Callable[[list[Future[Any]]], None] | None = None
                 ) -> None:
        if ahead < 1:
            raise ExecutorError(f"ordered: ahead must be >= 1, got {ahead}")
        self._submit, self._items = submit, list(items)
        self._futures: list[Future[Any]] = []
        self._free = list(range(ahead))
        self._busy: dict[int, Future[Any]] = {}  # slot -> its future
        self._head = 0
        self._on_close = on_close
        self._closed = False
        self._top_up()

    def _top_up(self) -> None:
        for slot, fut in list(self._busy.items()):
            if fut.done():
                del self._busy[slot]
                self._free.append(slot)
        while self._free and len(self._futures) < len(self._items) and not self._closed:
            slot = self._free.pop(0)
            fut = self._submit(self._items[len(self._futures)], slot)
            self._futures.append(fut)
            self._busy[slot] = fut

    def __next__(self) -> Any:
        if self._closed or self._head == len(self._items):
            raise StopIteration
        while self._head >= len(self._futures) or not self._futures[self._head].done():
            wait(list(self._busy.values()), return_when=FIRST_COMPLETED)
            self._top_up()
        fut = self._futures[self._head]
        self._head += 1
        self._top_up()  # the slot of a result read early may already be free
        try:
            return fut.result()
        except BrokenProcessPool as e:
            raise ExecutorError("process pool broke: a worker died") from e

    def close(self) -> None:
        """Cancel the items not started; the ones still running go to `on_close` (the
        executor's `close` stops their workers)."""
        if self._closed:
            return
        self._closed = True
        running = [f for f in self._futures if not f.cancel() and not f.done()]
        if self._on_close is not None:
            self._on_close(running)


class _Closable:
    local_solve: Callable[[Any], Any] = staticmethod(worker_local_solve)

    def close(self) -> None:  # pragma: no cover - overridden
        pass

    def __enter__(self: _E) -> _E:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


class SerialExecutor(_Closable):
    """In-process loop.  With a factory, builds the solver once in this process so that
    :func:`worker_local_solve` (``.local_solve``) works like in the parallel executors."""

    def __init__(self, factory: SolverFactory | None = None) -> None:
        if factory is not None:
            _init_worker(factory)

    def map(self, fn: Callable[[Any], Any], xs: Iterable[Any]) -> list[Any]:
        return [fn(x) for x in xs]

    def ordered(self, fn: Callable[[Any], Any], xs: Iterable[Any]) -> LazyResults:
        """``fn(x)`` in order, each evaluated only when asked for (nothing speculative)."""
        return LazyResults(fn, xs)


def _pickle_factory(factory: SolverFactory, dumps: Callable[[Any], bytes] = pickle.dumps
                    ) -> bytes:
    try:
        return dumps(factory)
    except Exception as e:
        raise ExecutorError(f"factory must be picklable for spawn/forkserver/Ray workers "
                            f"(use a module-level function or class): {e}") from e


class _WorkerContext:
    """A multiprocessing context that keeps the processes it starts: given to the pool as its
    ``mp_context``, it lists the pool's workers, so the executor can stop them and wait for
    them without reaching into ``ProcessPoolExecutor``'s private state. Everything else is the
    wrapped context's."""

    def __init__(self, ctx: BaseContext) -> None:
        self._ctx = ctx
        self.processes: list[BaseProcess] = []

    def Process(self, *args: Any, **kwargs: Any) -> BaseProcess:  # the context API's name
        proc = self._ctx.Process(*args, **kwargs)  # type: ignore[attr-defined]
        self.processes.append(proc)
        return proc  # type: ignore[no-any-return]

    def __getattr__(self, name: str) -> Any:
        return getattr(self._ctx, name)


class ProcessExecutor(_Closable):
    """``concurrent.futures.ProcessPoolExecutor`` whose workers each build the local solve
    once with ``factory()`` (in the pool initializer)."""

    def __init__(self, factory: SolverFactory | None = None, workers: int | None = None, *,
                 start_method: Literal["spawn", "forkserver"] = "spawn",
                 threads_per_worker: int | None = 1) -> None:
        if start_method not in ("spawn", "forkserver"):
            raise ExecutorError(f"start_method must be 'spawn' or 'forkserver' ('fork' is not "
                                f"safe with CasADi/IPOPT threads), got {start_method!r}")
        payload = _pickle_factory(factory) if factory is not None else None
        self.workers = workers if workers is not None else max(1, os.cpu_count() or 1)
        if self.workers < 1:
            raise ExecutorError(f"workers must be >= 1, got {self.workers}")
        self._context = _WorkerContext(mp.get_context(start_method))
        self._pool = ProcessPoolExecutor(
            max_workers=self.workers, mp_context=cast(BaseContext, self._context),
            initializer=partial(_init_remote_worker, payload, threads_per_worker)
            if payload is not None else None)
        #: queued once per worker behind every `map` batch (see the module docstring)
        self.idle_task: IdleTask | None = None
        self._ignored: list[Future[Any]] = []  # `ordered` items left running by their reader

    def map(self, fn: Callable[[Any], Any], xs: Iterable[Any]) -> list[Any]:
        items = list(xs)
        try:
            futures = [self._pool.submit(_call, fn, x) for x in items]
            if self.idle_task is not None:
                for _ in range(self.workers):  # behind the batch: run when a worker runs dry
                    self._pool.submit(_call, *self.idle_task)
            return [f.result() for f in futures]
        except BrokenProcessPool as e:
            raise ExecutorError("process pool broke: a worker died or its factory raised "
                                "(run the factory in-process to see the error)") from e

    def ordered(self, fn: Callable[[Any], Any], xs: Iterable[Any]) -> AheadResults:
        """``fn(x)`` in order, up to `workers` items evaluated ahead (module docstring)."""
        return AheadResults(lambda x, slot: self._pool.submit(_call, fn, x), xs,
                              self.workers, self._ignored.extend)

    def close(self) -> None:
        if any(not f.done() for f in self._ignored):
            # an `ordered` reader stopped early: its workers' results are not wanted, and
            # waiting for them would cost a solve's wall time; stop those processes
            self._terminate_workers()
        self._ignored = []
        self._pool.shutdown(wait=True, cancel_futures=True)

    def _terminate_workers(self) -> None:
        """Terminate the pool's worker processes (the pool is broken afterwards: `close` only):
        ``ProcessPoolExecutor.terminate_workers`` on Python ≥ 3.14; before it, which has no public
        way to stop a running call, the pool is shut down without waiting and each worker the
        pool started (`_WorkerContext`) still alive is terminated, as 3.14's method does."""
        procs = list(self._context.processes)
        terminate_workers = getattr(self._pool, "terminate_workers", None)
        if terminate_workers is not None:  # Python ≥ 3.14 (it shuts the pool down too)
            terminate_workers()
        else:
            self._pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                if proc.is_alive():
                    proc.terminate()
        # wait until none is listed alive (`is_alive` reaps a dead worker). Not `join`: the
        # pool's manager thread may reap a worker first, `join` then sees no child (ECHILD) and
        # returns with the process still listed alive until that thread records its status
        deadline = time.monotonic() + 10.0
        while any(proc.is_alive() for proc in procs) and time.monotonic() < deadline:
            time.sleep(0.01)


class RayExecutor(_Closable):
    """Ray actors, each building the local solve once in its constructor.

    ``address=None`` starts (or reuses) a local Ray runtime; otherwise ``ray.init(address=...)``
    connects to a cluster.  Needs the optional extra ``gaitsmith[ray]``.  The factory is
    serialised with Ray's cloudpickle (closures work); classes are still pickled by reference,
    so their module must be importable on the workers (installed, or shipped with
    ``runtime_env``/``cloudpickle.register_pickle_by_value``).
    """

    def __init__(self, factory: SolverFactory | None = None, workers: int | None = None, *,
                 address: str | None = None, threads_per_worker: int | None = 1) -> None:
        try:
            import ray
        except ImportError as e:
            raise ExecutorError("RayExecutor needs ray: pip install 'gaitsmith[ray]'") from e
        from ray import cloudpickle

        payload = _pickle_factory(factory, cloudpickle.dumps) if factory is not None else None
        self._ray = ray
        self._owns_ray = not ray.is_initialized()
        if self._owns_ray:
            ray.init(address=address, include_dashboard=False, log_to_driver=False)

        @ray.remote
        class _Worker:
            def __init__(self, payload: bytes | None, threads: int | None) -> None:
                if payload is not None:
                    _init_remote_worker(payload, threads)

            def run(self, fn: Callable[[Any], Any], x: Any) -> Any:
                return fn(x)

        n = workers if workers is not None else max(1, int(ray.available_resources().get(
            "CPU", 1)))
        if n < 1:
            raise ExecutorError(f"workers must be >= 1, got {n}")
        self.workers = n
        self._actors = [_Worker.remote(payload, threads_per_worker) for _ in range(n)]  # type: ignore[attr-defined]
        from ray.util import ActorPool
        self._pool = ActorPool(self._actors)

    def map(self, fn: Callable[[Any], Any], xs: Iterable[Any]) -> list[Any]:
        try:
            return list(self._pool.map(lambda a, x: a.run.remote(fn, x), list(xs)))
        except self._ray.exceptions.RayActorError as e:
            raise ExecutorError("a Ray actor died (its factory may have raised)") from e

    def ordered(self, fn: Callable[[Any], Any], xs: Iterable[Any]) -> AheadResults:
        """``fn(x)`` in order, one item ahead per actor (module docstring); `close` kills the
        actors, and with them any item still running."""
        return AheadResults(lambda x, slot: self._actors[slot].run.remote(fn, x).future(),
                              xs, len(self._actors))

    def close(self) -> None:
        for a in self._actors:
            self._ray.kill(a)
        self._actors = []
        if self._owns_ray:
            self._ray.shutdown()


def make_executor(kind: ExecutorKind, factory: SolverFactory | None = None,
                  workers: int | None = None, address: str | None = None
                  ) -> SerialExecutor | ProcessExecutor | RayExecutor:
    """``"serial"`` | ``"process"`` | ``"ray"`` executor building ``factory()`` once per
    worker; use ``executor.local_solve`` as the ``local_solve`` argument of ``basin_cma``."""
    if kind == "serial":
        return SerialExecutor(factory)
    if kind == "process":
        return ProcessExecutor(factory, workers)
    if kind == "ray":
        return RayExecutor(factory, workers, address=address)
    raise ExecutorError(f"unknown executor kind {kind!r}; expected 'serial', 'process' or 'ray'")

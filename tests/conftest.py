"""Suite-wide setup: the planner's knot-derivative cache lives in a folder of this test session
(`planner.nlp.solver_cache`), so tests neither read a stale user cache nor fill ~/.cache; and a
"knot" build never starts a background compile (`planner.nlp.background_compile`): the suite and
CI must not spawn gcc behind the tests' back (minutes of CPU, ~1 GB). The tests of that feature
turn it on themselves (tests/planner/nlp/test_background_compile.py)."""

from __future__ import annotations

import atexit
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from hypothesis import settings as _hypothesis_settings

if "GAITSMITH_CACHE" not in os.environ:
    # set before any test imports the planner; subprocesses (CLI tests) inherit it
    _CACHE = tempfile.mkdtemp(prefix="gaitsmith-test-cache-")
    os.environ["GAITSMITH_CACHE"] = _CACHE
    atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)

# MUMPS writes through gfortran's unit 6, buffered when stdout is not a terminal: a test that
# captures it at the file descriptor (tests/benchmarks/test_kkt_fill_screen.py) would otherwise
# leave lines in the buffer that reach the terminal at exit, after pytest's summary. Read by
# libgfortran when CasADi first loads IPOPT's plugin, so set before any test builds a solver.
os.environ.setdefault("GFORTRAN_UNBUFFERED_PRECONNECTED", "y")

# forced, not defaulted: a developer's own GAITSMITH_BACKGROUND_COMPILE=1 must not reach the suite;
# subprocesses (CLI tests, the search's workers) inherit it
os.environ["GAITSMITH_BACKGROUND_COMPILE"] = "0"

# property tests: no per-example wall-clock deadline. The suite runs on 2 shared cores, where an
# example that takes 30 ms alone took 325 ms under load and failed as "flaky" (hypothesis'
# default deadline is 200 ms); a test that must be fast says so in a benchmark, not here.
_hypothesis_settings.register_profile("gaitsmith", deadline=None)
_hypothesis_settings.load_profile("gaitsmith")

@pytest.fixture
def ctrl_c_reaches_python() -> Iterator[None]:
    """Python's own SIGINT handler for a test that sends itself Ctrl-C: a process started in
    the background by a non-interactive shell inherits SIGINT ignored (`signal.getsignal` is
    SIG_IGN), so no Ctrl-C would reach it and the test would measure the shell, not the code."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)

@pytest.fixture
def ctrl_c_during(ctrl_c_reaches_python: None) -> Callable[..., Any]:
    """`ctrl_c_during(call, delay_s, **kwargs)`: `call(**kwargs)` with a Ctrl-C (SIGINT to the
    main thread) `delay_s` into it. The timer is joined before it returns, so the signal always
    lands inside the call — however late a loaded machine runs the timer's thread — and never in
    a later test."""

    def run(call: Callable[..., Any], delay_s: float, **kwargs: Any) -> Any:
        main_thread = threading.main_thread().ident
        assert main_thread is not None
        timer = threading.Timer(delay_s, signal.pthread_kill, (main_thread, signal.SIGINT))
        timer.start()
        try:
            return call(**kwargs)
        finally:
            timer.join()

    return run

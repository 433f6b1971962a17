"""Suite-wide setup: the planner's knot-derivative cache lives in a folder of this test session
(`planner.nlp.solver_cache`), so tests neither read a stale user cache nor fill ~/.cache; and a
"knot" build never starts a background compile (`planner.nlp.background_compile`): the suite and
CI must not spawn gcc behind the tests' back (minutes of CPU, ~1 GB). The tests of that feature
turn it on themselves (tests/planner/nlp/test_background_compile.py)."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

from hypothesis import settings as _hypothesis_settings

if "GAITSMITH_CACHE" not in os.environ:
    # set before any test imports the planner; subprocesses (CLI tests) inherit it
    _CACHE = tempfile.mkdtemp(prefix="gaitsmith-test-cache-")
    os.environ["GAITSMITH_CACHE"] = _CACHE
    atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)

# forced, not defaulted: a developer's own GAITSMITH_BACKGROUND_COMPILE=1 must not reach the suite;
# subprocesses (CLI tests, the search's workers) inherit it
os.environ["GAITSMITH_BACKGROUND_COMPILE"] = "0"

# property tests: no per-example wall-clock deadline. The suite runs on 2 shared cores, where an
# example that takes 30 ms alone took 325 ms under load and failed as "flaky" (hypothesis'
# default deadline is 200 ms); a test that must be fast says so in a benchmark, not here.
_hypothesis_settings.register_profile("gaitsmith", deadline=None)
_hypothesis_settings.load_profile("gaitsmith")

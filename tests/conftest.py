"""Suite-wide setup: the planner's knot-derivative cache lives in a folder of this test session
(`planner.nlp.solver_cache`), so tests neither read a stale user cache nor fill ~/.cache."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

if "GAITSMITH_CACHE" not in os.environ:
    # set before any test imports the planner; subprocesses (CLI tests) inherit it
    _CACHE = tempfile.mkdtemp(prefix="gaitsmith-test-cache-")
    os.environ["GAITSMITH_CACHE"] = _CACHE
    atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)

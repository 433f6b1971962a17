"""Suite-wide setup: the planner's knot-derivative cache lives in a folder of this test session
(`planner.nlp.solver_cache`), so tests neither read a stale user cache nor fill ~/.cache."""

from __future__ import annotations

import os
import tempfile

if "GAITSMITH_CACHE" not in os.environ:
    # set before any test imports the planner; subprocesses (CLI tests) inherit it
    os.environ["GAITSMITH_CACHE"] = tempfile.mkdtemp(prefix="gaitsmith-test-cache-")

"""`benchmarks/retry_points.py`: where a retry lands, by class; bad input refused in one line."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from tests.benchmarks import BENCHMARKS, load_script

BENCH = BENCHMARKS / "retry_points.py"


def _module():  # type: ignore[no-untyped-def]
    return load_script("retry_points")


def _plan(feasible: bool, shift: float) -> SimpleNamespace:
    return SimpleNamespace(feasible=feasible, joint_angles_rad=np.full((4, 3), shift),
                           base_pose=np.zeros((4, 6)))


def test_distance_and_classes() -> None:
    rp = _module()
    same, near, far = _plan(True, 0.0), _plan(True, 2e-6), _plan(True, 0.3)
    assert rp.distance(same, same) == 0.0
    assert rp.point_class(rp.distance(same, same)) == "the same point (<= 1e-9)"
    assert rp.point_class(rp.distance(same, near)) == "the same optimum (< 1e-3)"
    assert rp.point_class(rp.distance(same, far)) == "another point (>= 1e-3)"
    assert math.isnan(rp.distance(same, _plan(False, 0.0)))
    assert rp.point_class(math.nan) == "half or full plan infeasible"


def test_a_missing_recording_is_one_line(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, str(BENCH), str(tmp_path / "none.pkl")],
                          capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode != 0 and "none.pkl: no such recording" in proc.stderr
    assert "Traceback" not in proc.stderr

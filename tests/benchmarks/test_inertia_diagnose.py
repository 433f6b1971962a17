"""`benchmarks/inertia_diagnose.py`: IPOPT's level-8 file log parsed into iterates, δ_c and the
δ_w tried; a small real run finds the reduced Hessian of a converging solve."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.benchmarks import load_script

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "inertia_diagnose.py"

LOG = """\
c scaling provided
DenseVector "c scaling vector" with 2 elements:
c scaling vector[    1]= 1.0000000000000000e+00
c scaling vector[    2]= 5.0000000000000000e-01
*** Beginning Iteration 0 from the following point:
DenseVector "curr_x" with 3 elements:
curr_x[    1]= 1.0000000000000000e+00
curr_x[    2]=-2.0000000000000000e+00
curr_x[    3]= 3.0000000000000000e+00
DenseVector "curr_z_L" with 2 elements:
Homogeneous vector, all elements have value 1.0000000000000000e-02
*** Update Barrier Parameter for Iteration 0:
Solving system with delta_x=0.000000e+00 delta_s=0.000000e+00
                    delta_c=2.260310e-10 delta_d=2.260310e-10
*** Solving the Primal Dual System for Iteration 0:
*** Beginning Iteration 1 from the following point:
DenseVector "curr_x" with 3 elements:
curr_x[    1]= 1.5000000000000000e+00
curr_x[    2]=-2.0000000000000000e+00
curr_x[    3]= 3.0000000000000000e+00
*** Update Barrier Parameter for Iteration 1:
Solving system with delta_x=0.000000e+00 delta_s=0.000000e+00
                    delta_c=1.000000e-10 delta_d=1.000000e-10
Solving system with delta_x=1.000000e-04 delta_s=1.000000e-04
                    delta_c=1.000000e-10 delta_d=1.000000e-10
"""


def test_the_log_is_parsed_per_iteration() -> None:
    diag = load_script("inertia_diagnose")
    log = diag.parse_log(iter(LOG.splitlines(keepends=True)))
    assert np.array_equal(log.vectors["c scaling vector"], [1.0, 0.5])
    assert sorted(log.iterates) == [0, 1]
    assert np.array_equal(log.iterates[0]["curr_x"], [1.0, -2.0, 3.0])
    assert np.array_equal(log.iterates[0]["curr_z_L"], [1e-2, 1e-2])
    assert log.iterates[1]["curr_x"][0] == 1.5
    assert log.delta_w == {0: [0.0], 1: [0.0, 1e-4]}
    assert log.delta_c == {0: 2.26031e-10, 1: 1e-10}


@pytest.mark.slow
def test_a_small_run_prints_the_reduced_hessian() -> None:
    proc = subprocess.run([sys.executable, str(SCRIPT), "--robot", "quad12", "--speed", "0.25",
                           "--gait", "trot", "--knots", "8", "--iters", "0,3"],
                          capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [line for line in proc.stdout.splitlines() if line.startswith("| 0 |")
            or line.startswith("| 3 |")]
    assert len(rows) == 2
    assert '"curvature"' in proc.stdout and '"blocks"' in proc.stdout

"""NUMBA_DISABLE_JIT=1 runs the kernels as plain Python (for debuggers and coverage); the
README promises it, so the result must still equal the oracle there."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

PROBE = """
import sys, warnings
import numpy as np
sys.path.insert(0, {tests!r})
from csw import kernels
from oracle import oracle_match
warnings.simplefilter("ignore")  # numpy warns when uint16 sums wrap, which is intended
rng = np.random.default_rng(1)
for dtype, scale in ((np.uint8, 1), (np.uint16, 300)):
    left = rng.integers(0, 200, (6, 12)).astype(dtype) * dtype(scale)
    right = rng.integers(0, 200, (6, 12)).astype(dtype) * dtype(scale)
    for cost in ("sad", "ssd", "shd"):
        for engine in ("window", "fast"):
            for rule, tau in (("literal", 3000), ("unique", 1e18)):
                got = kernels.match(left, right, engine=engine, window=3, dmin=0, dmax=5, cost=cost,
                                    csw=True, tau=tau, rule=rule,
                                    csw_margin=25 if cost == "ssd" else 12)
                disp, mins, evaluated = oracle_match(left, right, 3, 0, 5, cost, True, tau,
                                                     rule=rule)
                assert (got.disparity == disp).all(), (dtype, cost, engine, rule)
                assert (got.min_cost == mins).all() and got.evaluated == evaluated
from csw.kernels import sgm
from oracle import sgm_match
left, right = (rng.integers(0, 256, (5, 9)).astype(np.uint8) for _ in range(2))
for cost, window, paths, dmin in (("census", 1, 4, 0), ("sad", 3, 8, -2)):
    got = sgm.match_sgm(left, right, window=window, dmin=dmin, dmax=dmin + 4, cost=cost,
                        paths=paths, p1=5, p2=40, census_window=3, census_pattern="dense",
                        band_bytes=9 * 5 * 4 * 2)  # bands of two rows: both passes run
    disp, mins, _ = sgm_match(left, right, window, dmin, dmin + 4, cost, paths, 5, 40, 3)
    assert (got.disparity == disp).all() and (got.min_cost == mins).all(), (cost, paths)
print("ok")
"""


@pytest.mark.slow
def test_kernels_equal_the_oracle_with_the_jit_off():
    tests = str(Path(__file__).parent.parent)  # where oracle.py is
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    out = subprocess.run([sys.executable, "-c", PROBE.format(tests=tests)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "ok"

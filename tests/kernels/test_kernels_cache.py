"""Kernels are compiled once per CPU and stored; later processes load them without
compiling and without importing Numba (kernels/native.py), and processes that start
together on an empty cache compile each entry once."""

import json
import os
import subprocess
import sys

PROBE = """
import json, sys, numpy as np
from csw import kernels
img = np.zeros((4, 6), np.uint8)
kernels.match(img, img, engine="window", window=3, dmin=0, dmax=2, cost="sad", csw=True, tau=0)
print(json.dumps(dict(kernels.native.STATS, numba="numba" in sys.modules)))
"""


def probe(cache):
    env = dict(os.environ, CSW_KERNEL_CACHE=str(cache))
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                         timeout=600, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1]), out.stderr


def test_a_second_process_loads_without_compiling_or_numba(tmp_path):
    first, told = probe(tmp_path)
    assert first["compiled"] == 1 and first["numba"]
    assert told.count("compiling csw's kernels") == 1
    second, quiet = probe(tmp_path)
    assert second["compiled"] == 0 and second["loaded"] == 1, second
    assert not second["numba"] and "compiling" not in quiet

"""cache=True is only worth having if a second process really loads from the cache."""

import json
import subprocess
import sys

PROBE = """
import json, numpy as np, kernels
from kernels import window
img = np.zeros((4, 6), np.uint8)
kernels.match(img, img, window=3, dmax=2, csw=True, tau=0)
stats = window._window_driver.stats
print(json.dumps({"hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}))
"""


def probe():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                         timeout=600, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_second_process_loads_kernels_from_cache():
    probe()  # compiles and stores, unless an earlier run already did
    second = probe()
    assert second["hits"] >= 1 and second["misses"] == 0, second

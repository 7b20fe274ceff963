"""cache=True is only worth having if a second process really loads from the cache."""

import json
import subprocess
import sys

PROBE = """
import json, numpy as np
from csw import kernels
from csw.kernels import window
img = np.zeros((4, 6), np.uint8)
kernels.match(img, img, engine="window", window=3, dmin=0, dmax=2, cost="sad", csw=True, tau=0)
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

"""The fast engine's hot loops must stay SIMD in narrow lanes (see kernels/fast.py).

A regression here (say, a cast that widens |l - r| to 64 bits) keeps every result right
and only costs speed, so no other test would notice. This reads the machine code.
"""

import platform
import subprocess
import sys

import pytest

PROBE = """
import re, numpy as np
from csw.kernels import fast
left = np.zeros((20, 40), np.uint8)
fast.match_fast(left, left, window=9, dmax=16, dmin=0, cost="sad")
asm = "\\n".join(fast._column_shift_sad.inspect_asm().values())
print(*(len(re.findall(rf"\\bv?{op}\\b", asm)) for op in ("paddw", "psubw", "pmaxub",
                                                               "pminub")))
"""


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 mnemonics")
def test_column_update_uses_16_bit_vector_lanes(tmp_path):
    # A fresh cache folder: Numba can't show the machine code of cached functions.
    env = {"NUMBA_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"}
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                         timeout=600, env=env, check=True)
    add16, sub16, max8, min8 = (int(v) for v in out.stdout.split())
    # |l - r| as max - min on packed bytes, summed in packed 16-bit words.
    assert min(add16, sub16, max8, min8) > 0, out.stdout

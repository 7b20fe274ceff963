"""The fast engine's hot loops must stay SIMD in narrow lanes (see kernels/jit/fast.py).

A regression here (say, a cast that widens |l - r| to 64 bits) keeps every result right
and only costs speed, so no other test would notice. This reads the machine code.
"""

import platform
import re

import pytest

from csw.kernels.catalogue import entry


@pytest.mark.slow
@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 mnemonics")
def test_column_update_uses_16_bit_vector_lanes():
    import numpy as np

    from csw.kernels.contract import SAD
    from csw.kernels.jit.build import assembly

    asm = assembly(*entry("fast", SAD, np.dtype(np.uint8), 9, False, False, False))
    add16, sub16, max8, min8 = (len(re.findall(rf"\bv?{op}\b", asm))
                                for op in ("paddw", "psubw", "pmaxub", "pminub"))
    # |l - r| as max - min on packed bytes, summed in packed 16-bit words.
    assert min(add16, sub16, max8, min8) > 0, (add16, sub16, max8, min8)

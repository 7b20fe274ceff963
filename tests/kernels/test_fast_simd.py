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


def _vector_adds_of_a_summing_loop():
    """How many packed adds LLVM makes of a plain summing loop, compiled now."""
    import numba
    import numpy as np

    @numba.njit
    def total(values):
        s = 0
        for i in range(values.shape[0]):
            s += values[i]
        return s

    total(np.arange(4, dtype=np.int32))
    return len(re.findall(r"\bv?padd[bwdq]\b", total.inspect_asm(total.signatures[0])))


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 mnemonics")
def test_csws_llvm_options_hold_for_its_compiles_alone():
    # csw compiles with one vector a loop iteration (kernels/jit/options.py); LLVM's own
    # choice, several, must come back for whatever the process compiles after.
    from csw.kernels.jit.build import csw_llvm_options

    before = _vector_adds_of_a_summing_loop()
    with csw_llvm_options():
        inside = _vector_adds_of_a_summing_loop()
    after = _vector_adds_of_a_summing_loop()
    assert 0 < inside < before, (inside, before)
    assert after == before

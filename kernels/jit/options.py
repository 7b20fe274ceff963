"""The Numba option sets of every worker and entry, named once here (jit/*.py use these
names instead of spelling ``@njit(...)`` flags themselves), so that a change of policy
(fastmath, error model) is made in one place.  No function is cached by Numba: csw
stores each compiled entry itself (kernels/native.py), and loads it without Numba.
"""

# Workers and helpers: serial, no Python objects, no exceptions raised (an entry that
# could raise would need Numba's runtime to report it).  fastmath stays off: every cost
# is integer arithmetic and results must be exact.
SERIAL = dict(nogil=True, error_model="numpy")

# Helpers called once per pixel or column from a worker's inner loops: inlined by Numba
# where they are called.  Left to LLVM, a helper taking array views stays a call whose
# views' fields pass through memory: a semi-global path step over 64 values took 28 ns
# as a call and 10 ns inlined (jit/sgm.py's helpers; the filters' measured no change).
INLINE = dict(SERIAL, inline="always")

# LLVM's options while csw compiles its entries (jit/build.py sets them for the compile
# alone).  Left to itself, LLVM's loop vectorizer makes each iteration of a loop's
# vector body 4 vectors, 128 16-bit lanes with AVX-512: a loop over 32 or 64
# disparities (a camera's range, a narrowed search's slots) never reached it and ran in
# the 8-lane remainder.  One vector an iteration reaches it from 32 lanes on; on a Zen 4
# core the camera preset's frame at 320 x 240 took 12% less time, raw at 1242 x 375
# 12% less, the window engine 6% less, and sgm's steps no longer (census and the
# filters were not timed alone).
LLVM_OPTIONS = {"force-vector-interleave": (1, 0)}  # (csw's, LLVM's default)

# The C-callable entries around the workers.
ENTRY = dict(nopython=True, error_model="numpy")

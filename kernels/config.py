"""The one place that names the Numba option sets used by every kernel.

Kernels import these names instead of spelling ``@njit(...)`` flags themselves, so a
change of policy (caching, fastmath, error model) is made here once.

``cache=True`` is used because a second process really does load these kernels from
``kernels/__pycache__`` (checked by ``tests/test_kernels_cache.py``): without it every
``csw`` invocation would pay several seconds of compilation.
"""

# Per-row workers and helpers: serial, no Python objects, no exceptions raised.
# fastmath stays off: every cost is integer arithmetic and results must be exact.
SERIAL = dict(nogil=True, cache=True, error_model="numpy")

# Inlined helpers: tiny functions called inside hot loops.
INLINE = dict(SERIAL, inline="always")

# Drivers that split rows (or row stripes) over threads with prange.
PARALLEL = dict(SERIAL, parallel=True)

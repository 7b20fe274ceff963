"""The Numba option sets of every worker and entry, named once here (jit/*.py use these
names instead of spelling ``@njit(...)`` flags themselves), so that a change of policy
(fastmath, error model) is made in one place.  No function is cached by Numba: csw
stores each compiled entry itself (kernels/native.py), and loads it without Numba.
"""

# Workers and helpers: serial, no Python objects, no exceptions raised (an entry that
# could raise would need Numba's runtime to report it).  fastmath stays off: every cost
# is integer arithmetic and results must be exact.
SERIAL = dict(nogil=True, error_model="numpy")

# The C-callable entries around the workers.
ENTRY = dict(nopython=True, error_model="numpy")

"""The Numba code of csw's kernels, imported only to compile an entry (kernels/native.py)
or to run the kernels as plain Python with NUMBA_DISABLE_JIT=1.

Each module has ``spec(*variant)``: the worker for one variant and its arguments' layout,
and a row in kernels/catalogue.py, without which it is neither compiled nor loaded.
``options`` names the Numba option sets.
"""

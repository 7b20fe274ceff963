"""csw's compiled kernels: compiled once per CPU, then loaded without Numba; this module
finds each entry (``entry``, ``ensure``) and calls it (``Entry``), the store
(kernels/store.py), the compiler (kernels/compiler.py) and the loader
(kernels/loader.py) doing the rest.

Every kernel has a C-callable entry over raw arrays (see ``jit/``).  The first run that
needs an entry compiles it with Numba and stores its machine code as an object file in
the kernel cache; every later process loads that file with llvmlite (Numba's own code
generator, a small import) and calls the entry through ctypes, which releases the GIL so
that row stripes run in parallel threads.  ``import numba`` (about 0.3 s) and Numba's
cache lookups happen only when something must be compiled.

An entry is named by its kernel and its *variant*: the parameters fixed at compile time
(the cost, the pixel types, which optional maps it makes), so that a run compiles only
what it uses and each entry carries no code for the maps it does not make.

The cache (``cache_dir()``) is one folder per CPU, Python, llvmlite and kernel source:
any change of those gives a new folder, never a stale entry.  Entries are written to a
temporary file and renamed, and a lock beside them makes concurrent first runs compile
each entry once while the others wait.  The process holding the lock compiles what is
missing in worker processes, one per core, since Numba compiles on one.  With
``NUMBA_DISABLE_JIT=1`` the entries run as plain Python (for debugging and coverage),
with the same results.
"""

import ctypes
import os
import time

import numpy as np

from .catalogue import spec_of
from .compiler import compile_missing
from .loader import failed, load
from .signature import Signature
from .store import cache_dir, entry_key, lock, verified

JIT_DISABLED = os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")

# What happened in this process: entries loaded from the cache, and entries compiled.
STATS = {"loaded": 0, "compiled": 0, "compile_seconds": 0.0, "load_seconds": 0.0}


class Entry:
    """A loaded kernel entry: ``entry(**arguments)`` runs it, every array and scalar of
    its signature (kernels/signature.py) by name.  Arrays: C-contiguous numpy arrays of
    the signature's dtypes and dimensions; scalars: ints."""

    def __init__(self, key, signature, function, worker=None):
        self.key, self.signature, self.function = key, signature, function
        self.worker = worker  # the plain-Python worker, with the JIT off
        # What every call needs, made once: a stream calls each entry once per frame,
        # and a small frame's whole match takes a few milliseconds.
        self._names = [a.name for a in signature.arrays] + list(signature.scalars)
        self._checks = [(a.name, a.dtype, a.ndim) for a in signature.arrays]
        ndims = sum(a.ndim for a in signature.arrays)
        self._pointers = ctypes.c_void_p * max(len(signature.arrays), 1)
        self._dims = ctypes.c_int64 * max(ndims, 1)
        self._values = ctypes.c_int64 * max(len(signature.scalars), 1)

    def __call__(self, **arguments):
        return self.bind(**arguments)()

    def _arrays(self, arguments):
        """The array arguments in the signature's order, checked; TypeError else."""
        if len(arguments) != len(self._names) or not all(n in arguments for n in self._names):
            self.signature.ordered(arguments, self.key)  # raises, naming what is wrong
        arrays = []
        for name, dtype, ndim in self._checks:
            array = arguments[name]
            if array.dtype != dtype or array.ndim != ndim or not array.flags.c_contiguous:
                raise TypeError(f"kernel {self.key}: {name} must be C-contiguous {dtype} "
                                f"with {ndim} dimensions, got {array.dtype} {array.shape}")
            arrays.append(array)
        return arrays

    def bind(self, **arguments):
        """A :class:`Bound` call of this entry with these arguments: checked and turned
        into the entry's pointer, dimension and scalar lists once, for a caller that
        calls it again and again on the same buffers (a stream's frames)."""
        return Bound(self, self._arrays(arguments),
                     [int(arguments[n]) for n in self.signature.scalars])


class Bound:
    """An entry's call with its arguments made once: ``bound()`` runs it, and
    ``bound.point(name, array)`` points an array argument at another array of the same
    type and shape (a frame's fresh output).  The arrays stay referenced while bound."""

    def __init__(self, entry, arrays, scalars):
        self.entry, self.arrays, self.scalars = entry, arrays, scalars
        self._slot = {name: i for i, (name, _, _) in enumerate(entry._checks)}
        if entry.function is not None:
            self._pointers = entry._pointers(*map(_address, arrays))
            self._dims = entry._dims(*[d for a in arrays for d in a.shape])
            self._values = entry._values(*scalars)

    def point(self, name, array):
        """Make array argument ``name`` this array (C-contiguous, of the bound one's
        dtype and shape: the dimensions were bound); TypeError else."""
        i = self._slot[name]
        bound = self.arrays[i]
        if array.dtype != bound.dtype or array.shape != bound.shape or \
                not array.flags.c_contiguous:
            raise TypeError(f"kernel {self.entry.key}: {name} must be C-contiguous "
                            f"{bound.dtype} {bound.shape}, got {array.dtype} {array.shape}")
        self.arrays[i] = array
        if self.entry.function is not None:
            self._pointers[i] = _address(array)

    def __call__(self):
        entry = self.entry
        if entry.function is None:  # NUMBA_DISABLE_JIT: the worker is plain Python
            return int(entry.worker(*self.arrays, np.array(self.scalars, np.int64)))
        status = entry.function(self._pointers, self._dims, self._values)
        if failed():
            raise RuntimeError(f"csw's kernel {entry.key} failed: it reached Numba's error "
                               "path, which csw's kernels never take; please report it")
        return status


def _address(array):
    """The address of a C-contiguous array's data.  Through ctypes' view of its buffer it
    takes about 0.3 us, where ``array.ctypes.data`` takes 1 to 1.6 (an entry takes up to
    16 arrays, a default match makes six calls); read-only and empty arrays, which that
    view refuses, take the slow way."""
    try:
        return ctypes.addressof(ctypes.c_char.from_buffer(array))
    except (TypeError, ValueError):
        return array.ctypes.data


_LOADED = {}  # key -> Entry, in this process


def entry(kernel, variant):
    """The entry of ``kernel`` for ``variant`` (a tuple of str/int/bool), loaded from the
    cache or compiled into it."""
    key = entry_key(kernel, variant)
    if key not in _LOADED:
        ensure([(kernel, variant)])
    return _LOADED[key]


def ensure(wanted, progress=None, notice=True):
    """Load every (kernel, variant) of ``wanted``, compiling the missing ones first (one
    notice on stderr when that takes more than about a second); return the seconds
    spent.  Concurrent processes compile each entry once: the others wait for it.
    progress(key, compiled): called for each entry as it is compiled (True) or found.
    notice: say on stderr when a compile is ahead (off for a caller that shows progress)."""
    start = time.perf_counter()
    wanted = [(k, tuple(v)) for k, v in dict.fromkeys((k, tuple(v)) for k, v in wanted)]
    todo = [(k, v) for k, v in wanted if entry_key(k, v) not in _LOADED]
    if not todo:
        return 0.0
    if JIT_DISABLED:
        for kernel, variant in todo:
            spec = spec_of(kernel, variant)
            _LOADED[entry_key(kernel, variant)] = Entry(entry_key(kernel, variant),
                                                        spec.signature, None, spec.worker)
        return time.perf_counter() - start
    folder = cache_dir()
    found = {}  # key -> its verified description
    missing = [(k, v) for k, v in todo if not verified(folder, entry_key(k, v), found)]
    if missing:
        with lock(folder):  # another process may be compiling them: wait, then look again
            missing = [(k, v) for k, v in missing
                       if not verified(folder, entry_key(k, v), found, discard=True)]
            if missing:
                compiling = time.perf_counter()
                STATS["compiled"] += compile_missing(folder, missing, progress, notice)
                STATS["compile_seconds"] += time.perf_counter() - compiling
            for kernel, variant in missing:
                if not verified(folder, entry_key(kernel, variant), found):
                    raise RuntimeError(f"csw could not store the kernel "
                                       f"{entry_key(kernel, variant)} in {folder}")
    loading = time.perf_counter()
    for kernel, variant in todo:
        key = entry_key(kernel, variant)
        _LOADED[key] = Entry(key, Signature.from_description(found[key]),
                             load(folder, key, found[key]))
        STATS["loaded"] += 1
        if progress is not None and (kernel, variant) not in missing:
            progress(key, False)
    STATS["load_seconds"] += time.perf_counter() - loading
    return time.perf_counter() - start


def clear():
    """Forget the entries loaded in this process (tests: to load them again)."""
    _LOADED.clear()

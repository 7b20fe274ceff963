"""The calling contract of a compiled kernel entry, written once per kernel.

A kernel's jit module declares, in one :class:`Signature`, its arrays by name (with
dtype and rank) and its int64 scalars by name.  From that record derive:

  the compiled entry     ``entry(arrays, dims, scalars)``, C-callable: a pointer per
                         array, the arrays' dimensions in order, then the scalars
                         (jit/build.py writes the wrapper from the signature)
  the worker's reading   ``sc[SC.name]``, SC = :func:`scalar_index` of the names, so a
                         worker never counts positions by hand
  the call site          ``entry(name=array, ..., name=number)``, by keyword
                         (kernels/native.py orders them and checks every array)
  the stored entry       its description in the kernel cache names the same arrays
                         and scalars, so a loaded entry is checked without Numba

No Numba here: the loader and the call sites import this module, the compiler too.
"""

from collections import namedtuple
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Arg:
    """One array argument: its name, dtype and number of dimensions."""

    name: str
    dtype: np.dtype
    ndim: int


def arg(name, dtype, ndim):
    return Arg(name, np.dtype(dtype), int(ndim))


@dataclass(frozen=True)
class Signature:
    """A kernel entry's arguments: ``arrays`` (Arg, in order) and ``scalars`` (names of
    int64 values, in order)."""

    arrays: tuple
    scalars: tuple

    def ordered(self, named, key="kernel"):
        """(arrays, scalars) in the entry's order from keyword arguments ``named``;
        TypeError naming what is missing or unknown."""
        names = [a.name for a in self.arrays] + list(self.scalars)
        if set(named) != set(names):
            missing = [n for n in names if n not in named]
            unknown = sorted(set(named) - set(names))
            raise TypeError(f"kernel {key}: missing {missing}, unknown {unknown}")
        return [named[a.name] for a in self.arrays], [named[n] for n in self.scalars]

    def describe(self):
        """The signature as JSON-ready lists (stored beside a compiled entry)."""
        return {"arrays": [[a.name, a.dtype.str, a.ndim] for a in self.arrays],
                "scalars": list(self.scalars)}

    @classmethod
    def from_description(cls, meta):
        return cls(tuple(arg(n, d, k) for n, d, k in meta["arrays"]), tuple(meta["scalars"]))


def scalar_index(names):
    """A named tuple of each scalar's position: workers read ``sc[SC.window]`` (Numba
    takes a global named tuple as a compile-time constant)."""
    return namedtuple("Scalars", names)(*range(len(names)))


@dataclass(frozen=True)
class Spec:
    """What a jit module builds for a variant: ``worker(*arrays, sc) -> int`` (a Numba
    function, or plain Python with the JIT off) and its :class:`Signature`."""

    worker: object
    signature: Signature


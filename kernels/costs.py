"""The costs, in one table: what each compares, what its compiled workers compute, and
the largest cost one pixel adds, from which the engines' accumulator types
(``accumulator_dtype``; semi-global matching's in kernels/catalogue.py) and the
semi-global penalties follow.  Every driver and the catalogue (kernels/catalogue.py)
read it; a cost it does not hold raises, never falls back to another.

  sad     sum of absolute differences of the pixels
  ssd     sum of squared differences of the pixels
  shd     sum of Hamming distances of the pixels' bits
  census  shd over census codes (kernels/census.py): each pixel becomes a code with
          one bit per neighbour of its census window, set where the neighbour is darker
          than the centre

No Numba here, and nothing of the kernels': contract.py re-exports the codes.
"""

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

# The codes the kernels' records carry (contract.MatchParams.cost).
SAD, SSD, SHD, CENSUS = 0, 1, 2, 3


@dataclass(frozen=True)
class Cost:
    """One cost.

    name: the option's value.  code: its code in the kernels' records.  worker: the cost
    the compiled workers compute on what it compares ("sad", "ssd" or "shd": the jit
    modules' variants name it).  census: it compares census codes, not the pixels.
    largest(top, bits): the largest cost one compared pixel adds, from the compared
    type's largest value and its bits (a census code's: the pattern's).
    penalties(area, scale, bits): semi-global matching's default (P1, P2) for a window
    of ``area`` pixels, ``scale`` 1 for 8-bit images and 257 for 16-bit ones, ``bits``
    a compared pixel's bits (as OpenCV scales its penalties to its block).
    """

    name: str
    code: int
    worker: str
    census: bool
    largest: Callable[[int, int], int]
    penalties: Callable[[int, int, int], tuple]

    def per_pixel(self, compared, bits=None):
        """The largest cost one pixel of type ``compared`` adds (``bits``: a census
        code's, else the type's)."""
        info = np.iinfo(compared)
        return self.largest(int(info.max), int(info.bits if bits is None else bits))


def _hamming_penalties(area, scale, bits):
    # a quarter of the code's bits and all of them per window pixel
    return max(1, bits * area // 4), bits * area


COSTS_TABLE = (
    Cost("sad", SAD, "sad", False, lambda top, bits: top,
         lambda area, scale, bits: (8 * area * scale, 32 * area * scale)),  # OpenCV's
    Cost("ssd", SSD, "ssd", False, lambda top, bits: top * top,
         lambda area, scale, bits: (64 * area * scale * scale, 1024 * area * scale * scale)),
    Cost("shd", SHD, "shd", False, lambda top, bits: bits, _hamming_penalties),
    Cost("census", CENSUS, "shd", True, lambda top, bits: bits, _hamming_penalties),
)
COSTS = {cost.name: cost.code for cost in COSTS_TABLE}  # name -> code
_BY_CODE = {cost.code: cost for cost in COSTS_TABLE}


def cost_named(name):
    """The Cost called ``name``; ValueError naming the costs there are."""
    for cost in COSTS_TABLE:
        if cost.name == name:
            return cost
    raise ValueError(f"cost must be one of {', '.join(COSTS)}, got {name!r}")


@functools.cache
def accumulator_dtype(compared, cost, window):
    """The narrowest integer type that holds every window cost of the local engines
    exactly (kernels/fast.py), for images (or census codes) of type ``compared`` and a
    cost code; ValueError for a code the table does not hold."""
    largest = cost_coded(cost).per_pixel(compared) * window * window
    # Strictly below the maximum: the maximum itself marks blocked candidates.
    for dtype in (np.uint16, np.int32, np.int64):
        if largest < np.iinfo(dtype).max:
            return np.dtype(dtype)
    raise ValueError("window too large for exact 64-bit costs")


def cost_coded(code):
    """The Cost whose code is ``code``; ValueError if there is none."""
    try:
        return _BY_CODE[code]
    except (KeyError, TypeError):
        raise ValueError(f"no cost has the code {code!r}; the costs are "
                         f"{', '.join(f'{c.name} {c.code}' for c in COSTS_TABLE)}") from None

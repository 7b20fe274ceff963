"""The census transform: each pixel becomes a code with one bit per neighbour in its
census window, set where the neighbour is darker than the centre.

Bits run over the window row by row, left to right, the centre skipped, the first
neighbour in the most significant bit.  Pixels outside the image take the nearest edge
pixel's value, as in the matching contract.  Matching census codes with SHD (Hamming
distance summed over the matching window) is the census cost.

Layers:
  census_transform   public: validate, pad, allocate
  _census_driver     parallel over rows; each row writes only its own codes
"""

import numpy as np
from numba import njit, prange

from .config import PARALLEL
from .contract import census_dtype


@njit(**PARALLEL)
def _census_driver(image_p, size, codes):
    """image_p: uint8/uint16 (H + size - 1, W + size - 1), edge-padded by size // 2.
    codes: (H, W) out, of the code dtype (census_dtype(size)).

    Each row is built one neighbour at a time across the whole row (shift in one bit per
    pixel), so the loop over x vectorises instead of running a serial chain per pixel.
    """
    h = size // 2
    height, width = codes.shape
    one = codes.dtype.type(1)
    zero = codes.dtype.type(0)
    for y in prange(height):
        row = codes[y]
        row[:] = 0
        centre = image_p[y + h, h:h + width]
        for a in range(size):
            for b in range(size):
                if a == h and b == h:
                    continue
                neighbour = image_p[y + a, b:b + width]
                for x in range(width):
                    row[x] = (row[x] << one) | (one if neighbour[x] < centre[x] else zero)


def census_transform(image, size):
    """Census codes of a uint8/uint16 (H, W) image with a size x size window (odd, 3..7):
    an (H, W) array of the narrowest unsigned type holding size*size - 1 bits."""
    image = np.ascontiguousarray(image)
    dtype = census_dtype(size)
    padded = np.pad(image, size // 2, mode="edge")
    codes = np.empty(image.shape, dtype)
    _census_driver(padded, size, codes)
    return codes

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
    codes: (H, W) out, of the code dtype (census_dtype(size))."""
    h = size // 2
    height, width = codes.shape
    for y in prange(height):
        for x in range(width):
            centre = image_p[y + h, x + h]
            code = np.uint64(0)
            for a in range(size):
                for b in range(size):
                    if a == h and b == h:
                        continue
                    darker = np.uint64(1) if image_p[y + a, x + b] < centre else np.uint64(0)
                    code = (code << np.uint64(1)) | darker
            codes[y, x] = code


def census_transform(image, size):
    """Census codes of a uint8/uint16 (H, W) image with a size x size window (odd, 3..7):
    an (H, W) array of the narrowest unsigned type holding size*size - 1 bits."""
    image = np.ascontiguousarray(image)
    dtype = census_dtype(size)
    padded = np.pad(image, size // 2, mode="edge")
    codes = np.empty(image.shape, dtype)
    _census_driver(padded, size, codes)
    return codes

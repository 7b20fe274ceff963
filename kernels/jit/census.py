"""The census transform's worker (see kernels/census.py): each pixel becomes a code with
one bit per neighbour of its census window, set where the neighbour is darker than the
centre; bits run over the window row by row, the centre skipped, the first neighbour in
the most significant bit."""

import numpy as np
from numba import njit

from ..config import SERIAL
from .common import dtype_of


def spec(pixels, codes):
    """The worker for images of type ``pixels`` and codes of type ``codes``."""
    from ..native import Spec

    arrays = ((dtype_of(pixels), 2), (dtype_of(codes), 2), (np.dtype(np.uint8), 1))
    return Spec(_make(dtype_of(codes).type), arrays, 5)


def _make(code):
    """The worker for codes of numpy type ``code`` (a compile-time constant)."""

    @njit(**SERIAL)
    def rows(image_p, codes, byte, sc):
        """Codes of rows sc[1] <= y < sc[2] for a census window of side sc[0], written
        into codes edge-padded by sc[3] columns each side (and rows, which the caller
        fills) and, with sc[4], with the columns reversed: the layouts the engines read.

        image_p: (H + size - 1, W + size - 1), edge-padded by size // 2.  codes: (H + 2p,
        W + 2p) out, p = sc[3].  byte: uint8 (W,) scratch.  The bits are built eight
        neighbours at a time in a byte per pixel (one neighbour across the whole row at a
        time, so the loop over x runs in 8-bit SIMD lanes) and each byte then shifted into
        place: the code is the bytes in neighbour order, the first one most significant.
        """
        size, y0, y1, pad, reverse = sc[0], sc[1], sc[2], sc[3], sc[4]
        h = size // 2
        width = codes.shape[1] - 2 * pad
        zero = code(0)
        groups = (size * size - 1) // 8  # size * size - 1 is a multiple of 8 for odd sizes
        for y in range(y0, y1):
            padded = codes[y + pad]
            row = padded[pad:pad + width]
            row[:] = zero
            centre = image_p[y + h, h:h + width]
            i = 0
            for a in range(size):
                for b in range(size):
                    if a == h and b == h:
                        continue
                    neighbour = image_p[y + a, b:b + width]
                    if i % 8 == 0:
                        byte[:] = 0
                    for x in range(width):
                        byte[x] = (byte[x] << 1) | (neighbour[x] < centre[x])
                    i += 1
                    if i % 8 == 0:
                        shift = code(8 * (groups - i // 8))
                        for x in range(width):
                            row[x] = row[x] | (code(byte[x]) << shift)
            for x in range(pad):  # the edge codes, replicated
                padded[x] = row[0]
                padded[pad + width + x] = row[width - 1]
            if reverse:
                n = padded.shape[0]
                for x in range(n // 2):
                    padded[x], padded[n - 1 - x] = padded[n - 1 - x], padded[x]
        return 0

    return rows

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

    arrays = ((dtype_of(pixels), 2), (dtype_of(codes), 2), (np.dtype(np.uint8), 2))
    return Spec(_make(dtype_of(codes).type), arrays, 5)


def _make(code):
    """The worker for codes of numpy type ``code`` (a compile-time constant)."""

    @njit(**SERIAL)
    def rows(image_p, codes, planes, sc):
        """Codes of rows sc[1] <= y < sc[2] for a census window of side sc[0], written
        into codes edge-padded by sc[3] columns each side (and rows, which the caller
        fills) and, with sc[4], with the columns reversed: the layouts the engines read.

        image_p: (H + size - 1, W + size - 1), edge-padded by size // 2.  codes: (H + 2p,
        W + 2p) out, p = sc[3].  planes: uint8 ((size * size - 1) // 8, W) scratch.  The
        bits are built eight neighbours at a time in a byte plane (one neighbour across
        the whole row at a time, so the loop over x runs in 8-bit SIMD lanes); one pass
        then joins the planes into codes, the first plane most significant, and writes
        them in the order asked for.
        """
        size, y0, y1, pad, reverse = sc[0], sc[1], sc[2], sc[3], sc[4]
        h = size // 2
        width = codes.shape[1] - 2 * pad
        groups = planes.shape[0]  # size * size - 1 is a multiple of 8 for odd sizes
        for y in range(y0, y1):
            padded = codes[y + pad]
            centre = image_p[y + h, h:h + width]
            i = 0
            for a in range(size):
                for b in range(size):
                    if a == h and b == h:
                        continue
                    neighbour = image_p[y + a, b:b + width]
                    byte = planes[i // 8]
                    if i % 8 == 0:
                        for x in range(width):
                            byte[x] = neighbour[x] < centre[x]
                    else:
                        for x in range(width):
                            byte[x] = (byte[x] << 1) | (neighbour[x] < centre[x])
                    i += 1
            out = padded[pad:pad + width]
            if groups == 6:  # 7 x 7, the default: the join written out vectorises
                p0, p1, p2, p3, p4, p5 = planes[0], planes[1], planes[2], planes[3], \
                    planes[4], planes[5]
                for x in range(width):
                    out[x] = ((code(p0[x]) << code(40)) | (code(p1[x]) << code(32)) |
                              (code(p2[x]) << code(24)) | (code(p3[x]) << code(16)) |
                              (code(p4[x]) << code(8)) | code(p5[x]))
            else:
                out[:] = 0
                for g in range(groups):
                    plane = planes[g]
                    for x in range(width):
                        out[x] = (out[x] << code(8)) | code(plane[x])
            for x in range(pad):  # the edge codes, replicated
                padded[x] = out[0]
                padded[pad + width + x] = out[width - 1]
            if reverse:
                n = padded.shape[0]
                for x in range(n // 2):
                    padded[x], padded[n - 1 - x] = padded[n - 1 - x], padded[x]
        return 0

    return rows

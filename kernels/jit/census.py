"""The census transform's worker (see kernels/census.py): each pixel becomes a code with
one bit per neighbour of its census pattern (see contract.census_places), set where the
neighbour is darker than the centre; the first neighbour in the most significant bit."""

import numpy as np
from numba import njit

from ..signature import Signature, Spec, arg, scalar_index
from .common import dtype_of
from .options import SERIAL

# The scalars of a stripe (the entry's record; see kernels/signature.py).
SC = scalar_index(("size", "y0", "y1", "pad", "reverse"))


def spec(pixels, codes):
    """The worker for images of type ``pixels`` and codes of type ``codes``."""
    arrays = (arg("image_p", dtype_of(pixels), 2), arg("codes", dtype_of(codes), 2),
              arg("planes", np.uint8, 2), arg("places", np.int64, 1))
    return Spec(_make(dtype_of(codes).type), Signature(arrays, SC._fields))


@njit(**SERIAL)
def _neighbour(image_p, y, place, size, width):
    """The row of the neighbour at ``place`` (row-major in the window) of image row y's
    census windows: (width,) from image_p, edge-padded by size // 2."""
    return image_p[y + place // size, place % size:place % size + width]


def _make(code):
    """The worker for codes of numpy type ``code`` (a compile-time constant)."""

    @njit(**SERIAL)
    def rows(image_p, codes, planes, places, sc):
        """Codes of rows y0 <= y < y1 for a census window of side ``size``, written into
        codes edge-padded by ``pad`` columns and rows each side (the stripes holding the
        first and last rows write the rows beyond them) and, with ``reverse``, with the
        columns reversed: the layouts the engines read (sc: SC).

        image_p: (H + size - 1, W + size - 1), edge-padded by size // 2.  codes: (H + 2p,
        W + 2p) out, p = pad.  places: int64 (n,) the neighbours' places in the window,
        in bit order, n a multiple of 8.  planes: uint8 (n // 8, W) scratch.  Each byte
        plane takes eight neighbours in one pass over the row (8-bit SIMD lanes; a pass
        per neighbour cost twice as long, in loop set-up); one pass then joins the planes
        into codes, the first plane most significant.
        """
        size, y0, y1, pad, reverse = sc[SC.size], sc[SC.y0], sc[SC.y1], sc[SC.pad], \
            sc[SC.reverse]
        h = size // 2
        height, width = codes.shape[0] - 2 * pad, codes.shape[1] - 2 * pad
        groups = planes.shape[0]
        for y in range(y0, y1):
            padded = codes[y + pad]
            centre = image_p[y + h, h:h + width]
            for g in range(groups):
                at = places[8 * g:8 * g + 8]  # the group's neighbours
                n0, n1 = _neighbour(image_p, y, at[0], size, width), \
                    _neighbour(image_p, y, at[1], size, width)
                n2, n3 = _neighbour(image_p, y, at[2], size, width), \
                    _neighbour(image_p, y, at[3], size, width)
                n4, n5 = _neighbour(image_p, y, at[4], size, width), \
                    _neighbour(image_p, y, at[5], size, width)
                n6, n7 = _neighbour(image_p, y, at[6], size, width), \
                    _neighbour(image_p, y, at[7], size, width)
                byte = planes[g]
                for x in range(width):
                    c = centre[x]
                    byte[x] = (((n0[x] < c) << 7) | ((n1[x] < c) << 6) | ((n2[x] < c) << 5) |
                               ((n3[x] < c) << 4) | ((n4[x] < c) << 3) | ((n5[x] < c) << 2) |
                               ((n6[x] < c) << 1) | (n7[x] < c))
            out = padded[pad:pad + width]
            # The joins of the usual codes written out, which vectorises.
            if groups == 4:  # 32 bits: the sparse 9 x 9 of the default pipeline
                p0, p1, p2, p3 = planes[0], planes[1], planes[2], planes[3]
                for x in range(width):
                    out[x] = code((code(p0[x]) << code(24)) | (code(p1[x]) << code(16)) |
                                  (code(p2[x]) << code(8)) | code(p3[x]))
            elif groups == 6:  # dense 7 x 7
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
            # The rows beyond the image: copies of the first and last rows' codes.
            # (Element by element: Numba copies a slice assignment's source first.)
            if y == 0:
                for r in range(pad):
                    for x in range(padded.shape[0]):
                        codes[r, x] = padded[x]
            if y == height - 1:
                for r in range(pad):
                    for x in range(padded.shape[0]):
                        codes[height + pad + r, x] = padded[x]
        return 0

    return rows

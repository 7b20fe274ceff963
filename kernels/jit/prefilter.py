"""The x-Sobel prefilter's worker (see kernels/prefilter.py): StereoBM's 3x3 x-Sobel
response, clipped to +-cap and offset by cap into bytes, with edge-replicated borders."""

import numpy as np
from numba import njit

from ..signature import Signature, Spec, arg, scalar_index
from .common import dtype_of
from .options import SERIAL

# The scalars of a stripe of rows (the entry's record; see kernels/signature.py).
SC = scalar_index(("y0", "y1", "cap"))


def spec(pixels):
    """The worker for images of type ``pixels`` (uint8 or uint16): image (H, W), out
    uint8 (H, W)."""
    image = dtype_of(pixels)
    arrays = (arg("image", image, 2), arg("out", np.dtype(np.uint8), 2))
    # An 8-bit image's response (at most 4 x 255) fits 16-bit lanes, twice as many to a
    # vector as 32-bit ones; a 16-bit image's (4 x 65535) needs 32.
    return Spec(_make(np.int16 if image.itemsize == 1 else np.int32),
                Signature(arrays, SC._fields))


def _make(lane):
    """The worker computing in integers of numpy type ``lane`` (a compile-time
    constant)."""

    @njit(**SERIAL)
    def response(up_a, up_b, mid_a, mid_b, down_a, down_b):
        """The x-Sobel response from the pixels of the columns left (a) and right (b) of
        it in the rows above, its own and below."""
        return lane(lane(up_b) - lane(up_a) + lane(2) * (lane(mid_b) - lane(mid_a))
                    + lane(down_b) - lane(down_a))

    @njit(**SERIAL)
    def clipped(value, cap):
        return np.uint8(min(max(value, -cap), cap) + cap)

    @njit(**SERIAL)
    def xsobel_rows(image, out, sc):
        """out[y, x] = clip(gx, -cap, cap) + cap for the rows y0 <= y < y1 (sc: SC), gx
        the 3x3 x-Sobel response of image (H, W) with its rows and columns
        edge-replicated."""
        height, width = image.shape
        cap = lane(sc[SC.cap])
        for y in range(sc[SC.y0], sc[SC.y1]):
            up, mid = image[max(y - 1, 0)], image[y]
            down, row = image[min(y + 1, height - 1)], out[y]
            # The edge columns take their own pixel in place of the missing neighbour.
            b = min(1, width - 1)
            row[0] = clipped(response(up[0], up[b], mid[0], mid[b], down[0], down[b]), cap)
            # The inner columns through views from 0 (column x + 1 reads ul[x], up[x], and
            # ur[x], up[x + 2]): an index x - 1 may be negative for all Numba knows, and
            # its wraparound test at every access kept the loop from vectorising.
            inner = width - 2
            ul, ml, dl, ur, mr, dr = up[:inner], mid[:inner], down[:inner], up[2:], \
                mid[2:], down[2:]
            within = row[1:width - 1]
            for x in range(inner):
                within[x] = clipped(response(ul[x], ur[x], ml[x], mr[x], dl[x], dr[x]), cap)
            if width > 1:
                a, b = width - 2, width - 1
                row[b] = clipped(response(up[a], up[b], mid[a], mid[b], down[a], down[b]),
                                 cap)
        return 0

    return xsobel_rows

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
    def response(up, mid, down, a, b):
        """The x-Sobel response of the pixel between columns a (left) and b (right)."""
        return lane(lane(up[b]) - lane(up[a]) + lane(2) * (lane(mid[b]) - lane(mid[a]))
                    + lane(down[b]) - lane(down[a]))

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
            row[0] = clipped(response(up, mid, down, 0, min(1, width - 1)), cap)
            for x in range(1, width - 1):
                row[x] = clipped(response(up, mid, down, x - 1, x + 1), cap)
            if width > 1:
                row[width - 1] = clipped(response(up, mid, down, width - 2, width - 1), cap)
        return 0

    return xsobel_rows

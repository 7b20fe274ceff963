"""The x-Sobel prefilter's worker (see kernels/prefilter.py): StereoBM's 3x3 x-Sobel
response, clipped to +-cap and offset by cap into bytes, with edge-replicated borders."""

import numpy as np
from numba import njit

from ..config import SERIAL
from ..signature import Signature, Spec, arg, scalar_index
from .common import dtype_of

# The scalars of a stripe of rows (the entry's record; see kernels/signature.py).
SC = scalar_index(("y0", "y1", "cap"))


def spec(pixels):
    """The worker for images of type ``pixels`` (uint8 or uint16): image (H, W), out
    uint8 (H, W)."""
    image = dtype_of(pixels)
    arrays = (arg("image", image, 2), arg("out", np.dtype(np.uint8), 2))
    return Spec(xsobel_rows, Signature(arrays, SC._fields))


@njit(**SERIAL)
def _response(up, mid, down, a, b):
    """The x-Sobel response of the pixel between columns a (left) and b (right), in
    int32: a 16-bit image's response (at most 4 x 65535) fits, and 32-bit lanes keep the
    loop vectorised where NumPy's version took five passes in int32 and int64."""
    return (np.int32(up[b]) - np.int32(up[a]) + 2 * (np.int32(mid[b]) - np.int32(mid[a]))
            + np.int32(down[b]) - np.int32(down[a]))


@njit(**SERIAL)
def xsobel_rows(image, out, sc):
    """out[y, x] = clip(gx, -cap, cap) + cap for the rows y0 <= y < y1 (sc: SC), gx the
    3x3 x-Sobel response of image (H, W) with its rows and columns edge-replicated."""
    height, width = image.shape
    cap = np.int32(sc[SC.cap])
    for y in range(sc[SC.y0], sc[SC.y1]):
        up, mid = image[max(y - 1, 0)], image[y]
        down, row = image[min(y + 1, height - 1)], out[y]
        # The two edge columns take their own neighbour in place of the missing one.
        row[0] = min(max(_response(up, mid, down, 0, min(1, width - 1)), -cap), cap) + cap
        for x in range(1, width - 1):
            row[x] = min(max(_response(up, mid, down, x - 1, x + 1), -cap), cap) + cap
        if width > 1:
            last = width - 1
            row[last] = min(max(_response(up, mid, down, last - 1, last), -cap), cap) + cap
    return 0

"""The edge padding's worker (see kernels/contract.pad_edge and the plans of
kernels/census.py and kernels/fast.py): an image copied into a frame of its own edge
pixels, its columns reversed on request."""

from numba import njit

from ..signature import Signature, Spec, arg, scalar_index
from .common import dtype_of
from .options import SERIAL

# The scalars (the entry's record; see kernels/signature.py).
SC = scalar_index(("h", "reverse"))


def spec(pixels):
    """The worker for images of type ``pixels``: image (H, W), out (H + 2h, W + 2h)."""
    image = dtype_of(pixels)
    return Spec(pad, Signature((arg("image", image, 2), arg("out", image, 2)), SC._fields))


@njit(**SERIAL)
def pad(image, out, sc):
    """out = the image padded by h on every side with its nearest edge pixel, and with
    reverse its columns reversed (the padded image of image[:, ::-1]); sc: SC."""
    h, reverse = sc[SC.h], sc[SC.reverse] != 0
    height, width = image.shape
    for y in range(out.shape[0]):
        source = image[min(max(y - h, 0), height - 1)]
        if reverse:
            source = source[::-1]
        # Views indexed from 0: an index offset by a scalar may be negative for all
        # Numba knows, and its wraparound test at every access kept the copy from
        # vectorising (5x slower).
        row = out[y]
        before, inside, after = row[:h], row[h:h + width], row[h + width:]
        first, last = source[0], source[width - 1]
        for x in range(h):
            before[x] = first
            after[x] = last
        for x in range(width):
            inside[x] = source[x]
    return 0

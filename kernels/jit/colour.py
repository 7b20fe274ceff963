"""The colour conversion's worker (see kernels/colour.py): the ITU-R 601-2 luma of RGB
pixels, rounded as Pillow's convert("L") rounds it."""

import numpy as np
from numba import njit

from ..signature import Signature, Spec, arg, scalar_index
from .common import dtype_of
from .options import SERIAL

# The scalars of a stripe of rows (the entry's record; see kernels/signature.py).
SC = scalar_index(("y0", "y1"))


def spec(pixels, channels):
    """The worker for (H, W, channels) RGB (3) or RGBA (4; alpha is not read) images of
    type ``pixels`` (uint8 or uint16)."""
    image = dtype_of(pixels)
    arrays = (arg("rgb", image, 2), arg("out", image, 2))  # (H, W * channels), (H, W)
    return Spec(_make(image.type, int(channels)), Signature(arrays, SC._fields))


def _make(pixel, channels):
    """The worker for pixels of numpy type ``pixel`` and ``channels`` a pixel
    (compile-time constants: a pixel's stride known to LLVM lets it load the channels of
    many pixels at once and take them apart in registers; as a run-time value it read
    them one by one, at about 1.8 ns a pixel)."""

    @njit(**SERIAL)
    def rows(rgb, out, sc):
        """out[y, x] = (R * 19595 + G * 38470 + B * 7471 + 0x8000) >> 16 of rgb[y, x] for
        the rows y0 <= y < y1 (sc: SC).  rgb: (H, W * channels), each row's pixels'
        channels in turn; out: (H, W), of one type.
        The sum stays within 32 bits unsigned for 16-bit pixels too (at most
        65535 * 65536 + 0x8000), so it runs in 32-bit lanes."""
        width = out.shape[1]
        for y in range(sc[SC.y0], sc[SC.y1]):
            pixels, row = rgb[y], out[y]
            for x in range(width):
                at = x * channels
                total = (np.uint32(pixels[at]) * np.uint32(19595) +
                         np.uint32(pixels[at + 1]) * np.uint32(38470) +
                         np.uint32(pixels[at + 2]) * np.uint32(7471) + np.uint32(0x8000))
                row[x] = pixel(total >> np.uint32(16))
        return 0

    return rows

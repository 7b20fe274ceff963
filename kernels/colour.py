"""Colour to gray: the ITU-R 601-2 luma of an RGB image, in parallel stripes of rows,
rounded as Pillow's convert("L") rounds it.  The worker is kernels/jit/colour.py."""

import numpy as np

from . import native, runtime
from .catalogue import entry

# About 0.6 ns a pixel in one thread, in runtime.DIRECT_WORK's units: images from about
# 17 MP up run in stripes (below that, starting threads costs more than it saves).
LUMA_WORK = 3


def luma(rgb, threads=None):
    """(H, W) luma of an (H, W, 3) RGB or (H, W, 4) RGBA image, uint8 or uint16, of its
    type: (R * 19595 + G * 38470 + B * 7471 + 0x8000) >> 16, as Pillow's convert("L");
    alpha is dropped.  threads: as for csw.match."""
    rgb = np.ascontiguousarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] not in (3, 4) or rgb.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"luma takes an (H, W, 3) or (H, W, 4) uint8 or uint16 image, got "
                         f"{rgb.dtype} {rgb.shape}")
    height, width = rgb.shape[:2]
    out = np.empty((height, width), rgb.dtype)
    run = native.entry(*entry("colour", rgb.dtype, rgb.shape[2]))
    work = height * width * LUMA_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)
    rows = rgb.reshape(height, -1)  # a view: the worker reads each row's channels in turn
    runtime.run_stripes(lambda i, stop: run(rgb=rows, out=out, y0=edges[i], y1=edges[i + 1]),
                        count, count, work)
    return out

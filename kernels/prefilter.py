"""StereoBM's x-Sobel prefilter in one compiled pass over stripes of rows (the worker is
kernels/jit/prefilter.py): where NumPy's five passes (pad, widen, differences, clip,
narrow) took about a quarter of a SAD match's time, this takes a few percent."""

import numpy as np

from . import native, runtime
from .catalogue import entry

# About a nanosecond a pixel in one thread, in runtime.DIRECT_WORK's units: images up to
# several megapixels run in the calling thread (below that, threads cost more than they
# save).
XSOBEL_WORK = 5


def xsobel(image, cap, out=None, threads=None):
    """uint8 (H, W): the 3x3 x-Sobel response of ``image`` (uint8 or uint16 (H, W)),
    edge-replicated, clipped to [-cap, cap] and offset by cap (0..2 cap; cap 1..127).
    out: uint8 (H, W) to write into (C-contiguous), or None.  threads: as for
    csw.match."""
    image = np.ascontiguousarray(image)
    if image.ndim != 2 or image.dtype not in (np.uint8, np.uint16) or 0 in image.shape:
        raise ValueError(f"xsobel takes a non-empty (H, W) uint8 or uint16 image, got "
                         f"{image.dtype} {image.shape}")
    if not 1 <= int(cap) <= 127:
        raise ValueError(f"xsobel's cap must be from 1 to 127, got {cap!r}")
    height, width = image.shape
    if out is None:
        out = np.empty((height, width), np.uint8)
    run = native.entry(*entry("prefilter", image.dtype))
    work = height * width * XSOBEL_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)
    runtime.run_stripes(lambda i, stop: run(image=image, out=out, y0=edges[i],
                                            y1=edges[i + 1], cap=int(cap)),
                        count, count, work)
    return out

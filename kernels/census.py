"""The census transform: each pixel becomes a code with one bit per neighbour of its
census pattern in its census window, set where the neighbour is darker than the centre.

The dense pattern takes every neighbour, the sparse one every second pixel of every
second row and the centre's 8 neighbours (contract.census_places).  Bits run over the
window row by row, left to right, the centre skipped, the first neighbour in the most
significant bit.  Pixels outside the image take the nearest edge pixel's value, as in
the matching contract.  Matching census codes with SHD (Hamming distance summed over
the matching window) is the census cost.

Layers:
  census_transform   public: pad, allocate, run the stripes of rows in parallel
  census_pair        a pair's two transforms, side by side where that pays
  jit/census.py      the worker over a stripe of rows
"""

import functools

import numpy as np

from . import native, runtime
from .catalogue import entry
from .contract import (
    CENSUS,
    SHD,
    census_dtype,
    census_places,
    pad_edge,
)
from .pad import Padder
from .workspace import empty


def census_transform(image, size, threads=None, pad=0, reverse=False, out=None, *,
                     pattern, workspace=None):
    """Census codes of a uint8/uint16 (H, W) image with a size x size window (odd) and a
    pattern ("dense" or "sparse"): an (H, W) array of the narrowest unsigned type holding
    the pattern's bits (at most 64: dense up to 7 x 7, sparse up to 15 x 15).

    pad, reverse: the codes edge-padded by ``pad`` on every side, (H + 2 pad, W + 2 pad),
    and with reverse, their columns reversed: the layouts the engines read, written in
    place rather than copied.  out: the array to write them into (of that shape and
    type, C-contiguous), else a new one.  workspace: a kernels.workspace.Workspace for
    the image's padded copy, else a new one."""
    image = np.ascontiguousarray(image)
    height, width = image.shape
    h = size // 2
    padded = pad_edge(image, h, image.dtype,
                      out=empty(workspace, "census-image", (height + 2 * h, width + 2 * h),
                                image.dtype))
    shape = (height + 2 * pad, width + 2 * pad)
    codes = np.empty(shape, census_dtype(size, pattern)) if out is None else out
    run = native.entry(*entry("census", image.dtype, size, pattern))
    places = _places_array(size, pattern)
    n_threads = runtime.thread_count(threads)
    work = height * width * len(places)
    count = 1 if work < runtime.DIRECT_WORK else min(n_threads, height)
    edges = runtime.even_split(height, count)

    def stripe(i, stop):
        return run(**_arguments(padded, codes, size, pattern, edges[i], edges[i + 1], pad,
                                reverse))

    runtime.run_stripes(stripe, count, count, work)
    return codes


def census_pair(left, right, size, threads=None, pad=0, *, pattern):
    """(census_transform(left, ...), census_transform(right, ..., reverse=True)), both
    padded by ``pad``: the two images side by side, one a thread, where each alone would
    run in one thread but takes long enough (PAIR_WORK: a KITTI frame's 0.3 ms) for two
    threads to pay."""
    work = left.shape[0] * left.shape[1] * len(_places_array(size, pattern))
    if runtime.thread_count(threads) == 1 or not PAIR_WORK <= work < runtime.DIRECT_WORK:
        return (census_transform(left, size, threads, pad, pattern=pattern),
                census_transform(right, size, threads, pad, reverse=True, pattern=pattern))
    images = (left, right)
    return tuple(runtime.run_stripes(
        lambda i, stop: census_transform(images[i], size, 1, pad, reverse=i == 1,
                                         pattern=pattern), 2, 2, 2 * work, 0))


# An image's census work (pixels x the pattern's places) from which census_pair runs
# the two images side by side: about 0.3 ms each (KITTI's 1242 x 375, sparse 9 x 9:
# 11 million), where handing one to the pool costs about 0.1 ms.
PAIR_WORK = runtime.DIRECT_WORK // 10


def _arguments(padded, codes, size, pattern, y0, y1, pad, reverse):
    """The worker's arguments for rows y0..y1 of the image padded by size // 2 (its
    scratch made here, in the stripe's own thread)."""
    places = _places_array(size, pattern)
    width = padded.shape[1] - 2 * (size // 2)
    return dict(image_p=padded, codes=codes, planes=np.empty((len(places) // 8, width), np.uint8),
                places=places, size=size, y0=y0, y1=y1, pad=pad, reverse=int(reverse))


def fits_one_stripe(shape, size, pattern):
    """Whether census_transform runs an image of ``shape`` as one stripe, in the calling
    thread (what a :class:`CensusCall` does)."""
    return shape[0] * shape[1] * len(_places_array(size, pattern)) < runtime.DIRECT_WORK


class CensusCall:
    """census_transform of many images of one shape and type, made once: the padded
    copy, the codes and the bound call (a stream's small frames, whose whole match takes
    a few milliseconds).  ``call(image)`` writes the codes into ``call.codes`` (H + 2 pad,
    W + 2 pad), equal to census_transform's with the same arguments, in the calling
    thread as one stripe (for images :func:`fits_one_stripe` accepts)."""

    def __init__(self, shape, pixels, size, pattern, pad=0, reverse=False):
        height, width = shape
        h = size // 2
        self.padded = np.empty((height + 2 * h, width + 2 * h), pixels)
        self.padder = Padder(shape, pixels, h, self.padded)
        self.codes = np.empty((height + 2 * pad, width + 2 * pad), census_dtype(size, pattern))
        run = native.entry(*entry("census", pixels, size, pattern))
        self.call = run.bind(**_arguments(self.padded, self.codes, size, pattern, 0, height,
                                          pad, reverse))

    def __call__(self, image):
        self.padder(image)
        self.call()
        return self.codes


@functools.cache
def _places_array(size, pattern):
    """census_places as the worker reads them: int64 (n,), shared by every call (not
    read-only, since the entries take writable buffers' addresses)."""
    return np.array(census_places(size, pattern), np.int64)


def compared(left, right, params, census_window, threads=None, *, pattern):
    """The arrays the engines compare, and the contract.MatchParams they run with: the
    images, or for the census cost their census codes compared with SHD."""
    if params.cost == CENSUS:
        left = census_transform(left, census_window, threads, pattern=pattern)
        right = census_transform(right, census_window, threads, pattern=pattern)
        params = params._replace(cost=SHD)
    return left, right, params

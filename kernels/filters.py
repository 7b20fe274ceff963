"""Post filters on disparity maps that have no library equivalent: the left-right check,
speckle removal over regions of similar disparity (as OpenCV's filterSpeckles), a median
over valid pixels only, and the background fill of the Middlebury and KITTI evaluation
kits.

Maps are float32 (H, W) with NaN where invalid.  Each function allocates and runs its
worker (kernels/jit/filters.py); row-local ones in parallel stripes of rows.  csw.matching.pipeline
validates and calls them.
"""

import numpy as np

from . import native, runtime
from .workspace import empty

# The speckle filter's work per pixel in runtime.DIRECT_WORK's units: about 6 ns a pixel
# in one thread, so that maps from 2 MP up run in parallel stripes.
SPECKLE_WORK = 25


def _by_rows(kind, arguments, height, scratch=None, threads=None, per_pixel=8):
    """Run a row-local filter over stripes of rows, one per thread (``threads``: as for
    csw.match), with its ``arguments`` by name but the stripe's rows (y0, y1) and the
    ``scratch`` arrays each stripe makes (name -> a function making one); per_pixel: its
    work per pixel in runtime.DIRECT_WORK's units."""
    run = native.entry("filters", (kind,))
    work = arguments["disp"].size * per_pixel
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)

    def stripe(i, stop):
        made = {name: make() for name, make in (scratch or {}).items()}
        return run(**arguments, **made, y0=edges[i], y1=edges[i + 1])

    runtime.run_stripes(stripe, count, count, work)


def lr_consistent(disp, right_disp, limit, invalid=-1, threads=None, out=None):
    """bool (H, W): d = disp[y, x] is valid (not ``invalid``, the maps' invalid value:
    see contract.invalid) and its right pixel's own match, right_disp[y, x - d]
    (``invalid``: none), differs from it by at most ``limit``.

    disp, right_disp: int32 (H, W).  out: a uint8 (H, W) array of the caller's to write
    the check into, else a new one.  threads: as for csw.match."""
    disp, right_disp = np.ascontiguousarray(disp), np.ascontiguousarray(right_disp)
    valid = np.empty(disp.shape, np.uint8) if out is None else out
    # About 1.8 ns a pixel in one thread: 10 units, parallel from about 5 MP up.
    _by_rows("lr", dict(disp=disp, right_disp=right_disp, valid=valid, limit=int(limit),
                        invalid=int(invalid)), disp.shape[0], threads=threads, per_pixel=10)
    return valid.view(np.bool_)


def speckle_mask(disp, max_size, max_diff, workspace=None, threads=None):
    """bool (H, W): True for valid pixels in regions of fewer than ``max_size`` pixels,
    where a region is a 4-connected set of valid pixels whose neighbours differ by at
    most ``max_diff``.  Scratch: a union-find forest over the rows' runs (its H * W
    entries are reserved, and only as many as there are runs are touched).
    workspace: a kernels.workspace.Workspace for the scratch and the result (valid until
    its next speckle mask), else new arrays.  threads: as for csw.match.

    Stripes of rows find their regions in parallel, one thread joins them across the
    stripes' edges, and the stripes mark the small regions in parallel."""
    disp = np.ascontiguousarray(disp, np.float32)
    height, width = disp.shape
    small = empty(workspace, "speckle-mask", disp.shape, np.uint8)
    parent, size = (empty(workspace, f"speckle-forest-{i}", (disp.size,), np.int32)
                    for i in range(2))
    first = np.empty(height, np.int64)
    limit = np.array([max_diff], np.float64)
    work = disp.size * SPECKLE_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)

    run = native.entry("filters", ("speckle",))
    none = np.empty(0, np.int64)

    def step(number, i, joins=none):  # see jit/filters.py, speckle
        rows = [np.empty(width, np.int32) for _ in range(2)]
        return run(disp=disp, small=small, parent=parent, size=size, first=first,
                   here=rows[0], above=rows[1], max_diff=limit, edges=joins, step=number,
                   y0=edges[i], y1=edges[i + 1], max_size=int(max_size))

    runtime.run_stripes(lambda i, stop: step(0, i), count, count, work)
    if count > 1:
        step(1, 0, edges[1:-1].copy())
    runtime.run_stripes(lambda i, stop: step(2, i), count, count, work)
    return small.view(np.bool_)


def median_valid(disp, size, threads=None):
    """float32 (H, W): each valid pixel becomes the median of the valid pixels in its
    size x size window (the lower middle for an even count); invalid pixels stay NaN."""
    disp = np.ascontiguousarray(disp, np.float32)
    out = np.empty_like(disp)
    _by_rows("median", dict(disp=disp, out=out, size=int(size)), disp.shape[0],
             scratch={"window": lambda: np.empty(size * size, np.float32)}, threads=threads)
    return out


def fill_background(disp, threads=None):
    """float32 (H, W) with no invalid pixel: along each row, an invalid pixel takes the
    smaller of the nearest valid disparities to its left and right (the background side);
    at a row's end, the one valid neighbour; a row with none becomes 0 (the KITTI
    devkit's interpolation, used by the Middlebury kit for sparse results too)."""
    disp = np.ascontiguousarray(disp, np.float32)
    out = np.empty_like(disp)
    _by_rows("fill", dict(disp=disp, out=out), disp.shape[0], threads=threads)
    return out


def entries(speckle, median, fill):
    """The (kernel, variant) entries the 2-D filters load: speckle removal, the median,
    the background fill, each where True (the left-right check is the engines', see
    kernels.entries)."""
    kinds = [kind for kind, used in (("speckle", speckle), ("median", median),
                                     ("fill", fill)) if used]
    return [("filters", (kind,)) for kind in kinds]

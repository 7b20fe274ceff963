"""Post filters on disparity maps that have no library equivalent: the left-right check,
speckle removal over regions of similar disparity (as OpenCV's filterSpeckles), a median
over valid pixels only, and the background fill of the Middlebury and KITTI evaluation
kits.

Maps are float32 (H, W) with NaN where invalid.  Each function allocates and runs its
worker (kernels/jit/filters.py); row-local ones in parallel stripes of rows.  csw.pipeline
validates and calls them.
"""

import numpy as np

from . import native, runtime
from .workspace import empty


def _by_rows(kind, arrays, height, extra=(), scratch=None):
    """Run a row-local filter over stripes of rows, one per thread."""
    run = native.entry("filters", (kind,))
    work = arrays[0].size * 8
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(None), height)
    edges = np.linspace(0, height, count + 1).round().astype(np.int64)

    def stripe(i, stop):
        more = [scratch()] if scratch else []
        return run([*arrays, *more], [edges[i], edges[i + 1], *extra])

    runtime.run_stripes(stripe, count, count, work)


def lr_consistent(disp, right_disp, limit, invalid=-1, workspace=None):
    """bool (H, W): d = disp[y, x] is valid (not ``invalid``, the maps' invalid value:
    see contract.invalid) and its right pixel's own match, right_disp[y, x - d]
    (``invalid``: none), differs from it by at most ``limit``.

    disp, right_disp: int32 (H, W).  workspace: a kernels.workspace.Workspace to take the
    result from (valid until its next check), else a new array."""
    disp, right_disp = np.ascontiguousarray(disp), np.ascontiguousarray(right_disp)
    valid = empty(workspace, "lr-valid", disp.shape, np.uint8)
    _by_rows("lr", [disp, right_disp, valid], disp.shape[0], [int(limit), int(invalid)])
    return valid.view(np.bool_)


def speckle_mask(disp, max_size, max_diff, workspace=None):
    """bool (H, W): True for valid pixels in regions of fewer than ``max_size`` pixels,
    where a region is a 4-connected set of valid pixels whose neighbours differ by at
    most ``max_diff``.  Scratch: a union-find forest over the rows' runs (its H * W
    entries are reserved, and only as many as there are runs are touched).
    workspace: a kernels.workspace.Workspace for the scratch and the result (valid until
    its next speckle mask), else new arrays."""
    disp = np.ascontiguousarray(disp, np.float32)
    small = empty(workspace, "speckle-mask", disp.shape, np.uint8)
    forest = [empty(workspace, f"speckle-forest-{i}", (disp.size,), np.int32)
              for i in range(2)]
    rows = [np.empty(disp.shape[1], np.int32) for _ in range(2)]
    native.entry("filters", ("speckle",))([disp, small, *forest, *rows,
                                           np.array([max_diff], np.float64)],
                                          [int(max_size)])
    return small.view(np.bool_)


def median_valid(disp, size):
    """float32 (H, W): each valid pixel becomes the median of the valid pixels in its
    size x size window (the lower middle for an even count); invalid pixels stay NaN."""
    disp = np.ascontiguousarray(disp, np.float32)
    out = np.empty_like(disp)
    _by_rows("median", [disp, out], disp.shape[0], [int(size)],
             scratch=lambda: np.empty(size * size, np.float32))
    return out


def fill_background(disp):
    """float32 (H, W) with no invalid pixel: along each row, an invalid pixel takes the
    smaller of the nearest valid disparities to its left and right (the background side);
    at a row's end, the one valid neighbour; a row with none becomes 0 (the KITTI
    devkit's interpolation, used by the Middlebury kit for sparse results too)."""
    disp = np.ascontiguousarray(disp, np.float32)
    out = np.empty_like(disp)
    _by_rows("fill", [disp, out], disp.shape[0])
    return out


def entries(stages):
    """The (kernel, variant) entries the filters of ``stages`` load."""
    kinds = [kind for kind, used in (
        ("lr", stages.get("lr_check") is not None),
        ("speckle", stages.get("speckle_size", 0) > 0),
        ("median", bool(stages.get("median", 0))),
        ("fill", stages.get("fill", "none") == "background")) if used]
    return [("filters", (kind,)) for kind in kinds]

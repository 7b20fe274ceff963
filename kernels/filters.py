"""Post filters on disparity maps that have no library equivalent: the left-right check,
speckle removal over regions of similar disparity (as OpenCV's filterSpeckles), a median
over valid pixels only, and the background fill of the Middlebury and KITTI evaluation
kits.

Maps are float32 (H, W) with NaN where invalid.  Each function allocates and runs its
worker (kernels/jit/filters.py); row-local ones in parallel stripes of rows.  csw.matching.pipeline
validates and calls them.
"""

import functools

import numpy as np

from . import native, runtime
from .catalogue import entry
from .workspace import empty

# Columns a median above 3 x 3 sorts at once (kernels/jit/filters.py: median_block):
# their window values and the chosen medians, 50 rows of 64 at 7 x 7 (13 KB), stay in
# the first-level cache through the network's passes.
MEDIAN_BLOCK = 64

# The speckle filter's work per pixel in runtime.DIRECT_WORK's units: about 6 ns a pixel
# in one thread.
SPECKLE_WORK = 25


def direct_work():
    """The work (runtime.DIRECT_WORK's units) from which a filter runs in parallel
    stripes: a twentieth of a match's, about 0.5 ms (the speckle filter: from 0.1 MP up),
    since the match's next step waits for it and handing a stripe to the pool costs
    about 0.1 ms."""
    return runtime.DIRECT_WORK // 20


def stripe_count(work, height, threads=None):
    """The stripes of rows a filter of this much work runs in: one below direct_work(),
    else one a thread (``threads``: as for csw.match).  A filter run as one stripe keeps
    its bound call in a workspace (a stream's frames) where it has one."""
    return 1 if work < direct_work() else min(runtime.thread_count(threads), height)


def _by_rows(kind, arguments, height, scratch=None, threads=None, per_pixel=8):
    """Run a row-local filter over stripes of rows, one per thread (``threads``: as for
    csw.match), with its ``arguments`` by name but the stripe's rows (y0, y1) and the
    ``scratch`` arrays each stripe makes (name -> a function making one); per_pixel: its
    work per pixel in runtime.DIRECT_WORK's units."""
    run = native.entry(*entry("filters", kind))
    width = next(a.shape[1] for a in arguments.values() if getattr(a, "ndim", 0) == 2)
    work = height * width * per_pixel
    count = stripe_count(work, height, threads)
    edges = runtime.even_split(height, count)

    def stripe(i, stop):
        made = {name: make() for name, make in (scratch or {}).items()}
        return run(**arguments, **made, y0=edges[i], y1=edges[i + 1])

    runtime.run_stripes(stripe, count, count, work, direct_work())


def lr_consistent(disp, right_disp, limit, invalid=-1, threads=None, out=None):
    """bool (H, W): d = disp[y, x] is valid (not ``invalid``, the maps' invalid value:
    see contract.invalid) and its right pixel's own match, right_disp[y, x - d]
    (``invalid``: none), differs from it by at most ``limit``.

    disp, right_disp: int32 (H, W).  out: a uint8 (H, W) array of the caller's to write
    the check into, else a new one.  threads: as for csw.match."""
    disp, right_disp = np.ascontiguousarray(disp), np.ascontiguousarray(right_disp)
    valid = np.empty(disp.shape, np.uint8) if out is None else out
    # About 1.8 ns a pixel in one thread: 10 units, parallel from about 0.25 MP up.
    _by_rows("lr", dict(disp=disp, right_disp=right_disp, valid=valid, limit=int(limit),
                        invalid=int(invalid)), disp.shape[0], threads=threads, per_pixel=10)
    return valid.view(np.bool_)


def winners_consistent(disp, min_cost, limit, invalid=-1, threads=None, out=None):
    """bool (H, W): StereoBM's left-right check (its disp12MaxDiff): d = disp[y, x] is
    valid (not ``invalid``) and differs by at most ``limit`` from the disparity of the
    left pixel that chose right pixel x - d at the least cost (min_cost; the first of
    equals, left to right), the right image's match as StereoBM takes it.

    disp: int32 (H, W); min_cost: int64 (H, W).  out: a uint8 (H, W) array of the
    caller's to write the check into, else a new one.  threads: as for csw.match."""
    disp = np.ascontiguousarray(disp, np.int32)
    min_cost = np.ascontiguousarray(min_cost, np.int64)
    valid = np.empty(disp.shape, np.uint8) if out is None else out
    width = disp.shape[1]
    # About 2 ns a pixel in one thread (two passes of a row): parallel from 0.2 MP up.
    _by_rows("winners", dict(disp=disp, min_cost=min_cost, valid=valid, limit=int(limit),
                             invalid=int(invalid)), disp.shape[0],
             scratch={"best": lambda: np.empty(width, np.int64),
                      "owner": lambda: np.empty(width, np.int32)},
             threads=threads, per_pixel=12)
    return valid.view(np.bool_)


def as_float(disp, lr_valid, invalid, out=None, threads=None, workspace=None):
    """float32 (H, W): the integer map ``disp`` (int32 (H, W)) as floats, NaN where it
    holds ``invalid`` (contract.invalid) or where ``lr_valid`` (bool or uint8 (H, W), the
    left-right check; None: no check) is False.  out: a float32 (H, W) array to write
    into, else a new one.  threads: as for csw.match.  workspace: a
    kernels.workspace.Workspace that keeps the call, bound, for the next map like this
    one (a stream's frames)."""
    disp = np.ascontiguousarray(disp, np.int32)
    checked = lr_valid is not None
    lr = np.ascontiguousarray(lr_valid).view(np.uint8) if checked else _NO_CHECK
    out = np.empty(disp.shape, np.float32) if out is None else out
    arguments = dict(disp=disp, lr_valid=lr, out=out, invalid=int(invalid),
                     checked=int(checked))
    work = disp.size * FLOAT_WORK
    if workspace is not None and stripe_count(work, disp.shape[0], threads) == 1 and \
            workspace.keeps_calls(disp.size):
        call = workspace.kept_or_made(
            "float-call", (disp.shape, arguments["invalid"], checked),
            lambda: native.entry(*entry("filters", "float")).bind(**arguments, y0=0,
                                                             y1=disp.shape[0]))
        for name in ("disp", "lr_valid", "out"):
            call.point(name, arguments[name])
        call()
        return out
    _by_rows("float", arguments, disp.shape[0], threads=threads, per_pixel=FLOAT_WORK)
    return out


# About 0.3 ns a pixel in one thread, in runtime.DIRECT_WORK's units: parallel from
# about 1.25 MP up.
FLOAT_WORK = 2


def subpixel(disp, best, prev, nxt, valid, fit, threads=None, out=None):
    """float32 (H, W): the integer map ``disp`` (int32 (H, W)) moved by a fit through
    each pixel's costs at d - 1, d and d + 1 (``prev``, ``best``, ``nxt``: int64 (H, W),
    -1 where unknown), NaN where ``valid`` (bool or uint8 (H, W)) is False.  fit:
    "parabola" or "linear" (equiangular); the offset is within [-0.5, 0.5], 0 where a
    neighbour is unknown or the costs are flat (jit/filters.py, subpixel_map).  out: a
    float32 (H, W) array to write into, else a new one.  threads: as for csw.match."""
    if fit not in ("parabola", "linear"):
        raise ValueError(f"fit must be 'parabola' or 'linear', got {fit!r}")
    disp = np.ascontiguousarray(disp, np.int32)
    best, prev, nxt = (np.ascontiguousarray(a, np.int64) for a in (best, prev, nxt))
    valid = np.ascontiguousarray(valid).view(np.uint8)
    out = np.empty(disp.shape, np.float32) if out is None else out
    _by_rows("subpixel", dict(disp=disp, best=best, prev=prev, nxt=nxt, valid=valid,
                              out=out, linear=int(fit == "linear")),
             disp.shape[0], threads=threads, per_pixel=SUBPIXEL_WORK)
    return out


# About 1.2 ns a pixel in one thread (four maps read, one written; a KITTI frame's
# 0.5 ms on a Zen 4), in runtime.DIRECT_WORK's units.
SUBPIXEL_WORK = 6


def confidence(best, second, valid, threads=None, out=None):
    """float32 (H, W): (second - best) / second, 0..1 where the costs are a match's
    least and second best (int64 (H, W); second -1 where there is none); 0 where
    ``valid`` (bool or uint8 (H, W)) is False or there is no second.  out: a float32
    (H, W) array to write into, else a new one.  threads: as for csw.match."""
    best, second = (np.ascontiguousarray(a, np.int64) for a in (best, second))
    valid = np.ascontiguousarray(valid).view(np.uint8)
    out = np.empty(best.shape, np.float32) if out is None else out
    _by_rows("confidence", dict(best=best, second=second, valid=valid, out=out),
             best.shape[0], threads=threads, per_pixel=CONFIDENCE_WORK)
    return out


# Three maps read, one written: a little under subpixel's.
CONFIDENCE_WORK = 2

_NO_CHECK = np.zeros((1, 1), np.uint8)  # the worker never reads it


def speckle_mask(disp, max_size, max_diff, workspace=None, threads=None, clear=False):
    """bool (H, W): True for valid pixels in regions of fewer than ``max_size`` pixels,
    where a region is a 4-connected set of valid pixels whose neighbours differ by at
    most ``max_diff``.  Scratch: a union-find forest over the rows' runs (its H * W
    entries are reserved, and only as many as there are runs are touched).
    workspace: a kernels.workspace.Workspace for the scratch and the result (valid until
    its next speckle mask), else new arrays.  threads: as for csw.match.  clear: make
    those pixels of ``disp`` (float32, C-contiguous: changed in place) NaN as well.

    Stripes of rows find their regions in parallel, one thread joins them across the
    stripes' edges, and the stripes mark the small regions in parallel."""
    disp = np.ascontiguousarray(disp, np.float32)
    height, width = disp.shape
    work = disp.size * SPECKLE_WORK
    count = stripe_count(work, height, threads)
    if workspace is not None and count == 1 and workspace.keeps_calls(disp.size):
        key = (disp.shape, int(max_size), float(max_diff))
        return workspace.kept_or_made("speckle-call", key,
                                      lambda: SpeckleCall(*key))(disp, clear)
    small = empty(workspace, "speckle-mask", disp.shape, np.uint8)
    parent, size = (empty(workspace, f"speckle-forest-{i}", (disp.size,), np.int32)
                    for i in range(2))
    first = np.empty(height, np.int64)
    edges = runtime.even_split(height, count)
    run = native.entry(*entry("filters", "speckle"))
    none = np.empty(0, np.int64)

    def step(number, i, joins=none):  # see jit/filters.py, speckle
        return run(**_speckle_arguments(disp, small, parent, size, first, max_size, max_diff,
                                        number, edges[i], edges[i + 1], joins))

    runtime.run_stripes(lambda i, stop: step(0, i), count, count, work, direct_work())
    if count > 1:
        step(1, 0, edges[1:-1].copy())
    runtime.run_stripes(lambda i, stop: step(3 if clear else 2, i), count, count, work,
                        direct_work())
    return small.view(np.bool_)


def _speckle_arguments(disp, small, parent, size, first, max_size, max_diff, step, y0, y1,
                       joins):
    """The speckle worker's arguments for its ``step`` over rows y0..y1 (its row scratch
    made here, in the stripe's own thread)."""
    width = disp.shape[1]
    return dict(disp=disp, small=small, parent=parent, size=size, first=first,
                here=np.empty(width, np.int32), above=np.empty(width, np.int32),
                max_diff=np.array([max_diff], np.float64), edges=joins, step=step, y0=y0,
                y1=y1, max_size=int(max_size))


class SpeckleCall:
    """speckle_mask of many maps of one shape, made once (a stream's small frames): its
    scratch, its mask and its bound calls (the regions, then the marks with or without
    clearing), run as one stripe in the calling thread.
    ``call(disp)`` returns the mask, the call's own array, overwritten by the next call."""

    def __init__(self, shape, max_size, max_diff):
        height, width = shape
        self.small = np.empty(shape, np.uint8)
        # Shared by the two steps: the forest and each row's first run.
        shared = (self.small, np.empty(height * width, np.int32),
                  np.empty(height * width, np.int32), np.empty(height, np.int64))
        disp = np.zeros(shape, np.float32)
        run = native.entry(*entry("filters", "speckle"))
        # The regions, then the marks: alone (step 2) or clearing them too (step 3).
        self.regions, *marks = [
            run.bind(**_speckle_arguments(disp, *shared, max_size, max_diff, step, 0, height,
                                          np.empty(0, np.int64)))
            for step in (0, 2, 3)]
        self.marks = dict(zip((False, True), marks, strict=True))

    def __call__(self, disp, clear=False):
        """The mask of ``disp`` (float32 (H, W), C-contiguous; with clear, its small
        regions' pixels become NaN)."""
        mark = self.marks[bool(clear)]
        for call in (self.regions, mark):
            call.point("disp", disp)
            call()
        return self.small.view(np.bool_)


def median_valid(disp, size, threads=None):
    """float32 (H, W): each valid pixel becomes the median of the valid pixels in its
    size x size window (the lower middle for an even count); invalid pixels stay NaN."""
    if int(size) != size or size < 1 or size % 2 == 0:
        raise ValueError(f"the median's size must be odd and at least 1, got {size!r}")
    disp = np.ascontiguousarray(disp, np.float32)
    out = np.empty_like(disp)
    lanes = size * size + 1
    exchanges = median_network(int(size))
    # Sorting networks, one thread: about 24 ns a pixel at 5 x 5 and 64 at 7 x 7 (a unit
    # of work an exchange), where an insertion sort took 290 and 680; so a KITTI frame's
    # median is worth both threads.  3 x 3 (1.5 ns a pixel) keeps the work it was rated
    # at under the insertion sort, and with it both threads on a KITTI frame (its
    # median takes 0.6-0.7 ms on one thread or two).
    _by_rows("median", dict(disp=disp, out=out, size=int(size), exchanges=exchanges),
             disp.shape[0],
             scratch={"window": lambda: np.empty(size * size, np.float32),
                      "lanes": lambda: np.empty((lanes, MEDIAN_BLOCK), np.float32),
                      "ranks": lambda: np.empty(MEDIAN_BLOCK, np.int32)},
             threads=threads, per_pixel=170 if size == 3 else len(exchanges) + 10)
    return out


@functools.lru_cache(maxsize=8)
def median_network(size):
    """int32 (E, 2): the exchanges (wire pairs i < j: the smaller value to i) that put
    ranks 0 .. (n - 1) // 2 of n = size * size values in place: Batcher's odd-even merge
    sort of the next power of two, less the exchanges with a wire at or past n (those
    wires would hold +inf, so the exchange changes nothing) and those no kept rank
    depends on.  Ties between -0.0 and +0.0 may come out either way (as in the 3 x 3
    network).
    tests/library/test_pipeline.py checks it on every 0-1 input of the 5 x 5 window's."""
    n = size * size
    wires = 1 << max(n - 1, 0).bit_length()
    network, p = [], 1
    while p < wires:
        k = p
        while k >= 1:
            for j in range(k % p, wires - k, 2 * k):
                for i in range(min(k, wires - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p) and i + j + k < n:
                        network.append((i + j, i + j + k))
            k //= 2
        p *= 2
    needed, kept = set(range((n - 1) // 2 + 1)), []
    for a, b in reversed(network):
        if a in needed or b in needed:
            kept.append((a, b))
            needed |= {a, b}
    return np.array(kept[::-1], np.int32).reshape(-1, 2)


def fill_background(disp, threads=None):
    """float32 (H, W) with no invalid pixel: along each row, an invalid pixel takes the
    smaller of the nearest valid disparities to its left and right (the background side);
    at a row's end, the one valid neighbour; a row with none becomes 0 (the KITTI
    devkit's interpolation, used by the Middlebury kit for sparse results too)."""
    disp = np.ascontiguousarray(disp, np.float32)
    out = np.empty_like(disp)
    _by_rows("fill", dict(disp=disp, out=out), disp.shape[0], threads=threads)
    return out


def narrow_starts(disp, valid, shape, offset, ndisp, slots, base, margin, threads=None,
                  out=None):
    """int32 ``shape`` (H, W): the narrowed semi-global search's starts from its
    half-size match (csw.matching.narrow.starts defines them; the worker in
    kernels/jit/filters.py), each full-size pixel's from its half-size pixel (min(Y // 2,
    h - 1), min(X // 2, w - 1)).

    disp: int32 (h, w), the half-size match; valid: bool or uint8 (h, w), its left-right
    check; offset: the half range's start; ndisp: the full range's size; slots: K;
    base, margin: the full-size offset of the half range's start and the disparities
    added each side of a doubled span.  out: an int32 ``shape`` array to write into."""
    disp = np.ascontiguousarray(disp, np.int32)
    valid = np.ascontiguousarray(valid).view(np.uint8)
    height, width = disp.shape
    if tuple(shape) != (height * 2 + shape[0] % 2, width * 2 + shape[1] % 2) or \
            valid.shape != disp.shape or not 1 <= slots <= ndisp:
        raise ValueError(f"starts of {tuple(shape)} from a {disp.shape} half-size match "
                         f"with {slots} slots of {ndisp}: shapes or slots do not fit")
    out = np.empty(shape, np.int32) if out is None else out
    # About 7 ns a half-size pixel in one thread, its four full-size pixels written (a
    # KITTI frame's 0.8 ms on a Zen 4).
    _by_rows("starts", dict(disp=disp, valid=valid, out=out, offset=int(offset),
                            ndisp=int(ndisp), slots=int(slots), base=int(base),
                            margin=int(margin)), height,
             scratch={"low": lambda: np.empty((3, width), np.int32),
                      "high": lambda: np.empty((3, width), np.int32),
                      "rows": lambda: np.empty((3, width), np.int32)},
             threads=threads, per_pixel=36)
    return out

"""The post filters' workers (see kernels/filters.py): the left-right checks, speckle
removal over regions of similar disparity (as OpenCV's filterSpeckles), a median over
valid pixels only, and the background fill of the Middlebury and KITTI kits; and the
narrowed semi-global search's starts, from its half-size match.

Maps are float32 (H, W) with NaN where invalid, save the left-right check's int32 maps.
Row-local filters work on a stripe of rows (y0 <= y < y1) so that stripes run in
parallel.  The speckle filter's regions span rows: its stripes find their own regions in
parallel, one thread joins them across the stripes' edges, and the stripes mark the
small ones in parallel.
"""

import numpy as np
from numba import njit

from ..signature import Signature, Spec, arg, scalar_index
from .common import lr_agrees
from .options import INLINE, SERIAL

F32, I32, I64, U8, F64 = (np.dtype(t) for t in (np.float32, np.int32, np.int64, np.uint8,
                                                 np.float64))


# Each filter's scalars (the entries' records; see kernels/signature.py).
LR = scalar_index(("y0", "y1", "limit", "invalid"))
WINNERS = LR  # the same scalars
NO_COST = np.iinfo(np.int64).max  # above every winner's cost
SPECKLE = scalar_index(("step", "y0", "y1", "max_size"))
MEDIAN = scalar_index(("y0", "y1", "size"))
FILL = scalar_index(("y0", "y1"))
FLOAT = scalar_index(("y0", "y1", "invalid", "checked"))
SUBPIXEL = scalar_index(("y0", "y1", "linear"))
CONFIDENCE = scalar_index(("y0", "y1"))
STARTS = scalar_index(("y0", "y1", "offset", "ndisp", "slots", "base", "margin"))


def spec(kind):
    """The worker of a filter: "lr", "winners", "speckle", "median", "fill", "float",
    "subpixel", "confidence" or "starts"."""
    workers = {
        # the left-right check of a stripe of rows
        "lr": (lr_consistent, (arg("disp", I32, 2), arg("right_disp", I32, 2),
                               arg("valid", U8, 2)), LR),  # (H, W); valid out
        # StereoBM's check: disp, min_cost, valid (H, W), valid out; best, owner (W,)
        # scratch of the stripe
        "winners": (winners_consistent, (arg("disp", I32, 2), arg("min_cost", I64, 2),
                                         arg("valid", U8, 2), arg("best", I64, 1),
                                         arg("owner", I32, 1)), WINNERS),
        # one step of the speckle filter (see speckle): parent, size (H*W,) the forest;
        # first (H,) each row's first run; here, above (W,) scratch; max_diff (1,);
        # edges (n,) the stripes' inner edges
        "speckle": (speckle, (arg("disp", F32, 2), arg("small", U8, 2),
                              arg("parent", I32, 1), arg("size", I32, 1),
                              arg("first", I64, 1), arg("here", I32, 1),
                              arg("above", I32, 1), arg("max_diff", F64, 1),
                              arg("edges", I64, 1)), SPECKLE),
        # disp, out (H, W); exchanges (E, 2) the sorting network of a window above 3 x 3
        # (kernels/filters.py: median_network); window (size*size,), lanes
        # (size*size + 1, B), ranks (B,) scratch of the stripe, B columns at once
        "median": (median_valid, (arg("disp", F32, 2), arg("out", F32, 2),
                                  arg("exchanges", I32, 2), arg("window", F32, 1),
                                  arg("lanes", F32, 2), arg("ranks", I32, 1)), MEDIAN),
        "fill": (fill_background, (arg("disp", F32, 2), arg("out", F32, 2)), FILL),
        # disp (H, W), lr_valid (H, W) or a (1, W) dummy unless checked, out (H, W)
        "float": (as_float, (arg("disp", I32, 2), arg("lr_valid", U8, 2),
                             arg("out", F32, 2)), FLOAT),
        # disp, valid (H, W); best, prev, nxt (H, W) the costs at d, d - 1, d + 1; out
        "subpixel": (subpixel_map, (arg("disp", I32, 2), arg("best", I64, 2),
                                    arg("prev", I64, 2), arg("nxt", I64, 2),
                                    arg("valid", U8, 2), arg("out", F32, 2)), SUBPIXEL),
        # best, second (H, W) the least and second-best costs; valid (H, W); out
        "confidence": (confidence_map, (arg("best", I64, 2), arg("second", I64, 2),
                                        arg("valid", U8, 2), arg("out", F32, 2)),
                       CONFIDENCE),
        # disp, valid (h, w) the half-size match; low, high, rows (3, w) scratch of the
        # stripe; out (H, W) the full-size starts
        "starts": (narrow_starts, (arg("disp", I32, 2), arg("valid", U8, 2),
                                   arg("low", I32, 2), arg("high", I32, 2),
                                   arg("rows", I32, 2), arg("out", I32, 2)), STARTS),
    }
    worker, arrays, scalars = workers[kind]
    return Spec(worker, Signature(arrays, scalars._fields))


@njit(**SERIAL)
def lr_consistent(disp, right_disp, valid, sc):
    """valid[y, x] = 1 where d = disp[y, x] is valid (not invalid, the maps' invalid value)
    and its right pixel's own match, right_disp[y, x - d] (invalid: none), differs from it
    by at most limit; for the rows y0 <= y < y1 (sc: LR)."""
    width = disp.shape[1]
    limit, invalid = sc[LR.limit], sc[LR.invalid]
    for y in range(sc[LR.y0], sc[LR.y1]):
        for x in range(width):
            d = disp[y, x]
            back = right_disp[y, x - d] if d != invalid else invalid
            valid[y, x] = lr_agrees(d, back, limit, invalid)
    return 0


@njit(**SERIAL)
def winners_consistent(disp, min_cost, valid, best, owner, sc):
    """StereoBM's left-right check (its disp12MaxDiff), for the rows y0 <= y < y1 (sc:
    WINNERS): the right image's match of right pixel xr is the disparity of the left
    pixel that chose xr at the least cost (the first of equals, left to right);
    valid[y, x] = 1 where d = disp[y, x] is valid (not invalid) and differs from its
    right pixel x - d's match by at most limit.  Two passes of the row's winners, where
    the exact check (lr_consistent, the engines' right maps) takes the least of every
    candidate's cost, a pass over the range per pixel.

    disp: int32 (H, W); min_cost: int64 (H, W), each winner's cost; valid: uint8 (H, W)
    out; best: int64 (W,), owner: int32 (W,), scratch."""
    width = disp.shape[1]
    limit, invalid = sc[WINNERS.limit], sc[WINNERS.invalid]
    for y in range(sc[WINNERS.y0], sc[WINNERS.y1]):
        best[:] = NO_COST
        for x in range(width):
            d = disp[y, x]
            if d != invalid and min_cost[y, x] < best[x - d]:
                best[x - d] = min_cost[y, x]
                owner[x - d] = d
        # Every right pixel a valid pixel points at was claimed in this row: by that
        # pixel, if by no cheaper one.
        for x in range(width):
            d = disp[y, x]
            valid[y, x] = d != invalid and abs(d - owner[x - d]) <= limit
    return 0


@njit(**SERIAL)
def _root(parent, run):
    """The root of a run in the union-find forest, halving the path on the way."""
    while parent[run] != run:
        parent[run] = parent[parent[run]]
        run = parent[run]
    return run


@njit(**SERIAL)
def _row_runs(disp, y, limit, runs, next_run):
    """Number row y's runs from next_run on: maximal horizontal stretches of valid pixels
    whose neighbours differ by at most limit.  runs: int32 (W,) out, each pixel's run or
    -1 where invalid.  Returns the next free number."""
    row = disp[y]
    previous = np.float32(np.nan)  # compares False with everything: no run to continue
    # Branch-free (the valid and invalid pixels of a noisy map defeat branch prediction):
    # a valid pixel that does not continue the run on its left starts one.
    for x in range(row.shape[0]):
        v = row[x]
        valid = not np.isnan(v)
        continues = abs(v - previous) <= limit  # False when either is NaN
        next_run += np.int64(valid) - np.int64(continues)
        runs[x] = next_run - 1 if valid else -1
        previous = v
    return next_run


@njit(**SERIAL)
def _join(parent, size, a, b):
    """Join the trees of runs a and b, the smaller under the larger."""
    ra, rb = _root(parent, a), _root(parent, b)
    if ra != rb:
        if size[ra] < size[rb]:
            ra, rb = rb, ra
        parent[rb] = ra
        size[ra] += size[rb]


@njit(**SERIAL)
def _join_rows(disp, y, limit, here, above, parent, size):
    """Join each run of row y to the runs of row y - 1 it touches: wherever a pixel and
    the one above differ by at most limit.  here, above: the two rows' runs."""
    joined_a, joined_b = -1, -1  # the last pair of runs joined: most links repeat it
    for x in range(disp.shape[1]):
        a, b = here[x], above[x]
        if a < 0 or b < 0 or (a == joined_a and b == joined_b) or \
                abs(disp[y, x] - disp[y - 1, x]) > limit:
            continue
        joined_a, joined_b = a, b
        _join(parent, size, a, b)


@njit(**SERIAL)
def speckle_regions(disp, parent, size, first, here, above, max_diff, y0, y1):
    """The regions of a stripe of rows, y0 <= y < y1, on their own: a region is a
    4-connected set of valid pixels whose neighbours differ by at most max_diff[0].

    Regions are found as runs joined into a union-find forest: each row's runs (see
    _row_runs), joined to the runs above them.  A stripe numbers its runs from y0 * W on,
    so that stripes use disjoint entries of parent and size (int32 (H * W,); as many are
    written as there are runs); first[y]: row y's first run number.  here, above: int32
    (W,) scratch.
    """
    width = disp.shape[1]
    limit = max_diff[0]
    next_run = y0 * width
    for y in range(y0, y1):
        first[y] = next_run
        next_run = _row_runs(disp, y, limit, here, next_run)
        for run in range(first[y], next_run):
            parent[run] = run
        # The row's runs' sizes, whole, before any of them is joined: a run is a
        # stretch of x, so its size is written at each of its pixels, the last time
        # whole (a count, size[run] += 1, waited on its own store at every pixel).
        start = 0
        for x in range(width):
            run = here[x]
            if run >= 0:
                if x == 0 or here[x - 1] != run:
                    start = x
                size[run] = x - start + 1
        if y > y0:
            _join_rows(disp, y, limit, here, above, parent, size)
        here, above = above, here
    return 0


@njit(**SERIAL)
def speckle_join(disp, parent, size, first, here, above, max_diff, edges):
    """Join the stripes' regions across their edges: each row in edges to the row above
    it, their runs numbered again from first."""
    limit = max_diff[0]
    for i in range(edges.shape[0]):
        y = edges[i]
        _row_runs(disp, y - 1, limit, above, first[y - 1])
        _row_runs(disp, y, limit, here, first[y])
        _join_rows(disp, y, limit, here, above, parent, size)
    return 0


@njit(**SERIAL)
def speckle_mark(disp, small, parent, size, first, max_diff, y0, y1, max_size, clear):
    """small[y, x] = 1 for the valid pixels of rows y0 <= y < y1 whose region has
    fewer than max_size pixels, once every region is whole: the rows' runs numbered again
    from first, in one pass with the marking (a run's verdict taken where it starts).
    The roots are found without shortening paths, so that stripes may run at once: they
    only read the forest.  With clear, those pixels of disp become NaN too, each once
    read (a stripe reads only its own rows in this step)."""
    limit = max_diff[0]
    for y in range(y0, y1):
        row = disp[y]
        previous = np.float32(np.nan)
        run = first[y] - 1
        verdict = False
        for x in range(row.shape[0]):
            v = row[x]
            valid = not np.isnan(v)
            if valid and not abs(v - previous) <= limit:  # a run starts (see _row_runs)
                run += 1
                root = run
                while parent[root] != root:
                    root = parent[root]
                verdict = size[root] < max_size
            small[y, x] = valid and verdict
            if clear and valid and verdict:
                row[x] = np.nan
            previous = v
    return 0


@njit(**SERIAL)
def speckle(disp, small, parent, size, first, here, above, max_diff, edges, sc):
    """The speckle filter's steps in one entry (one compile, not three): step 0 finds a
    stripe's regions (speckle_regions), 1 joins the stripes (speckle_join), 2 marks a
    stripe's small regions (speckle_mark), 3 marks them and makes them NaN in disp;
    sc: SPECKLE."""
    step, y0, y1 = sc[SPECKLE.step], sc[SPECKLE.y0], sc[SPECKLE.y1]
    if step == 0:
        return speckle_regions(disp, parent, size, first, here, above, max_diff, y0, y1)
    if step == 1:
        return speckle_join(disp, parent, size, first, here, above, max_diff, edges)
    return speckle_mark(disp, small, parent, size, first, max_diff, y0, y1,
                        sc[SPECKLE.max_size], step == 3)


# A sorting network of 9 inputs (25 exchanges; tests/library/test_pipeline.py checks
# that sort_nine sorts every 0-1 input, so every input): a 3x3 median sorts its window
# in registers with no branch, where the insertion sort's branches, taken at random,
# cost about 100 ns a pixel.


@njit(**INLINE)
def sort_nine(a0, a1, a2, a3, a4, a5, a6, a7, a8):
    """The nine values in ascending order, by a network of 25 exchanges."""
    a0, a3 = min(a0, a3), max(a0, a3)
    a1, a7 = min(a1, a7), max(a1, a7)
    a2, a5 = min(a2, a5), max(a2, a5)
    a4, a8 = min(a4, a8), max(a4, a8)
    a0, a7 = min(a0, a7), max(a0, a7)
    a2, a4 = min(a2, a4), max(a2, a4)
    a3, a8 = min(a3, a8), max(a3, a8)
    a5, a6 = min(a5, a6), max(a5, a6)
    a0, a2 = min(a0, a2), max(a0, a2)
    a1, a3 = min(a1, a3), max(a1, a3)
    a4, a5 = min(a4, a5), max(a4, a5)
    a7, a8 = min(a7, a8), max(a7, a8)
    a1, a4 = min(a1, a4), max(a1, a4)
    a3, a6 = min(a3, a6), max(a3, a6)
    a5, a7 = min(a5, a7), max(a5, a7)
    a0, a1 = min(a0, a1), max(a0, a1)
    a2, a4 = min(a2, a4), max(a2, a4)
    a3, a5 = min(a3, a5), max(a3, a5)
    a6, a8 = min(a6, a8), max(a6, a8)
    a2, a3 = min(a2, a3), max(a2, a3)
    a4, a5 = min(a4, a5), max(a4, a5)
    a6, a7 = min(a6, a7), max(a6, a7)
    a1, a2 = min(a1, a2), max(a1, a2)
    a3, a4 = min(a3, a4), max(a3, a4)
    a5, a6 = min(a5, a6), max(a5, a6)
    return a0, a1, a2, a3, a4, a5, a6, a7, a8


@njit(**INLINE)
def sortable(v):
    """v, or +inf where v is NaN (invalid): after every valid value.  (NaN != NaN.)"""
    return v if v == v else np.float32(np.inf)


@njit(**SERIAL)
def median_at(disp, y, x, h, window):
    """The median of the valid pixels in the (2h + 1)^2 window at (y, x), by insertion
    into window (scratch)."""
    height, width = disp.shape
    n = 0
    for yy in range(max(y - h, 0), min(y + h + 1, height)):
        for xx in range(max(x - h, 0), min(x + h + 1, width)):
            v = disp[yy, xx]
            if not np.isnan(v):
                i = n
                while i > 0 and window[i - 1] > v:
                    window[i] = window[i - 1]
                    i -= 1
                window[i] = v
                n += 1
    return window[(n - 1) // 2]


@njit(**SERIAL)
def median_nine(up, row, down, out):
    """out[x] for the inner columns of a row (x = 1 .. W - 2 of the map, 0 .. W - 3
    here): the median of the valid pixels of the 3 x 3 window, by sort_nine with the
    invalid ones as +inf (after every valid one), so that the median of the n + 1 valid
    (n neighbours and the centre) is at n // 2; NaN where the centre is invalid.  The
    arguments are views that start at the window's left column (up, row, down: (W - 2,)
    from column 0, 1 and 2 of each row), indexed from 0, and the choice of the median
    is made without a branch, so that the loop vectorises: with sort_nine and sortable
    inlined, 1.4 ns a pixel, where a loop with branches took 10."""
    for x in range(out.shape[0]):
        a, b, c = up[0][x], up[1][x], up[2][x]
        d, centre, e = row[0][x], row[1][x], row[2][x]
        f, g, i = down[0][x], down[1][x], down[2][x]
        n = (np.int32(a == a) + np.int32(b == b) + np.int32(c == c) + np.int32(d == d)
             + np.int32(e == e) + np.int32(f == f) + np.int32(g == g) + np.int32(i == i))
        s0, s1, s2, s3, s4, _, _, _, _ = sort_nine(
            sortable(a), sortable(b), sortable(c), sortable(d), centre, sortable(e),
            sortable(f), sortable(g), sortable(i))
        k = n >> 1
        value = s0 if k == 0 else s1 if k == 1 else s2 if k == 2 else s3 if k == 3 else s4
        out[x] = value if centre == centre else np.float32(np.nan)


@njit(**SERIAL)
def median_block(disp, y, x0, count, h, exchanges, lanes, ranks, out_row):
    """out_row[x] for x = x0 .. x0 + count - 1, columns whose (2h + 1)^2 window lies
    within the map's width (rows beyond its top or bottom are none of the window's): the
    median of the window's valid pixels, as median_at, for count <= B columns at once.
    Each of the n = (2h + 1)^2 window positions is a row of lanes, the invalid pixels
    +inf (after every valid one); the network (exchanges: (E, 2) int32 wire pairs, the
    smaller value to the first) then orders the ranks a median can take, and each column
    takes rank (valid - 1) // 2.  Every loop runs over the block's columns with no
    branch, so that it vectorises.  lanes: float32 (n + 1, B), ranks: int32 (B,),
    scratch."""
    height = disp.shape[0]
    size = 2 * h + 1
    n = size * size
    inf = np.float32(np.inf)
    for t in range(count):
        ranks[t] = -1
    for dy in range(size):
        yy = y + dy - h
        for dx in range(size):
            lane = lanes[dy * size + dx]
            if 0 <= yy < height:
                source = disp[yy, x0 + dx - h:x0 + dx - h + count]
                for t in range(count):
                    v = source[t]
                    ranks[t] += np.int32(v == v)
                    lane[t] = v if v == v else inf
            else:
                for t in range(count):
                    lane[t] = inf
    for t in range(count):
        ranks[t] >>= 1  # from the valid count less one to the median's rank
    for e in range(exchanges.shape[0]):
        low, high = lanes[exchanges[e, 0]], lanes[exchanges[e, 1]]
        for t in range(count):
            a, b = low[t], high[t]
            low[t], high[t] = min(a, b), max(a, b)
    chosen, least = lanes[n], lanes[0]
    for t in range(count):
        chosen[t] = least[t]
    for r in range(1, (n - 1) // 2 + 1):
        lane = lanes[r]
        for t in range(count):
            chosen[t] = lane[t] if ranks[t] == r else chosen[t]
    centre = disp[y, x0:x0 + count]
    for t in range(count):
        out_row[x0 + t] = chosen[t] if centre[t] == centre[t] else np.float32(np.nan)


@njit(**SERIAL)
def median_valid(disp, out, exchanges, window, lanes, ranks, sc):
    """out[y, x]: for each valid pixel, the median of the valid pixels in its size x size
    window (the lower middle for an even count); NaN for invalid pixels; rows y0 to y1
    (sc: MEDIAN).  The columns whose window lies within the map's width go through
    median_nine (3 x 3, rows inside the map) or median_block (larger windows, blocks of
    as many columns as lanes has, the network in exchanges); the others through
    median_at, its insertion sort into window.  exchanges, window, lanes, ranks: see
    spec."""
    height, width = disp.shape
    size = sc[MEDIAN.size]
    h = size // 2
    inner = width - 2 * h  # the columns whose window lies within the width
    for y in range(sc[MEDIAN.y0], sc[MEDIAN.y1]):
        first, end = 0, 0  # the columns done by a network
        if size == 3 and 0 < y < height - 1 and inner > 0:
            up, row, down = disp[y - 1], disp[y], disp[y + 1]
            median_nine((up[:inner], up[1:inner + 1], up[2:]),
                        (row[:inner], row[1:inner + 1], row[2:]),
                        (down[:inner], down[1:inner + 1], down[2:]), out[y, 1:width - 1])
            first, end = 1, width - 1
        elif size > 3 and inner > 0:
            block = lanes.shape[1]
            for x0 in range(h, width - h, block):
                median_block(disp, y, x0, min(block, width - h - x0), h, exchanges, lanes,
                             ranks, out[y])
            first, end = h, width - h
        x = 0
        while x < width:
            if x == first and first < end:
                x = end
                continue
            if np.isnan(disp[y, x]):
                out[y, x] = np.nan
            else:
                out[y, x] = median_at(disp, y, x, h, window)
            x += 1
    return 0


@njit(**SERIAL)
def fill_background(disp, out, sc):
    """out: disp with every invalid pixel filled, for rows y0 to y1 (sc: FILL): along each row,
    an invalid pixel takes the smaller of the nearest valid disparities to its left and
    right (the background side); at a row's end, the one valid neighbour; a row with none
    becomes 0 (the KITTI devkit's interpolation, used by the Middlebury kit for sparse
    results too)."""
    width = disp.shape[1]
    for y in range(sc[FILL.y0], sc[FILL.y1]):
        last = np.nan  # the nearest valid value to the left
        x = 0
        while x < width:
            if not np.isnan(disp[y, x]):
                last = disp[y, x]
                out[y, x] = last
                x += 1
                continue
            end = x
            while end < width and np.isnan(disp[y, end]):
                end += 1
            right = disp[y, end] if end < width else np.nan
            if np.isnan(last) and np.isnan(right):
                value = 0.0
            elif np.isnan(last):
                value = right
            elif np.isnan(right):
                value = last
            else:
                value = min(last, right)
            for i in range(x, end):
                out[y, i] = value
            x = end
    return 0


@njit(**SERIAL)
def as_float(disp, lr_valid, out, sc):
    """out[y, x] = disp[y, x] as float32, or NaN where it is the maps' invalid value or,
    with checked, lr_valid[y, x] is 0 (the left-right check), for the rows y0 <= y < y1
    (sc: FLOAT): the pipeline's float map in one pass, where NumPy took four."""
    width = disp.shape[1]
    invalid, checked = sc[FLOAT.invalid], sc[FLOAT.checked] != 0
    nan = np.float32(np.nan)
    for y in range(sc[FLOAT.y0], sc[FLOAT.y1]):
        for x in range(width):
            d = disp[y, x]
            keep = d != invalid
            if checked:
                keep = keep and lr_valid[y, x] != 0
            out[y, x] = np.float32(d) if keep else nan
    return 0


@njit(**SERIAL)
def subpixel_map(disp, best, prev, nxt, valid, out, sc):
    """out[y, x] = disp[y, x] + the offset of a fit through the costs at d - 1, d and
    d + 1 (prev, best, nxt), as float32, NaN where valid[y, x] is 0; for the rows y0 <= y
    < y1 (sc: SUBPIXEL).  The offset: (prev - nxt) / (2 * denominator) clipped to
    [-0.5, 0.5], the denominator prev - 2 best + nxt (a parabola) or, with linear,
    max(prev, nxt) - best (the equiangular fit, suited to SAD-like costs); 0 where a
    neighbour is unknown (-1) or the denominator is not positive.  In float64 as NumPy
    divides integers, so that the map equals d + offset rounded once to float32.

    disp: int32 (H, W); best, prev, nxt: int64 (H, W); valid: uint8 (H, W); out:
    float32 (H, W)."""
    width = disp.shape[1]
    linear = sc[SUBPIXEL.linear] != 0
    nan = np.float32(np.nan)
    for y in range(sc[SUBPIXEL.y0], sc[SUBPIXEL.y1]):
        for x in range(width):
            if valid[y, x] == 0:
                out[y, x] = nan
                continue
            c, p, n = best[y, x], prev[y, x], nxt[y, x]
            offset = 0.0
            if p >= 0 and n >= 0:
                denominator = max(p, n) - c if linear else p - 2 * c + n
                if denominator > 0:
                    offset = min(max(np.float64(p - n) / np.float64(2 * denominator),
                                     -0.5), 0.5)
            out[y, x] = np.float32(np.float64(disp[y, x]) + offset)
    return 0


@njit(**SERIAL)
def confidence_map(best, second, valid, out, sc):
    """out[y, x] = (second - best) / second of the pixel's costs, in float64 rounded once
    to float32 (as NumPy divides integers), 0 where valid[y, x] is 0 or there is no
    second (second <= 0); for the rows y0 <= y < y1 (sc: CONFIDENCE).

    best, second: int64 (H, W); valid: uint8 (H, W); out: float32 (H, W)."""
    width = best.shape[1]
    for y in range(sc[CONFIDENCE.y0], sc[CONFIDENCE.y1]):
        for x in range(width):
            s = second[y, x]
            ratio = 0.0
            if valid[y, x] != 0 and s > 0:
                ratio = np.float64(s - best[y, x]) / np.float64(s)
            out[y, x] = np.float32(ratio)
    return 0


@njit(**SERIAL)
def _row_spans(disp, valid, y, offset, none, low, high):
    """low, high (w,) = half-size row y's spans (csw.matching.narrow.starts): each pixel's
    match (disp - offset) where valid, else the least and the greatest of the row's
    nearest valid matches on either side (one side's where only one has any); where the
    row has none, low = ``none`` and high = -1."""
    width = disp.shape[1]
    last = -1
    for x in range(width):  # the nearest match at or left of x, in low
        if valid[y, x] != 0:
            last = disp[y, x] - offset
        low[x] = last
    last = -1
    for x in range(width - 1, -1, -1):  # and at or right of x
        if valid[y, x] != 0:
            last = disp[y, x] - offset
        left = low[x]
        least = last if left < 0 else (left if last < 0 else min(left, last))
        low[x] = none if least < 0 else least
        high[x] = -1 if least < 0 else max(left, last)


@njit(**SERIAL)
def narrow_starts(disp, valid, low, high, rows, out, sc):
    """The narrowed search's starts (csw.matching.narrow.starts, which defines them)
    from a half-size match, for the half-size rows y0 <= y < y1 (sc: STARTS): out[Y, X]
    for every full-size pixel whose half-size pixel (min(Y // 2, h - 1), min(X // 2,
    w - 1)) lies in those rows.  offset: the half range's start (disp's d of offset 0);
    ndisp: the full range's size; slots: K; base, margin: the full-size offset of the
    half range's start, and the disparities added each side of a doubled span.

    disp: int32 (h, w) the half-size match; valid: uint8 (h, w), its left-right check;
    low, high: int32 (3, w), scratch: a ring of three rows' spans; rows: int32 (3, w),
    scratch: a row's least low and greatest high over its neighbourhood's rows, and its
    starts; out: int32 (H, W)."""
    height, width = disp.shape
    y0, y1, offset = sc[STARTS.y0], sc[STARTS.y1], sc[STARTS.offset]
    ndisp, slots, base, margin = sc[STARTS.ndisp], sc[STARTS.slots], sc[STARTS.base], \
        sc[STARTS.margin]
    none = 2 * ndisp  # above every low: no match in a row of the neighbourhood
    least, greatest, starts = rows[0], rows[1], rows[2]
    made = max(y0 - 1, 0) - 1  # the last row whose spans are in the ring
    for y in range(y0, y1):
        above, below = max(y - 1, 0), min(y + 1, height - 1)
        while made < below:
            made += 1
            _row_spans(disp, valid, made, offset, none, low[made % 3], high[made % 3])
        la, lh, lb = low[above % 3], low[y % 3], low[below % 3]
        ha, hh, hb = high[above % 3], high[y % 3], high[below % 3]
        for x in range(width):  # over the three rows, then the three columns
            least[x] = min(min(la[x], lh[x]), lb[x])
            greatest[x] = max(max(ha[x], hh[x]), hb[x])
        for x in range(width):
            lo = min(least[max(x - 1, 0)], least[x], least[min(x + 1, width - 1)])
            hi = max(greatest[max(x - 1, 0)], greatest[x], greatest[min(x + 1, width - 1)])
            own = disp[y, x] - offset if valid[y, x] != 0 else (lo + hi) // 2
            first = 2 * lo + base - margin
            span = 2 * hi + base + margin - first + 1
            start = first - (slots - span) // 2 if span <= slots else \
                2 * own + base - slots // 2
            start = start if lo <= hi else 0  # 0 where the neighbourhood has no match
            starts[x] = min(max(start, 0), ndisp - slots)
        line = out[2 * y]
        for x in range(width):
            line[2 * x] = starts[x]
            line[2 * x + 1] = starts[x]
        line[line.shape[0] - 1] = starts[width - 1]  # an odd width's last column
        last_row = 2 * y + 1 if y < height - 1 else out.shape[0] - 1
        for full_y in range(2 * y + 1, last_row + 1):
            copy = out[full_y]
            for x in range(copy.shape[0]):
                copy[x] = line[x]
    return 0

"""The fast engine: running sums, O(1) work per (pixel, disparity) whatever the window.

It computes the same contract as the window engine, bit for bit (integer sums are
exact, and the scan order and tie rule are the same), after OpenCV's stereobm.cpp:

  column sums   V[j, k] = sum over the w window rows of psi(L[., j], R[., j - d]),
                d = dmin + k, for padded column j; moved down one row by adding the
                entering row and subtracting the leaving one (the "_sub" row).
  row sums      H[k] = sum over b < w of V[x + b, k]: the cost C(y, x, d), moved right
                one pixel by adding V[x + w - 1] and subtracting V[x - 1].

V[j, k] is kept at 0 where j < d (no right column), so the running sums need no branch;
those H entries belong to candidates with x < d, which are never looked at.

Layout: the disparity index k is the innermost (contiguous) axis everywhere, and the right
image is stored with its columns reversed, so that R[y, j - d] for k = 0, 1, ... is a
forward, contiguous read and the loops over k vectorise.

Accumulator width is a decision: the narrowest unsigned/signed type that holds the
largest possible window cost (see ``accumulator_dtype``). Unsigned 16-bit sums wrap on
the way, but wrap-around arithmetic is exact modulo 2**16, and every true value fits.

Layers:
  match_fast      public: validate, pad, reverse, pick the accumulator, allocate
  _fast_driver    private, parallel: one prange iteration per row stripe, owning its
                  column sums, row sums and B-map
  _stripe         per-stripe worker; _shift_columns moves the column sums down,
                  _select_row slides the row sums and picks disparities
"""

import numpy as np
from numba import njit, prange

from .config import INLINE, PARALLEL, SERIAL
from .contract import (
    DEFAULT_CENSUS_WINDOW,
    INVALID,
    RULE_UNIQUE,
    SAD,
    SHD,
    SSD,
    candidate_count,
    run_stoppable,
    stop_requested,
    validate,
)
from .window import blocked, extra_maps, is_distinct, pad_edge, popcount, prepare, result

# SHD over values wider than 16 bits (census codes of 5x5 and 7x7 windows): its own cost
# code inside this engine, so that 8- and 16-bit SHD keeps its narrow-lane popcount.
SHD_WIDE = 4


@njit(**INLINE)
def popcount16(v):
    """Number of set bits of a value below 2**16, in 16-bit arithmetic (narrow lanes)."""
    v = v - ((v >> 1) & 0x5555)
    v = (v & 0x3333) + ((v >> 2) & 0x3333)
    v = (v + (v >> 4)) & 0x0F0F
    return (v + (v >> 8)) & 0x1F


def accumulator_dtype(image_dtype, cost, window):
    """The narrowest integer type that holds every window cost exactly."""
    top = np.iinfo(image_dtype).max
    bits = np.iinfo(image_dtype).bits
    per_pixel = {SAD: top, SSD: top * top}.get(cost, bits)
    largest = per_pixel * window * window
    # Strictly below the maximum: the maximum itself marks blocked candidates.
    for dtype in (np.uint16, np.int32, np.int64):
        if largest < np.iinfo(dtype).max:
            return dtype
    raise ValueError("window too large for exact 64-bit costs")


@njit(**INLINE)
def _psi(a, b, cost):
    """psi(a, b) written so that LLVM keeps it in the images' narrow lanes: |a - b| as
    max - min never leaves the unsigned range, where np.int64(a) - b would widen every
    SIMD lane to 64 bits."""
    if cost == SAD:
        return max(a, b) - min(a, b)
    if cost == SSD:
        diff = np.uint32(max(a, b) - min(a, b))  # its square fits 32 bits unsigned
        return diff * diff
    if cost == SHD:
        return popcount16(np.uint16(a ^ b))
    return popcount(a ^ b)


@njit(**INLINE)
def _shift_psi(sums, lv, right, lv_sub, right_sub, n, cost):
    """sums[k] += psi(lv, right[k]) - psi(lv_sub, right_sub[k]) for k < n."""
    if cost == SAD:
        for k in range(n):
            sums[k] = sums[k] + _psi(lv, right[k], SAD) - _psi(lv_sub, right_sub[k], SAD)
    elif cost == SSD:
        for k in range(n):
            sums[k] = sums[k] + _psi(lv, right[k], SSD) - _psi(lv_sub, right_sub[k], SSD)
    elif cost == SHD:
        for k in range(n):
            sums[k] = sums[k] + _psi(lv, right[k], SHD) - _psi(lv_sub, right_sub[k], SHD)
    else:
        for k in range(n):
            sums[k] = sums[k] + _psi(lv, right[k], SHD_WIDE) - _psi(lv_sub, right_sub[k],
                                                                   SHD_WIDE)


@njit(**INLINE)
def _column_shift(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin, cost):
    """col_sums[j, k] += psi(in_left[j], in_right[j - d]) - psi(out_left[j], out_right[j - d])
    for d = dmin + k <= j: move the column sums down one row in one pass, adding the
    entering row and subtracting the leaving (_sub) one.

    *_left: (Wp,) padded left rows.  *_right_rev: (Wp,) padded right rows, reversed, so
    right[j - d] = right_rev[Wp - 1 - j + d].  col_sums: (Wp, D).
    Inlined into one function per cost below, where the constant cost folds the other
    paths away.  psi(0, 0) = 0 for every cost, so a zero row as the leaving one adds a row.
    """
    wp, ndisp = col_sums.shape
    for j in range(dmin, wp):
        base = wp - 1 - j + dmin
        _shift_psi(col_sums[j], in_left[j], in_right_rev[base:], out_left[j],
                   out_right_rev[base:], min(ndisp, j - dmin + 1), cost)


@njit(**SERIAL)
def _column_shift_sad(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin):
    _column_shift(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin, SAD)


@njit(**SERIAL)
def _column_shift_ssd(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin):
    _column_shift(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin, SSD)


@njit(**SERIAL)
def _column_shift_shd(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin):
    _column_shift(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin, SHD)


@njit(**SERIAL)
def _column_shift_shd_wide(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin):
    _column_shift(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin, SHD_WIDE)


@njit(**SERIAL)
def _shift_columns(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin, cost):
    """_column_shift for the given cost."""
    if cost == SAD:
        _column_shift_sad(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin)
    elif cost == SSD:
        _column_shift_ssd(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin)
    elif cost == SHD:
        _column_shift_shd(in_left, in_right_rev, out_left, out_right_rev, col_sums, dmin)
    else:
        _column_shift_shd_wide(in_left, in_right_rev, out_left, out_right_rev, col_sums,
                               dmin)


@njit(**SERIAL)
def _select_row(col_sums, row_sums, zero_row, never, s, claims_rev, right_best_rev,
                right_rev_d, disp_row, cost_row, second_row, prev_row, next_row, right_row):
    """Slide the row sums along one row and pick each pixel's disparity in the contract's
    order: x ascending, and the smallest d among the minimum costs.

    col_sums: (Wp, D).  row_sums: (D,) scratch, of the accumulator dtype.
    zero_row: (D,) zeros of that dtype, the "leaving column" of the first pixel.
    never: accumulator scalar above every real cost (its dtype's maximum), so that blocked
        candidates drop out of the min without a branch and the loops stay SIMD.
    s: the Setup record.
    claims_rev: int64 (W,) the B-map reversed: claims[x - d] = claims_rev[W-1-x+d], the
        column of the pixel that last claimed each right pixel or -1, so the candidates
        of one pixel read it forward; reset here.
    right_best_rev: (W,) accumulator dtype, right_rev_d: int16 (W,): scratch, reversed like
        claims_rev: the least cost seen for each right pixel and its d - dmin (with
        s.right_map).
    disp_row: int32 (W,) out.  cost_row: int64 (W,) out.  second_row, prev_row, next_row:
        int64 (W,) out, written with s.extras; right_row: int32 (W,) out, written with
        s.right_map.
    Returns the number of candidates evaluated (those not blocked).

    The loops are written out here rather than in helpers: Numba's IR inlining of a
    helper kept LLVM from fusing them, and cost about 1.7x in time.
    """
    width = disp_row.shape[0]
    ndisp = col_sums.shape[1]
    w, dmin, csw, slack = s.window, s.dmin, s.csw, s.slack
    claims_rev[:] = -1
    if s.right_map:
        right_best_rev[:] = never
        right_rev_d[:] = INVALID
    # The window of pixel 0 less its last column, which the first slide adds.
    row_sums[:] = 0
    for b in range(w - 1):
        sums = col_sums[b]
        for k in range(ndisp):
            row_sums[k] = row_sums[k] + sums[k]
    evaluated = 0
    for x in range(width):
        n = max(min(ndisp, x - dmin + 1), 0)  # candidates d = dmin + k <= x
        base = width - 1 - x + dmin  # claims[k] and the right pixel x - dmin - k, reversed
        claims = claims_rev[base:]
        add = col_sums[x + w - 1]  # the column entering the window
        sub = col_sums[x - 1] if x > 0 else zero_row  # the column leaving it
        # Slide the first n sums and take their minimum in the same pass; blocked
        # candidates count as `never`.  Then the first index holding the minimum, as a
        # branch-free min over indices so that it vectorises like the min itself.
        best = never
        taken = 0
        first = np.int16(n)  # narrow lanes for the index min, like the sums' (D <= 2**15)
        none = np.int16(n)
        if csw:
            for k in range(n):
                row_sums[k] = row_sums[k] + add[k] - sub[k]
                skip = blocked(claims[k], x, slack)
                taken += skip
                best = min(best, never if skip else row_sums[k])
            for k in range(n):
                hit = row_sums[k] == best and not blocked(claims[k], x, slack)
                first = min(first, np.int16(k) if hit else none)
        elif s.right_map:
            # Also the right image's best match per right pixel, from the same costs, in
            # the same pass: for right pixel x - d, a strict < over ascending x keeps the
            # smallest d among equals.  d is kept as d - dmin in int16, the sums' lanes.
            best_r = right_best_rev[base:]
            d_r = right_rev_d[base:]
            for k in range(n):
                row_sums[k] = row_sums[k] + add[k] - sub[k]
                best = min(best, row_sums[k])
            for k in range(n):
                first = min(first, np.int16(k) if row_sums[k] == best else none)
            for k in range(n):
                v = row_sums[k]
                d_r[k] = np.int16(k) if v < best_r[k] else d_r[k]
                best_r[k] = min(v, best_r[k])
        else:
            for k in range(n):
                row_sums[k] = row_sums[k] + add[k] - sub[k]
                best = min(best, row_sums[k])
            for k in range(n):
                first = min(first, np.int16(k) if row_sums[k] == best else none)
        for k in range(n, ndisp):  # not candidates yet (d > x), needed further right
            row_sums[k] = row_sums[k] + add[k] - sub[k]
        evaluated += n - taken
        if s.right_map and csw:
            # The right image's best matches as above, over the candidates not blocked.
            best_r = right_best_rev[base:]
            d_r = right_rev_d[base:]
            for k in range(n):
                c = never if blocked(claims[k], x, slack) else row_sums[k]
                better = c < best_r[k]
                best_r[k] = min(c, best_r[k])
                d_r[k] = np.int16(k) if better else d_r[k]
        if taken == n:  # no candidate (x < dmin), or every one blocked
            disp_row[x] = INVALID
            cost_row[x] = -1
            if s.extras:
                second_row[x] = -1
                prev_row[x] = -1
                next_row[x] = -1
            continue
        disp_row[x] = dmin + first
        cost_row[x] = best
        second = never
        if csw and (s.extras or (s.rule == RULE_UNIQUE and best <= s.tau)):
            # The least evaluated cost at least 2 away from first.  One pass over all
            # candidates, the three next to the best masked out, vectorises better than
            # two passes around them.
            for k in range(n):
                skip = blocked(claims[k], x, slack) or abs(k - first) <= 1
                second = min(second, never if skip else row_sums[k])
        elif s.extras:
            # Without CSW nothing is blocked: one plain minimum over all candidates, with
            # the best's three set aside for it (and put back: later pixels slide them).
            lo, hi = max(int(first) - 1, 0), min(int(first) + 2, n)
            mid = min(lo + 1, hi - 1)
            kept0, kept1, kept2 = row_sums[lo], row_sums[mid], row_sums[hi - 1]
            for k in range(lo, hi):
                row_sums[k] = never
            for k in range(n):
                second = min(second, row_sums[k])
            row_sums[hi - 1] = kept2  # in reverse: where indices coincide, values agree
            row_sums[mid] = kept1
            row_sums[lo] = kept0
        if s.extras:
            second_row[x] = -1 if second == never else np.int64(second)
            prev_row[x] = -1 if first == 0 or (csw and blocked(claims[first - 1], x, slack)) \
                else np.int64(row_sums[first - 1])
            next_row[x] = -1 if first + 1 >= n or (csw and blocked(claims[first + 1], x,
                                                                      slack)) \
                else np.int64(row_sums[first + 1])
        if not csw or best > s.tau:
            continue
        if s.rule == RULE_UNIQUE and (second == never or not is_distinct(
                np.int64(best), np.int64(second), s.uniqueness)):
            continue
        claims_rev[base + first] = x
    if s.right_map:
        for xr in range(width):
            k = right_rev_d[width - 1 - xr]
            right_row[xr] = INVALID if k < 0 else dmin + k
    return evaluated


@njit(**SERIAL)
def _stripe(left_p, right_rev, y0, y1, s, col_sums, row_sums, zero_row, zero_pixels, never,
            claims, right_best, right_d, disp, min_cost, second, prev, nxt, right_disp,
            evaluated, stop):
    """Match image rows y0 <= y < y1 into disp, min_cost (and the extras maps) and
    evaluated (per row) there; return early, before a row, once stop[0] is set.

    left_p: (H + w - 1, Wp) padded left.  right_rev: the padded right, columns reversed.
    s: the Setup record.  col_sums: (Wp, D) and row_sums: (D,) accumulators, zero_row
    (D,) zeros of their dtype; zero_pixels: (Wp,) zeros of the images' dtype; claims:
    int64 (W,) reversed B-map; right_best, right_d: (W,) reversed right-map scratch.
    All scratch.  stop: uint8 (1,).
    """
    w, dmin, cost = s.window, s.dmin, s.cost
    col_sums[:] = 0
    for a in range(w):  # the window of padded rows y0 .. y0 + w - 1, each added once
        _shift_columns(left_p[y0 + a], right_rev[y0 + a], zero_pixels, zero_pixels,
                       col_sums, dmin, cost)
    for y in range(y0, y1):
        if stop_requested(stop):
            return
        if y > y0:
            # Move down: row y + w - 1 enters the window, row y - 1 leaves (the _sub row).
            _shift_columns(left_p[y + w - 1], right_rev[y + w - 1], left_p[y - 1],
                           right_rev[y - 1], col_sums, dmin, cost)
        e = y if s.extras else 0  # maps not asked for are 1-row dummies
        r = y if s.right_map else 0
        evaluated[y] = _select_row(col_sums, row_sums, zero_row, never, s, claims, right_best,
                                   right_d, disp[y], min_cost[y], second[e], prev[e], nxt[e],
                                   right_disp[r])


@njit(**PARALLEL)
def _fast_driver(left_p, right_rev, stripes, s, acc_max, disp, min_cost, second, prev, nxt,
                 right_disp, stop):
    """Run row stripes in parallel; each iteration owns its sums and B-map.

    stripes: int64 (n, 2), [start, end) rows of each stripe.  s: the Setup record.
    acc_max: (1,) array of the accumulator dtype holding its maximum.  disp: int32 (H, W)
    out.  min_cost: int64 (H, W) out.  second, prev, nxt: int64 (H, W) out with s.extras;
    right_disp: int32 (H, W) out with s.right_map.  stop: uint8 (1,), set to stop every
    stripe before its next row.  Returns int64 (H,), candidates evaluated per row.
    """
    n = stripes.shape[0]
    height, width = disp.shape
    wp = left_p.shape[1]
    ndisp = s.dmax - s.dmin + 1
    evaluated = np.zeros(height, np.int64)
    for i in prange(n):
        col_sums = np.zeros((wp, ndisp), acc_max.dtype)
        row_sums = np.zeros(ndisp, acc_max.dtype)
        zero_row = np.zeros(ndisp, acc_max.dtype)
        zero_pixels = np.zeros(wp, left_p.dtype)
        claims = np.empty(width, np.int64)
        right_best = np.empty(width, acc_max.dtype)
        right_d = np.empty(width, np.int16)
        _stripe(left_p, right_rev, stripes[i, 0], stripes[i, 1], s, col_sums, row_sums,
                zero_row, zero_pixels, acc_max[0], claims, right_best, right_d, disp,
                min_cost, second, prev, nxt, right_disp, evaluated, stop)
    return evaluated


def stripe_bounds(height, window, threads, rows):
    """int64 (n, 2) [start, end) rows of the stripes covering ``rows`` (ascending).

    Starting a stripe costs w rows of column sums, so each run of consecutive rows is cut
    into stripes as few and tall as load balance allows: one for one thread; otherwise up
    to 4 per thread, each at least 16 windows tall.  A sample of scattered rows (as for
    tau auto) gets one single-row stripe per row, so its cost follows the sample's size;
    a band's core rows (csw.tiled) are one run.
    """
    if rows.size == 0:
        return np.zeros((0, 2), np.int64)
    breaks = np.flatnonzero(np.diff(rows) != 1) + 1
    starts = rows[np.r_[0, breaks]]
    ends = rows[np.r_[breaks - 1, rows.size - 1]] + 1
    stripes = []
    for start, end in zip(starts, ends, strict=True):
        run = int(end - start)
        per_thread = 1 if threads == 1 else max(1, min(4, run // (threads * 16 * window)))
        count = max(1, min(threads * per_thread, run))
        edges = start + np.linspace(0, run, count + 1).round().astype(np.int64)
        stripes.append(np.stack([edges[:-1], edges[1:]], axis=1))
    return np.concatenate(stripes).astype(np.int64)


def match_fast(left, right, *, window, dmin, dmax, cost, csw=False, tau=-1,
               rule="literal", uniqueness=None, slack=None, rows=None, threads=None,
               census_window=DEFAULT_CENSUS_WINDOW, extras=False, right_map=False):
    """Match a rectified pair with running sums (same contract as match_window).

    left, right: uint8 or uint16 (H, W), same shape and dtype; left is the reference.
    rows: optional ascending row indices; the maps are then (n, W) for those rows.
    Other options as for match_window.
    Returns a MatchResult: disparity int32 (H, W), min_cost int64 (H, W).
    """
    left, right, s, rows = validate(left, right, window=window, dmin=dmin, dmax=dmax,
                                    cost=cost, csw=csw, tau=tau, rule=rule,
                                    uniqueness=uniqueness, slack=slack, rows=rows,
                                    census_window=census_window, extras=extras,
                                    right_map=right_map)
    height, width = left.shape
    if s.dmax - s.dmin + 1 > np.iinfo(np.int16).max:
        raise ValueError("the fast engine searches at most 32767 disparities at once; "
                         "narrow dmin..dmax or use the window engine")
    left, right, s = prepare(left, right, s, census_window)
    if s.cost == SHD and left.dtype.itemsize > 2:
        s = s._replace(cost=SHD_WIDE)
    h = s.window // 2
    left_p = pad_edge(left, h, left.dtype)
    right_rev = np.ascontiguousarray(pad_edge(right, h, right.dtype)[:, ::-1])
    acc_type = accumulator_dtype(left.dtype, s.cost, s.window)
    acc_max = np.array([np.iinfo(acc_type).max], acc_type)
    disp = np.empty((height, width), np.int32)
    min_cost = np.empty((height, width), np.int64)
    maps = extra_maps(disp.shape, s)

    def run(stop, n_threads):
        stripes = stripe_bounds(height, s.window, n_threads, rows)
        return _fast_driver(left_p, right_rev, stripes, s, acc_max, disp, min_cost, *maps,
                            stop)

    per_row = run_stoppable(run, threads, work=rows.size * width * (s.dmax - s.dmin + 1))
    if rows.size != height:  # only the sampled rows were computed
        disp, min_cost = disp[rows], min_cost[rows]
        maps = tuple(m[rows] if m.shape[0] == height else m for m in maps)
    plain = candidate_count(width, s.dmin, s.dmax) * rows.size
    return result(disp, min_cost, int(per_row[rows].sum()), plain, s, maps)

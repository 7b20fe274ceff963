"""Semi-global matching's workers (see kernels/sgm.py for the entry, the bands and the
parallel driver).  The definition, exactly (docs/engines.md, "Semi-global matching"):

  C(y, x, k)   the window cost of the contract at d = dmin + k, or cmax (above every
               real cost) where the right pixel x - d lies outside the image
  L_r(p, k)    = C(p, k) + min(L_r(p - r, k), L_r(p - r, k +- 1) + P1,
                               min_j L_r(p - r, j) + P2) - min_j L_r(p - r, j)
               along each path r; at a path's first pixel L_r(p, k) = C(p, k)
  S(p, k)      the sum of L_r over the paths: 4 (left, right, down, up) or 8 (and the
               four diagonals)

Every value is exact in the accumulator type: L_r <= cmax + P2 and S <= paths * (cmax +
P2) are checked to fit before a match (kernels/sgm.py), so no sum saturates or wraps.
The winner is the least S over a pixel's candidates, the smallest d among equals, as
in the local engines; its second best, neighbours, right map and left-right check are
taken from S as the fast engine takes them from C.

One entry per variant, its step chosen by a scalar (one compile, not five):
  COSTS      the window costs of image rows y0 <= y < y1 into the band's cost slab
             with each row's step of the vertical path down (or, the rows going up,
             of the path up)
  VERTICAL   a vertical path over the band's rows, for the columns x0 <= x < x1
  DIAGONAL   the two diagonal paths going down, or up, over the band's rows
  SELECT     the two horizontal paths of rows y0 <= y < y1, then each pixel's winner
             (fused: the rows going up, or down, each with its step of the vertical
             path that way)

A fused step makes a vertical path's row while the row's costs and sums are in the
caches, rather than in a pass of its own over the slabs, which reads them from memory:
the costs step always, the winners step where one thread takes a band's rows, or each
of two threads half of them (kernels/sgm.py).

Path states: state (2, W, D + 2) two buffers of each column's L along a vertical or
diagonal path (the row before and the row being made), with a sentinel (``big``) at both
ends of the d axis, so that L(k - 1) and L(k + 1) need no test; mins (2, W) their
minima.  Buffer 0 holds the state when a step starts and when it ends.

A whole-range pass may pad its d axis (costs, sums, states) past the D candidates to
whole vectors of LANES (kernels/sgm.py chooses; the scalar ``slots`` is D), the extra
slots costing pad_cost = cmax + 2 P2 - P1: every L_r there is then at least that, no
less than any real L_r (at most cmax + P2), so min_j L_r is the candidates', and slot
D - 1's neighbour plus P1 is at least min_j L_r + P2, which the recurrence takes
anyway, as it takes the sentinel's.  The winners are taken among the D only.

A narrowed variant ("banded") searches K slots a pixel, slot k of pixel p holding
d = dmin + starts[p] + k: the cost slab is (B, W, K), and a path meets p - r's slots
of d and d -/+ 1, shift = starts[p] - starts[p - r] slots away; a d that p - r did not
search has no L, as one beyond the range.  Its states are (2, W, K + 2) as a
whole-range pass's; where p - r searched other slots (shift not 0: on a KITTI pair 4 to
7 pixels in a hundred), its state is first moved in place (each state is read by one
pixel), each value to the slot of the same d and a sentinel where p - r has none
(meet), and path_step reads it unchanged.  (States padded by K + 2 sentinels each side
and read through a shifted view moved nothing, but were three times the size: a
KITTI pair's two steps at one thread took 29-30 and 34-35 ms against 24-26 and 32-33
with states of K + 2.)  Its sentinel is above every min_j L + P2, so that a d without L is as one
beyond the range (kernels/sgm.py).
"""

import numpy as np
from numba import njit

from ..contract import LANES
from ..signature import Signature, Spec, arg, scalar_index
from .common import (
    ctpop,
    dtype_of,
    keep_or_take,
    lr_agrees,
    prefetch,
    prefetch_write,
    stop_requested,
)
from .options import INLINE, SERIAL

COSTS, VERTICAL, DIAGONAL, SELECT = 0, 1, 2, 3
# Pixels ahead that the path from the right asks the caches for (it walks memory
# downwards, where the CPU's prefetchers don't follow: on a Zen 1 core the path took
# twice the time of the path from the left without them).
AHEAD = 4

SC = scalar_index(("step", "window", "dmin", "p1", "p2", "cmax", "never", "y0", "y1",
                   "band_y0", "x0", "x1", "direction", "add", "extras", "keep_right",
                   "lr_limit", "keyed", "tile_rows", "fused", "slots", "pad_cost"))



def spec(cost, pixels, costs, accumulator, negative=False, banded=False):
    """The worker of a variant: cost "sad", "ssd" or "shd" (census codes compared with
    shd); pixels: the compared type; costs: the cost slab's type ("u8" where every cost
    fits a byte, else the accumulator's); accumulator: "u16" or "u32", of paths and
    sums; negative: the range starts below 0; banded: each pixel searches its own
    slots (see above)."""
    pix, cst, acc = dtype_of(pixels), dtype_of(costs), dtype_of(accumulator)
    i16, i32, i64, u8 = (np.dtype(t) for t in (np.int16, np.int32, np.int64, np.uint8))
    arrays = (arg("left_p", pix, 2), arg("right_rev", pix, 2),  # (H + w - 1, Wp [+ s])
              arg("costs", cst, 3), arg("sums", acc, 3),  # (B, W, D) the band's slabs
              arg("col_sums", acc, 2), arg("row_sums", acc, 1),  # (Wp, D), (D,) scratch
              arg("ring", u8, 3),  # (w, Wp, D) scratch for "shd", else (1, 1, 1)
              arg("row_costs", cst, 2),  # (W, D) a banded variant's scratch, else (1, 1)
              arg("spans", i32, 2),  # (2, Wp) scratch: each column's k (cost_rows)
              arg("state", acc, 3), arg("mins", acc, 2),  # (2, W, D + 2), (2, W)
              arg("other", acc, 3), arg("other_mins", acc, 2),  # a diagonal's partner
              arg("line", acc, 2),  # (2, D + 2) a horizontal path's scratch
              arg("moved", acc, 1),  # (D + 2,) meet's scratch (a whole-range pass: (1,))
              arg("right_best", acc, 1), arg("right_d", i16, 1),  # (W + s,) scratch
              arg("disp", i32, 2), arg("min_cost", i64, 2),  # (H, W) out
              arg("second", i64, 2), arg("prev", i64, 2), arg("next", i64, 2),  # extras
              arg("right_disp", i32, 2), arg("lr_valid", u8, 2),  # or 1-row dummies
              arg("starts", i32, 2),  # (H, W) a banded variant's, else (1, 1)
              arg("stop", u8, 1))
    return Spec(_make(cost, cst.type, acc.type, bool(negative), bool(banded)),
                Signature(arrays, SC._fields))


def _make(cost, cost_type, acc, negative, banded):
    """The worker of one variant; ``cost``, the slab's ``cost_type``, ``acc``,
    ``negative`` and ``banded`` are compile-time constants in it."""
    from ..contract import INVALID, NEG_INVALID

    invalid = NEG_INVALID if negative else INVALID
    # 16-bit totals may pick their least at its smallest k as one minimum of keys,
    # total << 16 | k, in one pass with the path from the left, or as two passes of
    # 16-bit lanes: which is faster depends on the CPU (kernels/fast.py, keyed_range),
    # so the scalar "keyed" chooses, and both ways are compiled.
    may_key = acc == np.uint16
    # Elements a cache line: the prefetches' steps, constants here (an array's itemsize
    # is read at run time, and the range's length then takes two divisions a pixel).
    sum_line, cost_line = 64 // np.dtype(acc).itemsize, 64 // np.dtype(cost_type).itemsize

    # Only a byte slab's window costs may pass its c_max, where catalogue.aggregated_max
    # truncates them; a wider slab stores each as it is, with no test a cost.
    truncates = np.dtype(cost_type).itemsize < np.dtype(acc).itemsize

    @njit(**INLINE)
    def stored(value, cap):
        """A window cost (acc) as the slab holds it: at most cap where it may pass it."""
        if truncates:
            return cost_type(min(value, cap))
        return cost_type(value)

    @njit(**SERIAL)
    def psi(a, b):
        """As the fast engine's: in the pixels' narrow lanes."""
        if cost == "sad":
            return max(a, b) - min(a, b)
        if cost == "ssd":
            diff = np.uint32(max(a, b) - min(a, b))
            return diff * diff
        return ctpop(a ^ b)

    # Hamming costs keep each window row's costs (at most 64: a byte) in a ring of w
    # rows, so that a row leaving the column sums subtracts what it added rather than
    # counting its bits again, as the fast engine does (kernels/jit/fast.py).
    ringed = cost == "shd"

    @njit(**SERIAL)
    def column_add(left, right_rev, sums, dmin, kept, spans):
        """sums[j, k] += psi(left[j], right[j - d]) for d = dmin + k, k in spans[0, j] ..
        spans[1, j] - 1 (at most the candidates, d <= j), over the padded columns j; a
        ringed variant keeps the costs in kept, uint8 (Wp, D).  The loops index views
        that start at the span, from 0: an index from an array may be negative for all
        Numba knows, and its wraparound test per access cost 1.5x the whole search."""
        wp = sums.shape[0]
        wr = right_rev.shape[0]
        for j in range(max(dmin, 0), wp):
            lo, count = spans[0, j], spans[1, j] - spans[0, j]
            s = sums[j, lo:]
            lv = left[j]
            r = right_rev[wr - 1 - j + dmin + lo:]
            if ringed:
                row = kept[j, lo:]
                for k in range(count):
                    c = np.uint8(psi(lv, r[k]))
                    s[k] = s[k] + c
                    row[k] = c
            else:
                for k in range(count):
                    s[k] = s[k] + psi(lv, r[k])

    @njit(**SERIAL)
    def column_move(left, right_rev, left_sub, right_sub_rev, sums, dmin, kept, spans):
        """As column_add for the entering rows, less the leaving (_sub) ones' costs (from
        kept, where the entering row's then go, in a ringed variant), in one pass; exact
        modulo the accumulator's width."""
        wp = sums.shape[0]
        wr = right_rev.shape[0]
        for j in range(max(dmin, 0), wp):
            lo, count = spans[0, j], spans[1, j] - spans[0, j]
            s = sums[j, lo:]
            lv, lv_sub = left[j], left_sub[j]
            base = wr - 1 - j + dmin + lo
            r, r_sub = right_rev[base:], right_sub_rev[base:]
            if ringed:
                row = kept[j, lo:]
                for k in range(count):
                    c = np.uint8(psi(lv, r[k]))
                    s[k] = s[k] + c - row[k]
                    row[k] = c
            else:
                for k in range(count):
                    s[k] = s[k] + psi(lv, r[k]) - psi(lv_sub, r_sub[k])

    @njit(**SERIAL)
    def whole_spans(spans, dmin, ndisp, x0, x1, w):
        """The candidates of the columns that pixels x0 <= x < x1 sum (x0 <= j < x1 + w
        - 1): k < ndisp and d = dmin + k <= j; none for the others."""
        for j in range(spans.shape[1]):
            spans[0, j] = 0
            spans[1, j] = max(min(ndisp, j - dmin + 1), 0) if x0 <= j < x1 + w - 1 else 0

    @njit(**SERIAL)
    def tile_spans(starts, t0, t1, slots, w, dmin, ndisp, spans, x0, x1):
        """A banded variant's column spans over image rows t0 <= y < t1, for pixels x0
        <= x < x1: padded column j is in the windows of pixels x = j - w + 1 .. j, so
        its sums are needed from the least of their starts to the greatest start + slots
        (exclusive), candidates only (d <= j), widened to whole vectors (LANES);
        none for columns no such pixel sums.
        starts: int32 (H, W); spans: int32 (2, Wp) out."""
        low, high = spans[0], spans[1]
        for x in range(x0, x1):
            low[x] = starts[t0, x]
            high[x] = starts[t0, x]
        for y in range(t0 + 1, t1):
            row = starts[y]
            for x in range(x0, x1):
                low[x] = min(low[x], row[x])
                high[x] = max(high[x], row[x])
        # From the right, so that column j reads only pixels' entries (x <= j) not yet
        # overwritten by a column's.
        for j in range(spans.shape[1] - 1, -1, -1):
            a, b = max(j - w + 1, x0), min(j, x1 - 1)
            if a > b:  # no pixel of x0..x1 - 1 sums column j
                low[j], high[j] = 0, 0
                continue
            least, most = low[a], high[a]
            for x in range(a + 1, b + 1):
                least = min(least, low[x])
                most = max(most, high[x])
            top = min(ndisp, j - dmin + 1)
            end = max(min(most + slots, top), least)
            # Widened to whole vectors of LANES where the candidates allow: the
            # column loops then leave no remainder to do one d at a time, and the extra
            # sums are made like the others, never read.
            extra = -(end - least) % LANES if end > least else 0
            grown = min(extra, top - end)
            low[j] = max(least - (extra - grown), 0)
            high[j] = end + grown

    @njit(**SERIAL)
    def gather(row, out, row_starts, x0, x1):
        """A banded variant's slab row: out[x, k] = row[x, row_starts[x] + k], x0 <= x <
        x1, row being the whole range's costs of the image row (cmax where d has no
        right pixel)."""
        slots = out.shape[1]
        for x in range(x0, x1):
            source = row[x, row_starts[x]:]
            target = out[x]
            for k in range(slots):
                target[k] = source[k]

    @njit(**INLINE)
    def ask_to_write(costs_row, sums_row, x, costs_too, sums_too):
        """Ask for pixel x's lines of a slab row about to be stored (prefetch_write): its
        costs (costs_too) and its sums (sums_too)."""
        if costs_too:
            for k in range(0, costs_row.shape[1], cost_line):
                prefetch_write(costs_row, (x, k))
        if sums_too:
            for k in range(0, sums_row.shape[1], sum_line):
                prefetch_write(sums_row, (x, k))

    @njit(**INLINE)
    def ask_to_read(costs_row, sums_row, x):
        """Ask for pixel x's lines of a slab row about to be read: its costs and sums."""
        for k in range(0, sums_row.shape[1], sum_line):
            prefetch(sums_row, (x, k))
        for k in range(0, costs_row.shape[1], cost_line):
            prefetch(costs_row, (x, k))

    @njit(**SERIAL)
    def band_row(col_sums, row_sums, out, row_starts, w, dmin, cmax, x0, x1, next_costs,
                 next_sums, costs_too, sums_too):
        """A banded variant's slab row from the column sums, pixels x0 <= x < x1: out[x,
        k] = C(y, x, dmin + row_starts[x] + k), the sum of the window's w columns, or
        slid from pixel x - 1's where that searched the same slots (two columns' work
        for w).  Columns' sums
        outside their spans hold stale values: they reach only slots that are not
        candidates (cmax), or cancel exactly in a slide (the same value added at x - 1
        and subtracted at x).  next_costs, next_sums: the next row's, asked for as
        ask_to_write says."""
        width, slots = out.shape
        ndisp = col_sums.shape[1]
        cap = acc(cmax)  # stored's
        previous = -1
        for x in range(x0, x1):
            ask_to_write(next_costs, next_sums, x, costs_too, sums_too)
            start = row_starts[x]
            if start == previous:
                add = col_sums[x + w - 1, start:]
                sub = col_sums[x - 1, start:]
                for k in range(slots):
                    row_sums[k] = row_sums[k] + add[k] - sub[k]
            else:
                first = col_sums[x, start:]
                for k in range(slots):
                    row_sums[k] = first[k]
                for b in range(1, w):
                    column = col_sums[x + b, start:]
                    for k in range(slots):
                        row_sums[k] = row_sums[k] + column[k]
                previous = start
            # Candidates: d <= x and x - d <= width - 1, the slots head..tail - 1.
            n = max(min(ndisp, x - dmin + 1), 0)
            lo = min(max(x - dmin - (width - 1), 0), n) if negative else 0
            head = min(max(lo - start, 0), slots)
            tail = min(max(n - start, head), slots)
            c = out[x]
            for k in range(head):
                c[k] = cmax
            # Views from the first candidate, indexed from 0: an index that Numba can't
            # prove non-negative is tested for wraparound at every access.
            source, target = row_sums[head:], c[head:]
            for k in range(tail - head):
                target[k] = stored(source[k], cap)
            beyond = c[tail:]
            for k in range(slots - tail):
                beyond[k] = cmax

    @njit(**SERIAL)
    def cost_rows(left_p, right_rev, costs, col_sums, row_sums, ring, row_costs, spans,
                  starts, sums, state, mins, moved, sc, stop):
        """costs[y - band_y0, x, k] = C(y, x, dmin + k) for rows y0 <= y < y1: column
        sums moved down the rows, row sums slid along each row (kernels/jit/fast.py).
        Pixels x0 <= x < x1 only (their columns' sums: w - 1 more).  Each row's step of
        the vertical path down through those pixels (state, mins; add as for vertical)
        follows its costs, while they are in the caches; direction -1: the rows go up
        from y1 - 1 (the column sums moved up), each with its step of the path up.
        band_y0 is the slab's first row.
        A banded variant with a window works in tiles of rows (sc[tile_rows]): each
        column's sums cover only the slots its pixels search in the tile (tile_spans),
        and each pixel sums its own slots (band_row).  With a window of 1 it makes each
        row's costs over the whole range in row_costs, (W, D), and gathers each pixel's
        slots from there."""
        w, dmin, cmax = sc[SC.window], sc[SC.dmin], cost_type(sc[SC.cmax])
        y0, y1, band_y0 = sc[SC.y0], sc[SC.y1], sc[SC.band_y0]
        width = costs.shape[1]
        ndisp = col_sums.shape[1]
        # A whole-range pass's d axis runs past the range to whole vectors (see above):
        # its real disparities are the first ``slots``, the others cost pad_cost.
        real = ndisp if banded else sc[SC.slots]
        pad_cost = cost_type(sc[SC.pad_cost])
        cap = acc(sc[SC.cmax])  # stored's
        add = sc[SC.add]
        p1, p2, never = acc(sc[SC.p1]), acc(sc[SC.p2]), acc(sc[SC.never])
        x0, x1 = sc[SC.x0], sc[SC.x1]
        direction = sc[SC.direction]
        up = direction < 0
        if w == 1:  # each pixel's own cost: no sums to move
            wr = right_rev.shape[1]
            for i in range(y1 - y0):
                if stop_requested(stop):
                    return 0
                y = y1 - 1 - i if up else y0 + i
                out = row_costs if banded else costs[y - band_y0]
                left, right = left_p[y], right_rev[y]
                for x in range(x0, x1):
                    n = max(min(real, x - dmin + 1), 0)
                    lo = min(max(x - dmin - (width - 1), 0), n) if negative else 0
                    c = out[x]
                    lv = left[x]
                    r = right[wr - 1 - x + dmin:]
                    for k in range(lo):
                        c[k] = cmax
                    for k in range(lo, n):
                        c[k] = cost_type(psi(lv, r[k]))
                    for k in range(n, ndisp):
                        c[k] = cmax if k < real else pad_cost
                if banded:
                    gather(out, costs[y - band_y0], starts[y], x0, x1)
                vertical_row(costs, sums, state, mins, starts, moved, i, y, direction,
                             band_y0, x0, x1, add, p1, p2, never)
            vertical_end(state, mins, y1 - y0, x0, x1)
            return 0
        tile = sc[SC.tile_rows] if banded else max(y1 - y0, 1)
        if not banded:  # past the range too (whole vectors): sums made, never read
            whole_spans(spans, dmin, ndisp, x0, x1, w)
        for t in range(0, y1 - y0, tile):
            # Tiles from the first row of the run: the bottom one going up.
            t0, t1 = (max(y1 - t - tile, y0), y1 - t) if up else (y0 + t, min(y0 + t + tile, y1))
            first = t1 - 1 if up else t0
            if banded:
                tile_spans(starts, t0, t1, costs.shape[2], w, dmin, ndisp, spans, x0, x1)
            for j in range(col_sums.shape[0]):
                s = col_sums[j, spans[0, j]:]
                for k in range(spans[1, j] - spans[0, j]):
                    s[k] = 0
            for a in range(w):
                column_add(left_p[first + a], right_rev[first + a], col_sums, dmin,
                           ring[(first + a) % w if ringed else 0], spans)
            for i_tile in range(t1 - t0):
                if stop_requested(stop):
                    return 0
                y = t1 - 1 - i_tile if up else t0 + i_tile
                if i_tile > 0:
                    # Going down, padded row y + w - 1 enters and y - 1 leaves; going up,
                    # y enters and y + w leaves: one slot of the ring either way.
                    enter, leave = (y, y + w) if up else (y + w - 1, y - 1)
                    column_move(left_p[enter], right_rev[enter], left_p[leave],
                                right_rev[leave], col_sums, dmin,
                                ring[leave % w if ringed else 0], spans)
                # The next row's costs and (but for the state alone) its sums are
                # stored next: their lines asked for now, so that those stores find them
                # in the caches.
                next_y = y - 1 if up else y + 1
                costs_too = y0 <= next_y < y1
                sums_too = costs_too and add != 2
                next_costs = costs[next_y - band_y0 if costs_too else 0]
                next_sums = sums[next_y - band_y0 if sums_too else 0]
                i = y1 - 1 - y if up else y - y0  # the row's place in the vertical run
                if banded:
                    band_row(col_sums, row_sums, costs[y - band_y0], starts[y], w, dmin,
                             cmax, x0, x1, next_costs, next_sums, costs_too, sums_too)
                    vertical_row(costs, sums, state, mins, starts, moved, i, y, direction,
                                 band_y0, x0, x1, add, p1, p2, never)
                    continue
                row_sums[:] = 0
                for b in range(x0, x0 + w - 1):
                    s = col_sums[b]
                    for k in range(ndisp):
                        row_sums[k] = row_sums[k] + s[k]
                out = costs[y - band_y0]
                for x in range(x0, x1):
                    ask_to_write(next_costs, next_sums, x, costs_too, sums_too)
                    entering = col_sums[x + w - 1]
                    sub = col_sums[x - 1] if x > x0 else col_sums[0]
                    c = out[x]
                    # Candidates: d <= x and x - d <= width - 1 (k in lo..n - 1); the
                    # slots past the range take pad_cost.
                    n = max(min(real, x - dmin + 1), 0)
                    lo = min(max(x - dmin - (width - 1), 0), n) if negative else 0
                    keep = 1 if x > x0 else 0  # column x0 is not yet in the sums at x0
                    for k in range(ndisp):
                        v = acc(row_sums[k] + entering[k] - sub[k] * keep)
                        row_sums[k] = v
                        c[k] = stored(v, cap) if lo <= k < n else \
                            (cmax if k < real else pad_cost)
                vertical_row(costs, sums, state, mins, starts, moved, i, y, direction,
                             band_y0, x0, x1, add, p1, p2, never)
        vertical_end(state, mins, y1 - y0, x0, x1)
        return 0

    @njit(**INLINE)
    def path_step(before, least, cost, after, p1, p2, never):
        """after[1 + k] = L(p, k) from before (L(p - r) with its sentinels) and its
        minimum ``least``; returns min_k L(p, k).  before, after: (D + 2,); cost: (D,);
        never: the accumulator's largest value."""
        ndisp = cost.shape[0]
        jump = acc(least + p2)
        best = never
        for k in range(ndisp):
            v = min(min(before[k + 1], jump), acc(min(before[k], before[k + 2]) + p1))
            value = acc(cost[k] + v - least)
            after[k + 1] = value
            best = min(best, value)
        return best

    @njit(**INLINE)
    def path_step_into(before, least, cost, after, sums, add, p1, p2, never):
        """path_step, the values also added into sums, (D,) (add 1), or written there
        (add 0), in the same pass (add 2: path_step)."""
        if add == 2:
            return path_step(before, least, cost, after, p1, p2, never)
        ndisp = cost.shape[0]
        jump = acc(least + p2)
        best = never
        if add == 0:  # sums not read: a first path's slab rows come from memory
            for k in range(ndisp):
                v = min(min(before[k + 1], jump), acc(min(before[k], before[k + 2]) + p1))
                value = acc(cost[k] + v - least)
                after[k + 1] = value
                best = min(best, value)
                sums[k] = value
            return best
        for k in range(ndisp):
            v = min(min(before[k + 1], jump), acc(min(before[k], before[k + 2]) + p1))
            value = acc(cost[k] + v - least)
            after[k + 1] = value
            best = min(best, value)
            sums[k] = acc(sums[k] + value)
        return best

    @njit(**INLINE)
    def left_step(before, after, cost, totals, k, jump, least, p1):
        """Slot k of a step of the path from the left (path_step's recurrence, jump =
        least + P2) into after, its value added into totals; returns (value, total)."""
        v = min(min(before[k + 1], jump), acc(min(before[k], before[k + 2]) + p1))
        value = acc(cost[k] + v - least)
        after[k + 1] = value
        total = acc(totals[k] + value)
        totals[k] = total
        return value, total

    @njit(**INLINE)
    def key_of(total, k):
        """A 16-bit total and its slot as one key, total << 16 | k: the least key is the
        least total at its smallest k."""
        return np.uint32((np.uint32(total) << np.uint32(16)) | np.uint32(k))

    @njit(**SERIAL)
    def fresh(state):
        """A path's state before its first pixel: zeros between the sentinels."""
        for k in range(1, state.shape[0] - 1):
            state[k] = 0

    @njit(**SERIAL)
    def meet(state, shift, moved):
        """A banded variant's path state of the pixel before, (K + 2,), made to meet
        this pixel's slots, in place (path_step's ``before`` then): [1 + k], -1 <= k <=
        K, takes its slot k + shift's value, the same d, or the sentinel where that is
        none of its slots (so [0] and [K + 1] may hold values: see restore).  moved, (K +
        2,), scratch: through it each loop reads one array and writes another, which
        LLVM vectorises (in place, overlapping views ran one value at a time).  The
        loops index views from 0: an index Numba can't prove non-negative is tested for
        wraparound at every access."""
        size = state.shape[0]
        big = state[0]  # between steps every state's ends hold the sentinel
        for i in range(size):
            moved[i] = state[i]
        # [i] takes [i + shift] where that is a slot, 1 <= i + shift <= K: lo <= i < hi
        lo = min(max(1 - shift, 0), size)
        hi = max(min(size - 1 - shift, size), lo)
        for i in range(lo):
            state[i] = big
        source, target = moved[lo + shift:], state[lo:]
        for i in range(hi - lo):
            target[i] = source[i]
        rest = state[hi:]
        for i in range(size - hi):
            rest[i] = big

    @njit(**INLINE)
    def restore(state, big):
        """A met state's ends back to the sentinel, once its step has read it: the
        buffer takes a later pixel's values between them."""
        state[0] = big
        state[state.shape[0] - 1] = big

    @njit(**SERIAL)
    def meet_row(states, here, there, offset, x0, x1, moved):
        """meet, for pixels x0 <= x < x1 of a row, each the state states[x + offset] of
        the row before's that its path reads, where their starts differ (here[x], the
        pixel's; there[x + offset], that pixel's).  In a pass of its own before the
        steps: with a call in the steps' loop, a KITTI pair's costs step took 1-1.5 ms
        more at one thread (the vector registers are saved around a call)."""
        for x in range(x0, x1):
            if here[x] != there[x + offset]:
                meet(states[x + offset], here[x] - there[x + offset], moved)

    @njit(**SERIAL)
    def restore_row(states, here, there, offset, x0, x1, big):
        """restore, after the steps, every state meet_row met (the same arguments)."""
        for x in range(x0, x1):
            if here[x] != there[x + offset]:
                restore(states[x + offset], big)

    @njit(**INLINE)
    def path_start(cost, after, never):
        """A path's first pixel: after[1 + k] = C(p, k); returns its minimum."""
        best = never
        for k in range(cost.shape[0]):
            after[k + 1] = cost[k]
            best = min(best, cost[k])
        return best

    @njit(**INLINE)
    def add_into(sums, after, add):
        """sums[k] (+)= after[1 + k]: the first path of a band's pass assigns."""
        if add:
            for k in range(sums.shape[0]):
                sums[k] = sums[k] + after[k + 1]
        else:
            for k in range(sums.shape[0]):
                sums[k] = after[k + 1]

    @njit(**SERIAL)
    def copy_state(state, mins, x):
        """Column x's state from buffer 1 into buffer 0 (element by element: Numba
        copies a slice assignment's source first, which allocates)."""
        a, b = state[0, x], state[1, x]
        for k in range(a.shape[0]):
            a[k] = b[k]
        mins[0, x] = mins[1, x]

    @njit(**SERIAL)
    def vertical_row(costs, sums, state, mins, starts, moved, i, y, direction, band_y0, x0,
                     x1, add, p1, p2, never):
        """Image row y's step of a vertical path down (direction 1) or up (-1), the i-th
        of its run (buffer i % 2 holds the row before, 1 - i % 2 takes this one), columns
        x0 <= x < x1; adds into sums (add 0: assigns, 2: leaves them, for the state
        alone).  Numba compiles a function again for each set of constants it is called
        with, so the costs step passes int64s, as vertical does: one compile for both."""
        down = direction > 0
        before, after = i % 2, 1 - i % 2
        row = costs[y - band_y0]
        band_sums = sums[y - band_y0] if add < 2 else sums[0]
        y_before = y - 1 if down else y + 1  # none: a fresh state, no shift
        shifts = banded and 0 <= y_before < starts.shape[0] and x0 < x1
        # The sentinel, from a state of this call's own columns (another thread's may be
        # met meanwhile).
        big = state[before, x0, 0] if shifts else never
        if shifts:
            meet_row(state[before], starts[y], starts[y_before], 0, x0, x1, moved)
        for x in range(x0, x1):
            mins[after, x] = path_step_into(state[before, x], mins[before, x], row[x],
                                            state[after, x], band_sums[x], add, p1, p2,
                                            never)
        if shifts:
            restore_row(state[before], starts[y], starts[y_before], 0, x0, x1, big)

    @njit(**SERIAL)
    def vertical_end(state, mins, rows, x0, x1):
        """After a run of ``rows`` vertical steps: the last row's state back into buffer
        0 (where an odd run left it in buffer 1)."""
        if rows % 2:
            for x in range(x0, x1):
                copy_state(state, mins, x)

    @njit(**SERIAL)
    def vertical(costs, sums, state, mins, starts, moved, sc, stop):
        """The vertical path down (direction 1) or up (-1) over the band's rows y0 <=
        y < y1 (image rows; the slabs start at band_y0), columns x0 <= x < x1, from the
        state the band's neighbour left (fresh where y0 is the image's first row going
        down, or the band ends at the image's last going up: see kernels/sgm.py); adds
        into sums (add 0: assigns, 2: leaves them, for the state alone)."""
        p1, p2, never = acc(sc[SC.p1]), acc(sc[SC.p2]), acc(sc[SC.never])
        y0, y1, band_y0 = sc[SC.y0], sc[SC.y1], sc[SC.band_y0]
        x0, x1, add = sc[SC.x0], sc[SC.x1], sc[SC.add]
        down = sc[SC.direction] > 0
        rows = y1 - y0
        for i in range(rows):
            if stop_requested(stop):
                return 0
            y = y0 + i if down else y1 - 1 - i
            vertical_row(costs, sums, state, mins, starts, moved, i, y, sc[SC.direction],
                         band_y0, x0, x1, add, p1, p2, never)
        vertical_end(state, mins, rows, x0, x1)
        return 0

    @njit(**SERIAL)
    def diagonal(costs, sums, state, mins, other, other_mins, starts, moved, sc, stop):
        """The two diagonal paths going down (direction 1: from up-left and up-right)
        or up (-1: from down-left and down-right) over the band's rows, every column:
        state for the path coming from the left (x - 1), other for the one from the
        right (x + 1); a path entering at the image's side starts there."""
        p1, p2, never = acc(sc[SC.p1]), acc(sc[SC.p2]), acc(sc[SC.never])
        y0, y1, band_y0, add = sc[SC.y0], sc[SC.y1], sc[SC.band_y0], sc[SC.add]
        down = sc[SC.direction] > 0
        width = costs.shape[1]
        rows = y1 - y0
        for i in range(rows):
            if stop_requested(stop):
                return 0
            y = y0 + i if down else y1 - 1 - i
            before, after = i % 2, 1 - i % 2
            row = costs[y - band_y0]
            y_before = y - 1 if down else y + 1
            shifts = banded and 0 <= y_before < starts.shape[0]
            big = state[before, 0, 0]
            if shifts:
                # Each state is read by one pixel: x - 1's by x on the path from the
                # left, x + 1's by x on the one from the right.
                meet_row(state[before], starts[y], starts[y_before], -1, 1, width, moved)
                meet_row(other[before], starts[y], starts[y_before], 1, 0, width - 1, moved)
            # The states' rows as slices of themselves: so written, LLVM compiles this
            # loop to a third of the time it takes over the rows as they are (a KITTI
            # pair's half-size diagonal step: 4.1 ms against 11.7; the vertical step's
            # loop goes the other way).
            size = costs.shape[2] + 2
            for x in range(width):
                here = state[after, x][0:size]
                there = other[after, x][0:size]
                if x == 0:
                    mins[after, x] = path_start(row[x], here, never)
                else:
                    mins[after, x] = path_step(state[before, x - 1][0:size],
                                               mins[before, x - 1], row[x], here, p1, p2,
                                               never)
                if x == width - 1:
                    other_mins[after, x] = path_start(row[x], there, never)
                else:
                    other_mins[after, x] = path_step(other[before, x + 1][0:size],
                                                     other_mins[before, x + 1], row[x],
                                                     there, p1, p2, never)
                if add < 2:
                    s = sums[y - band_y0, x]
                    add_into(s, here, add)
                    add_into(s, there, 1)
            if shifts:
                restore_row(state[before], starts[y], starts[y_before], -1, 1, width, big)
                restore_row(other[before], starts[y], starts[y_before], 1, 0, width - 1,
                            big)
        if rows % 2:
            for x in range(width):
                copy_state(state, mins, x)
                copy_state(other, other_mins, x)
        return 0

    @njit(**SERIAL)
    def select_rows(costs, sums, line, moved, right_best_rev, right_rev_d, disp, min_cost,
                    second, prev, nxt, right_disp, lr_valid, starts, state, mins, sc,
                    stop):
        """For rows y0 <= y < y1: the path from the right added into the row's sums,
        then the path from the left made on the way to each pixel's winner, second
        best, neighbours, and right map, and the row's left-right check (as the fast
        engine's select_row).  fused 1: the rows go up from y1 - 1, each first taking
        its step of the vertical path up (state, mins) into its sums, while they are in
        the caches; fused 2: the rows go down from y0, each with its step of the path
        down.  Fused, y0..y1 covers every column, and the path's state enters at y1 - 1
        (up) or y0 (down)."""
        p1, p2, never = acc(sc[SC.p1]), acc(sc[SC.p2]), acc(sc[SC.never])
        y0, y1, band_y0 = sc[SC.y0], sc[SC.y1], sc[SC.band_y0]
        # extras 1: the neighbours' totals; 2: and the second best (kernels/sgm.py)
        dmin, extras, seconds = sc[SC.dmin], sc[SC.extras] != 0, sc[SC.extras] == 2
        keep_right, lr_limit = sc[SC.keep_right], sc[SC.lr_limit]
        track_right = keep_right != 0 or lr_limit >= 0
        width, ndisp = costs.shape[1], costs.shape[2]
        real = sc[SC.slots]  # the candidates' slots: a whole-range pass pads past them
        big = line[0, 0]  # the sentinel, at both ends of the lines' states
        shift = -dmin if negative else 0
        keyed = sc[SC.keyed] != 0
        fused = sc[SC.fused]
        going_up = fused == 1
        for i_row in range(y1 - y0):
            if stop_requested(stop):
                return 0
            y = y1 - 1 - i_row if going_up else y0 + i_row
            # Constants (its own compile, the path's adding step alone in it): with
            # int64s here the winners step took 7% longer.
            if going_up:
                vertical_row(costs, sums, state, mins, starts, moved, i_row, y, -1, band_y0,
                             0, width, 1, p1, p2, never)
            elif fused:
                vertical_row(costs, sums, state, mins, starts, moved, i_row, y, 1, band_y0,
                             0, width, 1, p1, p2, never)
            row, total = costs[y - band_y0], sums[y - band_y0]
            # A path starts from a state of zeros with least 0: its first values are
            # then the costs themselves (min(0, P1, P2) = 0), with no branch.
            fresh(line[1])
            least = acc(0)
            # Two pixels a turn, the states' roles fixed in each (line[j] takes this
            # pixel's, line[1 - j] holds the one before) rather than line[i % 2]: the
            # compiled loop then sees the same two state rows every turn, and this step
            # took 7% less at 640 x 480, d 64 (the path from the left's longer loop,
            # paired so, took a third more).
            for pair in range(0, width, 2):
                for j in range(2):
                    i = pair + j
                    if i == width:
                        break
                    x = width - 1 - i
                    b, a = line[1 - j], line[j]
                    shift_here = starts[y, x] - starts[y, x + 1] if banded and i > 0 else 0
                    if shift_here != 0:
                        meet(b, shift_here, moved)
                    if x >= AHEAD:  # this path walks memory downwards: see prefetch
                        ask_to_read(row, total, x - AHEAD)
                    least = path_step_into(b, least, row[x], a, total[x], 1, p1, p2, never)
                    if shift_here != 0:
                        restore(b, big)
            if track_right:
                right_best_rev[:] = never
                right_rev_d[:] = -1
            out_disp, out_cost = disp[y], min_cost[y]
            fresh(line[1])
            least = acc(0)
            # The next row's costs and sums come from memory (fused, its step of the
            # vertical path reads them first): asked for here, where the work waits on
            # them less.
            next_y = y - 1 if going_up else y + 1
            ask_next = y0 <= next_y < y1
            next_costs = costs[next_y - band_y0 if ask_next else 0]
            next_sums = sums[next_y - band_y0 if ask_next else 0]
            for x in range(width):
                before, after = (x + 1) % 2, x % 2
                t = total[x]
                if ask_next:
                    ask_to_read(next_costs, next_sums, x)
                a, b = line[after], line[before]
                start = 0
                shift_here = 0
                if banded:
                    start = starts[y, x]
                    shift_here = start - starts[y, x - 1] if x > 0 else 0
                    if shift_here != 0:
                        meet(b, shift_here, moved)
                c = row[x]
                first_d = dmin + start
                n = max(min(real, x - first_d + 1), 0)
                lo = min(max(x - first_d - (width - 1), 0), n) if negative else 0
                # The path from the left, its values added into the totals, and the
                # least total among the candidates at its smallest k, in one pass.
                jump = acc(least + p2)
                next_least = never
                if may_key and keyed:
                    key = np.uint32(0xFFFFFFFF)
                    if lo == 0 and n == ndisp:
                        # Every slot a candidate (all but the pixels near the image's
                        # sides): the minimum without the test per k (KITTI at two
                        # threads: a match took 1-3 ms less, alternating runs).
                        for k in range(ndisp):
                            value, total_k = left_step(b, a, c, t, k, jump, least, p1)
                            next_least = min(next_least, value)
                            key = min(key, key_of(total_k, k))
                    else:
                        for k in range(ndisp):
                            value, total_k = left_step(b, a, c, t, k, jump, least, p1)
                            next_least = min(next_least, value)
                            key = min(key, key_of(total_k, k) if lo <= k < n else
                                      np.uint32(0xFFFFFFFF))
                    best = acc(key >> np.uint32(16))
                    first = np.int16(key & np.uint32(0xFFFF))
                else:
                    best = never
                    for k in range(ndisp):
                        value, total_k = left_step(b, a, c, t, k, jump, least, p1)
                        next_least = min(next_least, value)
                        best = min(best, total_k if lo <= k < n else never)
                    first = np.int16(n)
                    none = np.int16(n)
                    for k in range(lo, n):
                        first = min(first, np.int16(k) if t[k] == best else none)
                least = next_least
                if shift_here != 0:
                    restore(b, big)
                if n <= lo:
                    out_disp[x] = invalid
                    out_cost[x] = -1
                    if extras:
                        prev[y, x], nxt[y, x] = -1, -1
                    if seconds:
                        second[y, x] = -1
                    continue
                out_disp[x] = first_d + first
                out_cost[x] = best
                if track_right:  # right_rev_d holds d - dmin
                    base = width - 1 - x + first_d + shift
                    best_r = right_best_rev[base:]
                    d_r = right_rev_d[base:]
                    for k in range(lo, n):
                        v = t[k]
                        kept = best_r[k]
                        d_r[k] = keep_or_take(d_r[k], k + start, v < kept)
                        best_r[k] = min(v, kept)
                if seconds:
                    # The least total 2 or more from first: one plain minimum with the
                    # three around first set aside, then put back (a test per k, or two
                    # loops on either side, stayed scalar: a third of the rows' time).
                    a0, hi = max(int(first) - 1, lo), min(int(first) + 2, n)
                    mid = min(a0 + 1, hi - 1)
                    kept0, kept1, kept2 = t[a0], t[mid], t[hi - 1]
                    for k in range(a0, hi):
                        t[k] = never
                    other = never
                    for k in range(lo, n):
                        other = min(other, t[k])
                    t[hi - 1] = kept2  # in reverse: where indices coincide, values agree
                    t[mid] = kept1
                    t[a0] = kept0
                    second[y, x] = -1 if other == never else np.int64(other)
                if extras:
                    prev[y, x] = -1 if first == lo else np.int64(t[first - 1])
                    nxt[y, x] = -1 if first + 1 >= n else np.int64(t[first + 1])
            if track_right and keep_right:
                for xr in range(width):
                    k = right_rev_d[width - 1 - xr + shift]
                    right_disp[y, xr] = invalid if k < 0 else dmin + k
            if lr_limit >= 0:
                for x in range(width):
                    d = out_disp[x]
                    back = invalid
                    if d != invalid:
                        k = right_rev_d[width - 1 - x + d + shift]
                        back = invalid if k < 0 else dmin + k
                    lr_valid[y, x] = lr_agrees(d, back, lr_limit, invalid)
        if fused:
            vertical_end(state, mins, y1 - y0, 0, width)
        return 0

    @njit(**SERIAL)
    def worker(left_p, right_rev, costs, sums, col_sums, row_sums, ring, row_costs, spans,
               state, mins, other, other_mins, line, moved, right_best, right_d, disp,
               min_cost, second, prev, nxt, right_disp, lr_valid, starts, stop, sc):
        step = sc[SC.step]
        if step == COSTS:
            return cost_rows(left_p, right_rev, costs, col_sums, row_sums, ring, row_costs,
                             spans, starts, sums, state, mins, moved, sc, stop)
        if step == VERTICAL:
            return vertical(costs, sums, state, mins, starts, moved, sc, stop)
        if step == DIAGONAL:
            return diagonal(costs, sums, state, mins, other, other_mins, starts, moved, sc,
                            stop)
        return select_rows(costs, sums, line, moved, right_best, right_d, disp, min_cost,
                           second, prev, nxt, right_disp, lr_valid, starts, state, mins, sc,
                           stop)

    return worker

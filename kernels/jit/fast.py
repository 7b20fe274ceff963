"""The fast engine's workers: running sums, O(1) work per (pixel, disparity) whatever the
window, after OpenCV's stereobm.cpp (see kernels/fast.py for the layout and the entry):

  column sums   V[j, k] = sum over the w window rows of psi(L[., j], R[., j - d]),
                d = dmin + k, for padded column j; moved down one row by adding the
                entering row and subtracting the leaving one (the "_sub" row, or, for
                Hamming costs, its costs kept in a ring of the window's rows).
  row sums      H[k] = sum over b < w of V[x + b, k]: the cost C(y, x, d), moved right
                one pixel by adding V[x + w - 1] and subtracting V[x - 1].

A variant fixes at compile time the cost, the pixel and accumulator types, and which of
the optional results a pass makes (CSW's B-map, the right image's best matches, the
second-best and neighbour costs), so that a pass carries no code and pays no time for
the others.  From the right image's best matches a row stores its map, its left-right
check, or both, as the scalars keep_right and lr_limit say.

Layers (the entry and the parallel driver over stripes are in kernels/fast.py):
  stripe        per-stripe worker: column sums down the rows, one row at a time
  select_row    per-row worker: slide the row sums, pick each pixel's disparity
  columns_*     move the column sums down one row
"""

import numpy as np
from numba import njit

from ..contract import INVALID, NEG_INVALID, RULE_UNIQUE
from ..signature import Signature, Spec, arg, scalar_index
from .common import blocked, ctpop, dtype_of, is_distinct, keep_or_take, lr_agrees, stop_requested
from .options import SERIAL

# The scalars every stripe takes (the entry's record; see kernels/signature.py).
SCALARS = ("window", "dmin", "dmax", "tau", "rule", "csw_margin", "slack", "y0", "y1",
           "never", "keep_right", "lr_limit", "keyed_range")
SC = scalar_index(SCALARS)


def spec(cost, pixels, accumulator, csw, right_map, extras, negative=False):
    """The stripe worker of a variant.  cost: "sad", "ssd" or "shd" (census codes are
    compared with shd); pixels, accumulator: type names ("u8", "u16", "i32", ...);
    negative: the range starts below 0 (see _make)."""
    pix, acc = dtype_of(pixels), dtype_of(accumulator)
    i16, i32, i64, u8 = (np.dtype(t) for t in (np.int16, np.int32, np.int64, np.uint8))
    arrays = (arg("left_p", pix, 2), arg("right_rev", pix, 2),  # (H + w - 1, Wp)
              arg("col_sums", acc, 2), arg("row_sums", acc, 1),  # (Wp, D), (D,) scratch
              arg("claims", i32, 1), arg("right_best", acc, 1),  # (W + s,) scratch
              arg("right_d", i16, 1),
              arg("disp", i32, 2), arg("min_cost", i64, 2),  # (H, W) out
              arg("second", i64, 2), arg("prev", i64, 2), arg("next", i64, 2),  # extras
              arg("right_disp", i32, 2), arg("lr_valid", u8, 2),  # (H, W) or 1-row dummies
              arg("evaluated", i64, 1), arg("stop", u8, 1),  # (H,), (1,)
              arg("ring", u8, 3))  # (w, Wp, D) scratch for "shd", else (1, 1, 1)
    return Spec(_make(cost, acc.type, bool(csw), bool(right_map), bool(extras),
                      bool(negative)), Signature(arrays, SCALARS))


def _make(cost, acc, csw, right_map, extras, negative):
    """The workers of one variant; ``cost``, the accumulator type ``acc``, ``csw``,
    ``right_map``, ``extras`` and ``negative`` are compile-time constants in them, so the
    branches they decide are folded away.

    negative: dmin < 0.  A candidate's right pixel x - d may then lie beyond the image's
    right edge: the right image is padded s = -dmin columns more on that side (so the
    column sums stay defined) and such candidates, k < lo(x), are not candidates; the
    right-pixel arrays (B-map, right map) hold s entries more at the front, and invalid
    pixels are NEG_INVALID, since -1 is a disparity here.
    """
    keyed = acc == np.uint16  # sum and index pack into one 32-bit key
    # Hamming costs keep the window's rows' costs (each at most 64: a byte) in a ring of
    # w rows, so that a row leaving the column sums subtracts what it added rather than
    # counting its bits again, as stereobm.cpp keeps its rows' SADs: the bit count is
    # most of a census match's column work (AVX2 has no vector popcount).  With 32-bit
    # codes the column update took 10.1 ms instead of 15.4 at 640x480, d 0..63, and
    # 71 instead of 111 at 1920 wide, d 0..255, where the ring is 4.4 MB.  SAD's
    # difference costs less than the byte stored and loaded: a ring took 18 ms against
    # 6.8 at 640x480, d 0..63.
    ringed = cost == "shd"
    invalid = NEG_INVALID if negative else INVALID

    @njit(**SERIAL)
    def psi(a, b):
        """psi(a, b) written so that LLVM keeps it in the pixels' narrow lanes: |a - b| as
        max - min never leaves the unsigned range, where np.int64(a) - b would widen
        every SIMD lane to 64 bits."""
        if cost == "sad":
            return max(a, b) - min(a, b)
        if cost == "ssd":
            diff = np.uint32(max(a, b) - min(a, b))  # its square fits 32 bits unsigned
            return diff * diff
        return ctpop(a ^ b)

    @njit(**SERIAL)
    def columns_add(left, right_rev, col_sums, dmin, kept):
        """col_sums[j, k] += psi(left[j], right[j - d]) for d = dmin + k <= j: add one
        row.  left, right_rev: (Wp,) padded rows, the right one reversed, so
        right[j - d] = right_rev[Wp - 1 - j + d].  col_sums: (Wp, D).  kept: uint8
        (Wp, D), where a ringed variant keeps the row's costs (else unused)."""
        wp, ndisp = col_sums.shape
        wr = right_rev.shape[0]  # wp, or wp + s for a negative range
        for j in range(max(dmin, 0), wp):
            sums = col_sums[j]
            lv = left[j]
            r = right_rev[wr - 1 - j + dmin:]
            if ringed:
                costs = kept[j]
                for k in range(min(ndisp, j - dmin + 1)):
                    c = np.uint8(psi(lv, r[k]))
                    sums[k] = sums[k] + c
                    costs[k] = c
            else:
                for k in range(min(ndisp, j - dmin + 1)):
                    sums[k] = sums[k] + psi(lv, r[k])

    @njit(**SERIAL)
    def columns_move(left, right_rev, left_sub, right_sub_rev, col_sums, dmin, kept):
        """As columns_add, adding the entering rows and subtracting the leaving (_sub)
        ones in one pass.  Unsigned sums may wrap on the way: the arithmetic is exact
        modulo their width, and every true value fits.  A ringed variant reads the
        leaving row's costs from kept, uint8 (Wp, D), and writes the entering row's over
        them (left_sub and right_sub_rev are then unused)."""
        wp, ndisp = col_sums.shape
        wr = right_rev.shape[0]
        for j in range(max(dmin, 0), wp):
            sums = col_sums[j]
            lv, lv_sub = left[j], left_sub[j]
            base = wr - 1 - j + dmin
            r, r_sub = right_rev[base:], right_sub_rev[base:]
            if ringed:
                costs = kept[j]
                for k in range(min(ndisp, j - dmin + 1)):
                    c = np.uint8(psi(lv, r[k]))
                    sums[k] = sums[k] + c - costs[k]
                    costs[k] = c
            else:
                for k in range(min(ndisp, j - dmin + 1)):
                    sums[k] = sums[k] + psi(lv, r[k]) - psi(lv_sub, r_sub[k])

    @njit(**SERIAL)
    def select_row(col_sums, row_sums, never, sc, claims_rev, right_best_rev, right_rev_d,
                   disp_row, cost_row, second_row, prev_row, next_row, right_row, lr_row):
        """Slide the row sums along one row and pick each pixel's disparity in the
        contract's order: x ascending, and the smallest d among the minimum costs.

        col_sums: (Wp, D).  row_sums: (D,) scratch, of the accumulator type.
        never: accumulator scalar above every real cost (its type's maximum), so that
            blocked candidates drop out of the min without a branch and the loops stay
            SIMD.  sc: int64 (len(SCALARS),) the stripe's scalars.
        claims_rev: int32 (W,) the B-map reversed: claims[x - d] = claims_rev[W-1-x+d],
            the column of the pixel that last claimed each right pixel or -1, so the
            candidates of one pixel read it forward; reset here.
        right_best_rev: (W,) accumulator type, right_rev_d: int16 (W,): the least cost
            seen for each right pixel and its d - dmin, reversed like claims_rev.
        disp_row: int32 (W,) out.  cost_row: int64 (W,) out.  second_row, prev_row,
            next_row: int64 (W,) out with extras.  With right_map: right_row, int32 (W,),
            the right image's map, out where sc[keep_right]; lr_row, uint8 (W,), the
            left-right check at sc[lr_limit], out where that is >= 0 (see the row's end).
            Returns the number of candidates evaluated (those not blocked).

        The loops are written out here rather than in helpers: Numba's IR inlining of a
        helper kept LLVM from fusing them, and cost about 1.7x in time.
        """
        width = disp_row.shape[0]
        ndisp = col_sums.shape[1]
        w, dmin, tau, rule = sc[SC.window], sc[SC.dmin], sc[SC.tau], sc[SC.rule]
        csw_margin, slack = sc[SC.csw_margin], sc[SC.slack]
        keep_right, lr_limit = sc[SC.keep_right], sc[SC.lr_limit]
        # Packed keys pick the minimum up to this range (kernels/fast.py, KEYED_RANGE).
        packed = keyed and ndisp <= sc[SC.keyed_range]
        shift = -dmin if negative else 0  # the right-pixel arrays' extra front entries
        if csw:
            claims_rev[:] = -1
        if right_map:
            right_best_rev[:] = never
            right_rev_d[:] = INVALID
        # The window of pixel 0 less its last column, which the first slide adds; and
        # column 0 once more, which the first slide subtracts as its "leaving" column
        # (the sums are exact modulo their width, so adding and subtracting it is too).
        row_sums[:] = 0
        for b in range(w - 1):
            sums = col_sums[b]
            for k in range(ndisp):
                row_sums[k] = row_sums[k] + sums[k]
        sums = col_sums[0]
        for k in range(ndisp):
            row_sums[k] = row_sums[k] + sums[k]
        evaluated = 0
        for x in range(width):
            n = max(min(ndisp, x - dmin + 1), 0)  # candidates d = dmin + k <= x
            # ... and, for a negative range, x - d <= width - 1: k >= lo.
            lo = min(max(x - dmin - (width - 1), 0), n) if negative else 0
            base = width - 1 - x + dmin + shift  # claims[k]: right pixel x - d, reversed
            add = col_sums[x + w - 1]  # the column entering the window
            sub = col_sums[max(x - 1, 0)]  # the column leaving it (see above for x = 0)
            # Slide the first n sums and take their minimum in the same pass (blocked
            # candidates count as `never`); then the first index holding the minimum, as
            # a branch-free min over indices, so that it vectorises like the min itself.
            best = never
            taken = 0
            first = np.int16(n)  # narrow lanes for the index min, like the sums' (D <= 2**15)
            none = np.int16(n)
            for k in range(lo):  # right pixels beyond the image: slid, not candidates
                row_sums[k] = row_sums[k] + add[k] - sub[k]
            if csw:
                claims = claims_rev[base:]
                for k in range(lo, n):
                    row_sums[k] = row_sums[k] + add[k] - sub[k]
                    skip = blocked(claims[k], x, slack)
                    taken += skip
                    best = min(best, never if skip else row_sums[k])
                for k in range(lo, n):
                    hit = row_sums[k] == best and not blocked(claims[k], x, slack)
                    first = min(first, np.int16(k) if hit else none)
                if right_map:
                    # The right image's best matches over the candidates not blocked: for
                    # right pixel x - d, a strict < over ascending x keeps the smallest d.
                    best_r = right_best_rev[base:]
                    d_r = right_rev_d[base:]
                    for k in range(lo, n):
                        c = never if blocked(claims[k], x, slack) else row_sums[k]
                        b = best_r[k]
                        d_r[k] = keep_or_take(d_r[k], k, c < b)
                        best_r[k] = min(c, b)
            else:
                # The right image's best match per right pixel, from the same costs: for
                # right pixel x - d, a strict < over ascending x keeps the smallest d
                # among equals (kept as d - dmin in int16, the sums' lanes).  It goes
                # with the pass that finds the first index of the minimum (fused into
                # the slide, LLVM no longer vectorised it).  Every lane is stored
                # (keep_or_take): a store only where the cost improves needs masked
                # 16-bit stores, which AVX2 lacks, and LLVM left that loop scalar.
                best_r = right_best_rev[base:]
                d_r = right_rev_d[base:]
                if packed:
                    # One pass: the least of (sum << 16 | k) is the least sum at its
                    # smallest k.  Fewer loops per pixel than two passes, in lanes twice
                    # as wide: which wins depends on range and CPU (kernels/fast.py,
                    # KEYED_RANGE); 16-bit sums only.
                    # The outer uint32 keeps the keys in 32-bit lanes: Numba types the
                    # shift and the | as uint64, and without it the min ran in 64-bit ones.
                    key = np.uint32(0xFFFFFFFF)
                    for k in range(lo, n):
                        row_sums[k] = row_sums[k] + add[k] - sub[k]
                        key = min(key, np.uint32((np.uint32(row_sums[k]) << np.uint32(16)) |
                                                 np.uint32(k)))
                    best = acc(key >> np.uint32(16))
                    first = np.int16(key & np.uint32(0xFFFF)) if n > lo else none
                else:
                    for k in range(lo, n):
                        row_sums[k] = row_sums[k] + add[k] - sub[k]
                        best = min(best, row_sums[k])
                    if right_map:
                        for k in range(lo, n):
                            v = row_sums[k]
                            first = min(first, np.int16(k) if v == best else none)
                            b = best_r[k]
                            d_r[k] = keep_or_take(d_r[k], k, v < b)
                            best_r[k] = min(v, b)
                    else:
                        for k in range(lo, n):
                            first = min(first, np.int16(k) if row_sums[k] == best
                                        else none)
                if packed and right_map:
                    # The right map's pass of its own, outside the branch: inside it,
                    # LLVM left the other way's fused pass scalar (2.7x slower).
                    for k in range(lo, n):
                        v = row_sums[k]
                        b = best_r[k]
                        d_r[k] = keep_or_take(d_r[k], k, v < b)
                        best_r[k] = min(v, b)
            for k in range(n, ndisp):  # not candidates yet (d > x), needed further right
                # An unsigned index: Numba wraps a signed one that may be negative (it
                # can't tell that n >= 0), which kept this loop scalar.  It runs on the
                # row's first ndisp pixels only, yet took a tenth of a SAD match.
                i = np.uint64(k)
                row_sums[i] = row_sums[i] + add[i] - sub[i]
            evaluated += n - lo - taken
            if taken == n - lo:  # no candidate (x < dmin), or every one blocked
                disp_row[x] = invalid
                cost_row[x] = -1
                if extras:
                    second_row[x] = -1
                    prev_row[x] = -1
                    next_row[x] = -1
                continue
            disp_row[x] = dmin + first
            cost_row[x] = best
            second = never
            if csw and (extras or (rule == RULE_UNIQUE and best <= tau)):
                # The least evaluated cost at least 2 away from first.  One pass over all
                # candidates, the three next to the best masked out, vectorises better
                # than two passes around them.
                claims = claims_rev[base:]
                for k in range(lo, n):
                    skip = blocked(claims[k], x, slack) or abs(k - first) <= 1
                    second = min(second, never if skip else row_sums[k])
            elif extras:
                # Without CSW nothing is blocked: one plain minimum over all candidates,
                # with the best's three set aside for it (and put back: later pixels
                # slide them).
                a0, hi = max(int(first) - 1, lo), min(int(first) + 2, n)
                mid = min(a0 + 1, hi - 1)
                kept0, kept1, kept2 = row_sums[a0], row_sums[mid], row_sums[hi - 1]
                for k in range(a0, hi):
                    row_sums[k] = never
                for k in range(lo, n):
                    second = min(second, row_sums[k])
                row_sums[hi - 1] = kept2  # in reverse: where indices coincide, values agree
                row_sums[mid] = kept1
                row_sums[a0] = kept0
            if extras:
                claims = claims_rev[base:]
                second_row[x] = -1 if second == never else np.int64(second)
                prev_row[x] = -1 if first == lo or (csw and blocked(claims[first - 1], x,
                                                                   slack)) \
                    else np.int64(row_sums[first - 1])
                next_row[x] = -1 if first + 1 >= n or (csw and blocked(claims[first + 1], x,
                                                                       slack)) \
                    else np.int64(row_sums[first + 1])
            if not csw or best > tau:
                continue
            if rule == RULE_UNIQUE and (second == never or not is_distinct(
                    np.int64(best), np.int64(second), csw_margin)):
                continue
            claims_rev[base + first] = x
        if right_map and keep_right:
            for xr in range(width):
                k = right_rev_d[width - 1 - xr + shift]
                right_row[xr] = invalid if k < 0 else dmin + k
        if right_map and lr_limit >= 0:
            # The left-right check while the row's two maps are in cache, as the filter
            # lr_consistent makes it on whole maps (the right pixel x - d's own match is
            # dmin + k, k from the reversed right_rev_d).
            for x in range(width):
                d = disp_row[x]
                back = invalid
                if d != invalid:
                    k = right_rev_d[width - 1 - x + d + shift]
                    back = invalid if k < 0 else dmin + k
                lr_row[x] = lr_agrees(d, back, lr_limit, invalid)
        return evaluated

    @njit(**SERIAL)
    def stripe(left_p, right_rev, col_sums, row_sums, claims, right_best, right_d, disp,
               min_cost, second, prev, nxt, right_disp, lr_valid, evaluated, stop, ring, sc):
        """Match image rows sc[y0] <= y < sc[y1] into disp, min_cost (and the optional
        maps) and evaluated (per row); return early, before a row, once stop[0] is set.

        left_p: (H + w - 1, Wp) padded left.  right_rev: the padded right, columns
        reversed.  col_sums: (Wp, D), row_sums: (D,) accumulators; claims: int32 (W,)
        reversed B-map; right_best, right_d: (W,) reversed right-map scratch; ring:
        uint8 (w, Wp, D), a ringed variant's costs of the window's rows, padded row p in
        ring[p % w] (the entering and the leaving row share a slot): all scratch of this
        stripe.  Maps not made are 1-row dummies, never written.
        """
        w, dmin, y0, y1 = sc[SC.window], sc[SC.dmin], sc[SC.y0], sc[SC.y1]
        never = acc(sc[SC.never])
        keep_right, lr_limit = sc[SC.keep_right], sc[SC.lr_limit]
        col_sums[:] = 0
        for a in range(w):  # the window of padded rows y0 .. y0 + w - 1, each added once
            columns_add(left_p[y0 + a], right_rev[y0 + a], col_sums, dmin,
                        ring[(y0 + a) % w if ringed else 0])
        for y in range(y0, y1):
            if stop_requested(stop):
                return 0
            if y > y0:
                # Move down: row y + w - 1 enters the window, row y - 1 leaves (the _sub).
                columns_move(left_p[y + w - 1], right_rev[y + w - 1], left_p[y - 1],
                             right_rev[y - 1], col_sums, dmin,
                             ring[(y - 1) % w if ringed else 0])
            e = y if extras else 0
            r = y if right_map and keep_right else 0
            v = y if right_map and lr_limit >= 0 else 0
            evaluated[y] = select_row(col_sums, row_sums, never, sc, claims, right_best,
                                      right_d, disp[y], min_cost[y], second[e], prev[e],
                                      nxt[e], right_disp[r], lr_valid[v])
        return 0

    return stripe

"""The window engine's workers: the paper's method, a full w x w cost sum for every
candidate, so the candidates CSW skips are real work saved (see kernels/window.py).

Layers (the entry and the parallel driver over stripes of rows are in kernels/window.py):
  rows          per-stripe worker: the stripe's rows, each with its own B-map
  match_row     per-row worker: no checks, no allocation
"""

import numpy as np
from numba import njit

from ..contract import INVALID, NEG_INVALID, RULE_UNIQUE
from ..signature import Signature, Spec, arg, scalar_index
from .common import blocked, ctpop, dtype_of, is_distinct, stop_requested
from .options import SERIAL

# The scalars every stripe takes (the entry's record; see kernels/signature.py).
SCALARS = ("window", "dmin", "dmax", "tau", "rule", "csw_margin", "slack", "i0", "i1")
SC = scalar_index(SCALARS)


def spec(cost, pixels, csw, right_map, extras, negative=False):
    """The stripe worker of a variant.  cost: "sad", "ssd" or "shd"; pixels: the padded
    images' type name ("u16" for 8- and 16-bit images, the codes' type for census)."""
    pix = dtype_of(pixels)
    i32, i64, u8 = (np.dtype(t) for t in (np.int32, np.int64, np.uint8))
    arrays = (arg("left_p", pix, 2), arg("right_p", pix, 2),  # (H + w - 1, W + w - 1)
              arg("rows", i64, 1),  # (n,) the rows to match
              arg("claims", i32, 1), arg("costs", i64, 1),  # (W,), (D,) scratch
              arg("right_best", i64, 1),  # (W,) scratch
              arg("disp", i32, 2), arg("min_cost", i64, 2),  # (n, W) out
              arg("second", i64, 2), arg("prev", i64, 2), arg("next", i64, 2),  # extras
              arg("right_disp", i32, 2),  # (n, W) or 1-row dummies
              arg("evaluated", i64, 1), arg("stop", u8, 1))  # (n,), (1,)
    return Spec(_make(cost, bool(csw), bool(right_map), bool(extras), bool(negative)),
                Signature(arrays, SCALARS))


def _make(cost, csw, right_map, extras, negative):
    """The workers of one variant, with its cost and flags as compile-time constants.
    negative: dmin < 0, so that invalid pixels are NEG_INVALID (-1 is a disparity)."""
    invalid = NEG_INVALID if negative else INVALID

    @njit(**SERIAL)
    def window_cost(left_p, right_p, top, xl, xr, w):
        """C for one candidate: the w x w window with top-left (top, xl) in the padded
        left image against the one with top-left (top, xr) in the padded right image."""
        total = np.int64(0)
        for a in range(w):
            for b in range(w):
                lv, rv = left_p[top + a, xl + b], right_p[top + a, xr + b]
                if cost == "sad":
                    total += abs(np.int64(lv) - np.int64(rv))
                elif cost == "ssd":
                    diff = np.int64(lv) - np.int64(rv)
                    total += diff * diff
                else:
                    total += np.int64(ctpop(lv ^ rv))
        return total

    @njit(**SERIAL)
    def match_row(left_p, right_p, y, sc, claims, costs, right_best, disp_row, cost_row,
                  second_row, prev_row, next_row, right_row):
        """Match one row y, left to right, and return the number of candidates evaluated.

        left_p, right_p: (H + w - 1, W + w - 1), images (or census codes) edge-padded by
            h = w // 2, so the window centred on image pixel (y, x) has top-left (y, x).
        sc: the stripe's scalars (window, range, CSW rule).
        claims: int32 (W,), this row's B-map: the column of the pixel that last claimed
            each right pixel, or -1; reset here.  A claim by x' blocks pixel x if
            x - x' > slack.
        costs: int64 (D,) scratch: this pixel's evaluated costs by d - dmin (-1 = skipped).
        right_best: int64 (W,) scratch: the least cost seen for each right pixel.
        disp_row: int32 (W,) out, D(y, x) or INVALID.  cost_row: int64 (W,) out, m or -1.
        second_row, prev_row, next_row: int64 (W,) out with extras; right_row: int32 (W,)
            out with right_map (see MatchResult).
        """
        width = disp_row.shape[0]
        w, dmin, dmax, tau = sc[SC.window], sc[SC.dmin], sc[SC.dmax], sc[SC.tau]
        rule, csw_margin, slack = sc[SC.rule], sc[SC.csw_margin], sc[SC.slack]
        if csw:
            claims[:] = -1
        if right_map:
            right_best[:] = np.iinfo(np.int64).max
            right_row[:] = invalid
        evaluated = 0
        for x in range(width):
            best_d = invalid
            best = np.int64(-1)
            top = min(dmax, x)
            bottom = max(dmin, x - width + 1)  # the right pixel x - d lies in the image
            for d in range(bottom, top + 1):
                if csw and blocked(claims[x - d], x, slack):
                    costs[d - dmin] = -1
                    continue
                c = window_cost(left_p, right_p, y, x, x - d, w)
                costs[d - dmin] = c
                evaluated += 1
                # Strict < over ascending d: the smallest d wins ties.
                if best_d == invalid or c < best:
                    best = c
                    best_d = d
                if right_map and c < right_best[x - d]:
                    # Strict < over ascending x: for a right pixel, the smallest d wins.
                    right_best[x - d] = c
                    right_row[x - d] = d
            disp_row[x] = best_d
            cost_row[x] = best
            second = np.int64(-1)
            if best_d != invalid and (extras or (csw and rule == RULE_UNIQUE and
                                                 best <= tau)):
                # The least evaluated cost at least 2 away from best_d.
                for d in range(bottom, top + 1):
                    c = costs[d - dmin]
                    if c >= 0 and abs(d - best_d) >= 2 and (second < 0 or c < second):
                        second = c
            if extras:
                second_row[x] = second
                found = best_d != invalid
                prev_row[x] = costs[best_d - 1 - dmin] if found and best_d > bottom else -1
                next_row[x] = costs[best_d + 1 - dmin] if found and best_d < top else -1
            if not csw or best_d == invalid or best > tau:
                continue
            if rule == RULE_UNIQUE and not is_distinct(best, second, csw_margin):
                continue
            claims[x - best_d] = x
        return evaluated

    @njit(**SERIAL)
    def rows(left_p, right_p, row_list, claims, costs, right_best, disp, min_cost, second,
             prev, nxt, right_disp, evaluated, stop, sc):
        """Match rows row_list[i] for sc[i0] <= i < sc[i1] into the maps' rows i; rows not
        started once stop[0] is set are skipped (an interrupted run's maps are unused).
        claims, costs, right_best: this stripe's scratch.  Maps not made are 1-row
        dummies, never written."""
        for i in range(sc[SC.i0], sc[SC.i1]):
            if stop_requested(stop):
                return 0
            e = i if extras else 0
            r = i if right_map else 0
            evaluated[i] = match_row(left_p, right_p, row_list[i], sc, claims, costs,
                                     right_best, disp[i], min_cost[i], second[e], prev[e],
                                     nxt[e], right_disp[r])
        return 0

    return rows

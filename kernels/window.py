"""The window engine: the paper's method, a full w x w cost sum for every candidate.

Because every candidate costs a full window sum, the candidates that CSW skips are real
work saved; this is the engine that reproduces the paper's timings.

Layers (as in stumpy's stump.py):
  match_window      public: validate, pad, allocate, pick the thread count
  _window_driver    private, parallel: one prange iteration per row, owning its B-map
  _match_row        per-row worker: no checks, no allocation
"""

import numpy as np
from numba import njit, prange

from .census import census_transform
from .config import INLINE, PARALLEL, SERIAL
from .contract import (
    CENSUS,
    DEFAULT_CENSUS_WINDOW,
    INVALID,
    RULE_UNIQUE,
    SAD,
    SHD,
    SSD,
    MatchResult,
    candidate_count,
    run_stoppable,
    stop_requested,
    validate,
)


@njit(**INLINE)
def popcount(v):
    """Number of set bits of an unsigned value of up to 64 bits (SHD's per-pixel cost,
    on pixels or census codes)."""
    v = np.uint64(v)
    v = v - ((v >> np.uint64(1)) & np.uint64(0x5555555555555555))
    m2 = np.uint64(0x3333333333333333)
    v = (v & m2) + ((v >> np.uint64(2)) & m2)
    v = (v + (v >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (v * np.uint64(0x0101010101010101)) >> np.uint64(56)


@njit(**SERIAL)
def _window_cost(left_p, right_p, top, xl, xr, w, cost):
    """C for one candidate: the w x w window with top-left (top, xl) in the padded left
    image against the one with top-left (top, xr) in the padded right image."""
    total = np.int64(0)
    if cost == SAD:
        for a in range(w):
            for b in range(w):
                total += abs(np.int64(left_p[top + a, xl + b]) - np.int64(right_p[top + a, xr + b]))
    elif cost == SSD:
        for a in range(w):
            for b in range(w):
                diff = np.int64(left_p[top + a, xl + b]) - np.int64(right_p[top + a, xr + b])
                total += diff * diff
    else:
        for a in range(w):
            for b in range(w):
                total += np.int64(popcount(left_p[top + a, xl + b] ^ right_p[top + a, xr + b]))
    return total


@njit(**INLINE)
def blocked(claim, x, slack):
    """Whether a claim (the claimant's column, or -1) blocks pixel x: x - claimant > slack."""
    return claim >= 0 and x - claim > slack


@njit(**INLINE)
def is_distinct(best, second, uniqueness):
    """The unique rule's test: a second-best cost exists and beats best by uniqueness %."""
    return second >= 0 and second * 100 > best * (100 + uniqueness)


@njit(**SERIAL)
def _match_row(left_p, right_p, y, s, claims, costs, right_best, disp_row, cost_row,
               second_row, prev_row, next_row, right_row):
    """Match one row y, left to right, and return the number of candidates evaluated.

    left_p, right_p: (H + w - 1, W + w - 1), images (or census codes) edge-padded by
        h = w // 2, so the window centred on image pixel (y, x) has top-left (y, x).
    s: the Setup record (window, range, cost, CSW rule, extras).
    claims: int64 (W,), this row's B-map: the column of the pixel that last claimed each
        right pixel, or -1; reset here.  A claim by x' blocks pixel x if x - x' > slack.
    costs: int64 (D,) scratch: this pixel's evaluated costs by d - dmin (-1 = skipped).
    right_best: int64 (W,) scratch: the least cost seen for each right pixel.
    disp_row: int32 (W,) out, D(y, x) or INVALID.  cost_row: int64 (W,) out, m or -1.
    second_row, prev_row, next_row: int64 (W,) out, written only with s.extras;
        right_row: int32 (W,) out, written only with s.right_map (see MatchResult).
    """
    width = disp_row.shape[0]
    w, dmin, dmax = s.window, s.dmin, s.dmax
    claims[:] = -1
    if s.right_map:
        right_best[:] = np.iinfo(np.int64).max
        right_row[:] = INVALID
    evaluated = 0
    for x in range(width):
        best_d = INVALID
        best = np.int64(-1)
        top = min(dmax, x)
        for d in range(dmin, top + 1):
            if s.csw and blocked(claims[x - d], x, s.slack):
                costs[d - dmin] = -1
                continue
            c = _window_cost(left_p, right_p, y, x, x - d, w, s.cost)
            costs[d - dmin] = c
            evaluated += 1
            # Strict < over ascending d: the smallest d wins ties.
            if best_d == INVALID or c < best:
                best = c
                best_d = d
            if s.right_map and c < right_best[x - d]:
                # Strict < over ascending x: for a right pixel, the smallest d wins ties.
                right_best[x - d] = c
                right_row[x - d] = d
        disp_row[x] = best_d
        cost_row[x] = best
        second = np.int64(-1)
        if best_d != INVALID and (s.extras or (s.csw and s.rule == RULE_UNIQUE and
                                               best <= s.tau)):
            # The least evaluated cost at least 2 away from best_d.
            for d in range(dmin, top + 1):
                c = costs[d - dmin]
                if c >= 0 and abs(d - best_d) >= 2 and (second < 0 or c < second):
                    second = c
        if s.extras:
            second_row[x] = second
            prev_row[x] = costs[best_d - 1 - dmin] if best_d > dmin else -1
            next_row[x] = costs[best_d + 1 - dmin] if 0 <= best_d < top else -1
        if not s.csw or best_d == INVALID or best > s.tau:
            continue
        if s.rule == RULE_UNIQUE and not is_distinct(best, second, s.uniqueness):
            continue
        claims[x - best_d] = x
    return evaluated


@njit(**PARALLEL)
def _window_driver(left_p, right_p, rows, s, disp, min_cost, second, prev, nxt, right_disp,
                   stop):
    """Match the given rows in parallel; each iteration owns its B-map and cost scratch.

    rows: int64 (n,).  s: the Setup record.  disp: int32 (n, W) out.  min_cost: int64
    (n, W) out.  second, prev, nxt: int64 (n, W) out, written with s.extras; right_disp:
    int32 (n, W) out, written with s.right_map.  stop: uint8 (1,); rows not started once
    it is set are skipped (an interrupted run's maps are not used).  Returns int64 (n,),
    candidates evaluated per row.
    """
    n, width = disp.shape
    evaluated = np.zeros(n, np.int64)
    for i in prange(n):
        if stop_requested(stop):
            continue
        claims = np.empty(width, np.int64)
        costs = np.empty(s.dmax - s.dmin + 1, np.int64)
        right_best = np.empty(width, np.int64)
        e = np.int64(i) if s.extras else np.int64(0)  # maps not asked for: 1-row dummies
        r = np.int64(i) if s.right_map else np.int64(0)
        evaluated[i] = _match_row(left_p, right_p, rows[i], s, claims, costs, right_best,
                                  disp[i], min_cost[i], second[e], prev[e], nxt[e],
                                  right_disp[r])
    return evaluated


def pad_edge(image, h, dtype=np.uint16):
    """Copy of a (H, W) image padded by h on every side with its edge values (the
    contract's clamp), as ``dtype``: the window engine uses one uint16 kernel for 8- and
    16-bit input; the fast engine keeps 8-bit data 8-bit."""
    return np.pad(image.astype(dtype, copy=False), h, mode="edge")


def prepare(left, right, setup, census_window):
    """The arrays the drivers compare, and the Setup they run with: the images, or for
    the census cost their census codes compared with SHD."""
    if setup.cost == CENSUS:
        left = census_transform(left, census_window)
        right = census_transform(right, census_window)
        setup = setup._replace(cost=SHD)
    return left, right, setup


def extra_maps(shape, s):
    """(second, prev, next, right) outputs: full maps where asked for (s.extras for the
    first three, s.right_map for the last), else 1-row dummies the drivers never write
    (Numba needs arrays of the right type either way)."""
    rows = shape[0] if s.extras else 1
    costs = tuple(np.full((rows, shape[1]), -1, np.int64) for _ in range(3))
    right = np.full((shape[0] if s.right_map else 1, shape[1]), INVALID, np.int32)
    return (*costs, right)


def result(disp, min_cost, evaluated, plain, s, maps):
    """The MatchResult, with the extra maps only where they were computed."""
    costs = maps[:3] if s.extras else (None,) * 3
    return MatchResult(disp, min_cost, evaluated, plain, *costs,
                       maps[3] if s.right_map else None)


def match_window(left, right, *, window, dmin, dmax, cost, csw=False, tau=-1,
                 rule="literal", uniqueness=None, slack=None, rows=None, threads=None,
                 census_window=DEFAULT_CENSUS_WINDOW, extras=False, right_map=False):
    """Match a rectified pair with full window sums (the contract: docs/engines.md).

    left, right: uint8 or uint16 (H, W), same shape and dtype; left is the reference.
    cost: "sad", "ssd", "shd" or "census" (census_window x census_window census codes,
        compared with SHD).
    rule, uniqueness: the CSW rule ("literal" or "unique") and the unique rule's margin
        in percent (see docs/engines.md, "CSW rules").  slack: override the rule's binding (a
        claim by x' blocks x only when x - x' > slack); for studies of the rule.
    rows: optional int64 (n,) ascending row indices; then the maps are (n, W).
    extras: also return the second-best and neighbour costs; right_map: the right image's
        map from the same costs (see MatchResult).
    Returns a MatchResult: disparity int32 (H, W), min_cost int64 (H, W).
    Raises ValueError, with a message that says how to fix it, on bad input.
    """
    left, right, s, rows = validate(left, right, window=window, dmin=dmin, dmax=dmax,
                                    cost=cost, csw=csw, tau=tau, rule=rule,
                                    uniqueness=uniqueness, slack=slack, rows=rows,
                                    census_window=census_window, extras=extras,
                                    right_map=right_map)
    left, right, s = prepare(left, right, s, census_window)
    h = s.window // 2
    dtype = np.uint16 if left.dtype.itemsize <= 2 else left.dtype
    left_p, right_p = pad_edge(left, h, dtype), pad_edge(right, h, dtype)
    width = left.shape[1]
    disp = np.empty((rows.size, width), np.int32)
    min_cost = np.empty((rows.size, width), np.int64)
    maps = extra_maps(disp.shape, s)
    per_row = run_stoppable(
        lambda stop, _: _window_driver(left_p, right_p, rows, s, disp, min_cost, *maps, stop),
        threads, work=rows.size * width * (s.dmax - s.dmin + 1) * s.window ** 2)
    plain = candidate_count(width, s.dmin, s.dmax) * rows.size
    return result(disp, min_cost, int(per_row.sum()), plain, s, maps)

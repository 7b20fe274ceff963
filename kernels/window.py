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

from .config import INLINE, PARALLEL, SERIAL
from .contract import (
    INVALID,
    RULE_UNIQUE,
    SAD,
    SSD,
    MatchResult,
    candidate_count,
    run_stoppable,
    validate,
)


@njit(**INLINE)
def popcount16(v):
    """Number of set bits of a value below 2**16 (SHD's per-pixel cost)."""
    v = v - ((v >> 1) & 0x5555)
    v = (v & 0x3333) + ((v >> 2) & 0x3333)
    v = (v + (v >> 4)) & 0x0F0F
    return (v + (v >> 8)) & 0x1F


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
                bits = np.int64(left_p[top + a, xl + b]) ^ np.int64(right_p[top + a, xr + b])
                total += popcount16(bits)
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
def _match_row(left_p, right_p, y, w, dmin, dmax, cost, csw, tau, rule, uniqueness, slack,
               claims, costs, disp_row, cost_row):
    """Match one row y, left to right, and return the number of candidates evaluated.

    left_p, right_p: uint16 (H + w - 1, W + w - 1), images edge-padded by h = w // 2,
        so the window centred on image pixel (y, x) has top-left (y, x) in padded coords.
    claims: int64 (W,), this row's B-map: the column of the pixel that last claimed each
        right pixel, or -1; reset here.  A claim by x' blocks pixel x if x - x' > slack.
    costs: int64 (D,) scratch: this pixel's evaluated costs by d - dmin (-1 = skipped).
    disp_row: int32 (W,) out, D(y, x) or INVALID.  cost_row: int64 (W,) out, m or -1.
    """
    width = disp_row.shape[0]
    claims[:] = -1
    evaluated = 0
    for x in range(width):
        best_d = INVALID
        best = np.int64(-1)
        for d in range(dmin, min(dmax, x) + 1):
            if csw and blocked(claims[x - d], x, slack):
                costs[d - dmin] = -1
                continue
            c = _window_cost(left_p, right_p, y, x, x - d, w, cost)
            costs[d - dmin] = c
            evaluated += 1
            # Strict < over ascending d: the smallest d wins ties.
            if best_d == INVALID or c < best:
                best = c
                best_d = d
        disp_row[x] = best_d
        cost_row[x] = best
        if not csw or best_d == INVALID or best > tau:
            continue
        if rule == RULE_UNIQUE:
            # Second best among the evaluated candidates at least 2 away from best_d.
            second = np.int64(-1)
            for d in range(dmin, min(dmax, x) + 1):
                c = costs[d - dmin]
                if c >= 0 and abs(d - best_d) >= 2 and (second < 0 or c < second):
                    second = c
            if not is_distinct(best, second, uniqueness):
                continue
        claims[x - best_d] = x
    return evaluated


@njit(**PARALLEL)
def _window_driver(left_p, right_p, rows, w, dmin, dmax, cost, csw, tau, rule, uniqueness,
                   slack, disp, min_cost, stop):
    """Match the given rows in parallel; each iteration owns its B-map and cost scratch.

    rows: int64 (n,).  disp: int32 (n, W) out.  min_cost: int64 (n, W) out.
    stop: uint8 (1,); rows not started once it is set are skipped (an interrupted run's
    maps are not used).  Returns int64 (n,), the candidates evaluated per row.
    """
    n, width = disp.shape
    evaluated = np.zeros(n, np.int64)
    for i in prange(n):
        if stop[0]:
            continue
        claims = np.empty(width, np.int64)
        costs = np.empty(dmax - dmin + 1, np.int64)
        evaluated[i] = _match_row(left_p, right_p, rows[i], w, dmin, dmax, cost, csw, tau,
                                  rule, uniqueness, slack, claims, costs, disp[i], min_cost[i])
    return evaluated


def pad_edge(image, h, dtype=np.uint16):
    """Copy of a (H, W) image padded by h on every side with its edge values (the
    contract's clamp), as ``dtype``: the window engine uses one uint16 kernel for 8- and
    16-bit input; the fast engine keeps 8-bit data 8-bit."""
    return np.pad(image.astype(dtype, copy=False), h, mode="edge")


def match_window(left, right, *, window, dmin, dmax, cost, csw=False, tau=-1,
                 rule="literal", uniqueness=None, slack=None, rows=None, threads=None):
    """Match a rectified pair with full window sums (see the README's contract).

    left, right: uint8 or uint16 (H, W), same shape and dtype; left is the reference.
    rule, uniqueness: the CSW rule ("literal" or "unique") and the unique rule's margin
        in percent (see README, "CSW rules").  slack: override the rule's binding (a
        claim by x' blocks x only when x - x' > slack); for studies of the rule.
    rows: optional int64 (n,) ascending row indices; then the maps are (n, W).
    Returns a MatchResult: disparity int32 (H, W), min_cost int64 (H, W).
    Raises ValueError, with a message that says how to fix it, on bad input.
    """
    left, right, p = validate(left, right, window=window, dmin=dmin, dmax=dmax, cost=cost,
                              csw=csw, tau=tau, rule=rule, uniqueness=uniqueness, slack=slack,
                              rows=rows)
    h = p.window // 2
    left_p, right_p = pad_edge(left, h), pad_edge(right, h)
    width = left.shape[1]
    disp = np.empty((p.rows.size, width), np.int32)
    min_cost = np.empty((p.rows.size, width), np.int64)
    per_row = run_stoppable(
        lambda stop, _: _window_driver(left_p, right_p, p.rows, p.window, p.dmin, p.dmax,
                                       p.cost, p.csw, p.tau, p.rule, p.uniqueness, p.slack,
                                       disp, min_cost, stop), threads,
        work=p.rows.size * width * (p.dmax - p.dmin + 1) * p.window ** 2)
    plain = candidate_count(width, p.dmin, p.dmax) * p.rows.size
    return MatchResult(disp, min_cost, int(per_row.sum()), plain)

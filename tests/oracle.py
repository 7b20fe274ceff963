"""Brute-force reference for the matching contract, in plain Python and NumPy.

This is the definition of correctness: every engine must equal it bit for bit. It shares
no code with ``kernels`` (its own padding, its own popcount), so a bug in a kernel's
helper can't hide here.
"""

import numpy as np


def window_costs(left, right, y, x, ds, window, cost):
    """The contract's C(y, x, d) for each d in ds, as a list of Python ints."""
    h = window // 2
    height, width = left.shape
    ys = np.clip(np.arange(y - h, y + h + 1), 0, height - 1)
    out = []
    for d in ds:
        xs_l = np.clip(np.arange(x - h, x + h + 1), 0, width - 1)
        xs_r = np.clip(np.arange(x - d - h, x - d + h + 1), 0, width - 1)
        lw = left[np.ix_(ys, xs_l)].astype(np.int64)
        rw = right[np.ix_(ys, xs_r)].astype(np.int64)
        if cost == "sad":
            out.append(int(np.abs(lw - rw).sum()))
        elif cost == "ssd":
            out.append(int(((lw - rw) ** 2).sum()))
        else:
            out.append(int(np.bitwise_count((lw ^ rw).astype(np.uint64)).sum()))
    return out


def oracle_match(left, right, window, dmin, dmax, cost, csw=False, tau=-1, rows=None,
                 rule="literal", uniqueness=None, slack=None):
    """Reference (disparity int32 (n, W), min_cost int64 (n, W), evaluated int).

    CSW rules: "literal" claims the right pixel when m <= tau, and a claim blocks every
    later pixel. "unique" claims only when also some evaluated candidate at least 2 away
    from the best exists and every such one costs more than best * (1 + uniqueness/100);
    its claims do not block the pixel right after the claimant. uniqueness defaults to
    12 (SAD, SHD) or 25 (SSD).
    """
    if uniqueness is None:
        uniqueness = 25 if cost == "ssd" else 12
    height, width = left.shape
    rows = range(height) if rows is None else rows
    if slack is None:
        slack = 1 if rule == "unique" else 0
    disp = np.full((len(rows), width), -1, np.int32)
    mins = np.full((len(rows), width), -1, np.int64)
    evaluated = 0
    for i, y in enumerate(rows):
        claimant = {}  # right column -> the column of the pixel that last claimed it
        for x in range(width):
            ds = [d for d in range(dmin, min(dmax, x) + 1)
                  if not (csw and x - claimant.get(x - d, x) > slack)]
            if not ds:
                continue
            costs = window_costs(left, right, y, x, ds, window, cost)
            evaluated += len(ds)
            best = min(costs)
            d_best = ds[costs.index(best)]  # first, i.e. smallest, d attaining the minimum
            disp[i, x], mins[i, x] = d_best, best
            if not csw or best > np.floor(tau):
                continue
            if rule == "unique":
                others = [c for d, c in zip(ds, costs, strict=True) if abs(d - d_best) >= 2]
                if not others or min(others) * 100 <= best * (100 + uniqueness):
                    continue
            claimant[x - d_best] = x
    return disp, mins, evaluated

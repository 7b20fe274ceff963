"""Brute-force reference for the matching contract, in plain Python and NumPy.

This is the definition of correctness: every engine must equal it bit for bit. It shares
no code with ``kernels`` (its own padding, its own popcount), so a bug in a kernel's
helper can't hide here.
"""

import numpy as np


def census(image, size, pattern="dense"):
    """Census codes as Python ints in an object array: one bit per neighbour of the
    size x size window (edge-replicated), row by row, the centre skipped, the first
    neighbour most significant; a bit is set where the neighbour is darker.  The dense
    pattern takes every neighbour; the sparse one those at an even row and column offset
    from the centre, and the 3 x 3 around it."""
    height, width = image.shape
    h = size // 2
    codes = np.zeros((height, width), object)
    for y in range(height):
        for x in range(width):
            code = 0
            for a in range(-h, h + 1):
                for b in range(-h, h + 1):
                    if a == 0 and b == 0:
                        continue
                    if pattern == "sparse" and not (a % 2 == 0 and b % 2 == 0) and \
                            not (abs(a) <= 1 and abs(b) <= 1):
                        continue
                    yy = min(max(y + a, 0), height - 1)
                    xx = min(max(x + b, 0), width - 1)
                    code = (code << 1) | int(image[yy, xx] < image[y, x])
            codes[y, x] = code
    return codes


def window_costs(left, right, y, x, ds, window, cost):
    """The contract's C(y, x, d) for each d in ds, as a list of Python ints.  For
    "census", left and right are census code arrays (see census) and the cost is SHD."""
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
        elif cost == "shd":
            out.append(int(np.bitwise_count((lw ^ rw).astype(np.uint64)).sum()))
        else:
            lw, rw = left[np.ix_(ys, xs_l)], right[np.ix_(ys, xs_r)]
            out.append(sum(bin(a ^ b).count("1") for a, b in zip(lw.ravel(), rw.ravel(),
                                                                  strict=True)))
    return out


def record(ds, costs, i, x, disp, mins, more, seen):
    """Pixel x of map row i from its candidates ds and their costs: the smallest d among
    the least costs into disp and mins, the second best (2 or more away), the costs at
    d -/+ 1, and the right map (seen: right column -> (cost, d) of its best match so
    far, the smallest d on ties).  Returns (d, its cost)."""
    best = min(costs)
    d_best = ds[costs.index(best)]  # first, i.e. smallest, d attaining the minimum
    disp[i, x], mins[i, x] = d_best, best
    by_d = dict(zip(ds, costs, strict=True))
    others = [c for d, c in by_d.items() if abs(d - d_best) >= 2]
    more["second_cost"][i, x] = min(others) if others else -1
    more["prev_cost"][i, x] = by_d.get(d_best - 1, -1)
    more["next_cost"][i, x] = by_d.get(d_best + 1, -1)
    for d, c in by_d.items():
        if x - d not in seen or c < seen[x - d][0]:
            seen[x - d] = (c, d)
            more["right_disparity"][i, x - d] = d
    return d_best, best


def oracle_match(left, right, window, dmin, dmax, cost, csw=False, tau=-1, rows=None,
                 rule="literal", csw_margin=None, slack=None, census_window=5, extras=False,
                 census_pattern="dense"):
    """Reference (disparity int32 (n, W), min_cost int64 (n, W), evaluated int), and with
    ``extras`` a fourth item: a dict of second_cost, prev_cost, next_cost (int64, the
    least evaluated cost 2 or more from d, the costs at d -/+ 1; -1 where none) and
    right_disparity (int32: each right pixel's best left match d, smallest d on ties,
    over evaluated candidates; invalid where none).

    A candidate d needs its right pixel in the image: 0 <= x - d <= W - 1 (the upper
    bound matters only for a range reaching below 0).  Invalid pixels of the integer
    maps are -1, or int32's minimum for a range reaching below 0 (where -1 is a d).

    CSW rules: "literal" claims the right pixel when m <= tau, and a claim blocks every
    later pixel. "unique" claims only when also some evaluated candidate at least 2 away
    from the best exists and every such one costs more than best * (1 + csw_margin/100);
    its claims do not block the pixel right after the claimant. the margin defaults to
    12 (SAD, SHD) or 25 (SSD).
    """
    if csw_margin is None:
        csw_margin = 25 if cost == "ssd" else 12
    if cost == "census":
        left = census(left, census_window, census_pattern)
        right = census(right, census_window, census_pattern)
    height, width = left.shape
    rows = range(height) if rows is None else rows
    if slack is None:
        slack = 1 if rule == "unique" else 0
    invalid = -1 if dmin >= 0 else np.iinfo(np.int32).min
    disp = np.full((len(rows), width), invalid, np.int32)
    mins = np.full((len(rows), width), -1, np.int64)
    more = {k: np.full((len(rows), width), -1, np.int64)
            for k in ("second_cost", "prev_cost", "next_cost")}
    more["right_disparity"] = np.full((len(rows), width), invalid, np.int32)
    evaluated = 0
    for i, y in enumerate(rows):
        claimant = {}  # right column -> the column of the pixel that last claimed it
        seen = {}  # right column -> (cost, d) of its best match so far
        for x in range(width):
            ds = [d for d in range(max(dmin, x - width + 1), min(dmax, x) + 1)
                  if not (csw and x - claimant.get(x - d, x) > slack)]
            if not ds:
                continue
            costs = window_costs(left, right, y, x, ds, window, cost)
            evaluated += len(ds)
            d_best, best = record(ds, costs, i, x, disp, mins, more, seen)
            if not csw or best > np.floor(tau):
                continue
            if rule == "unique":
                others = [c for d, c in zip(ds, costs, strict=True) if abs(d - d_best) >= 2]
                if not others or min(others) * 100 <= best * (100 + csw_margin):
                    continue
            claimant[x - d_best] = x
    if extras:
        return disp, mins, evaluated, more
    return disp, mins, evaluated


# The pipeline's stages, brute force (see csw.matching.pipeline and csw.kernels.filters).

def xsobel(image, cap):
    height, width = image.shape
    out = np.zeros((height, width), np.uint8)

    def at(y, x):
        return int(image[min(max(y, 0), height - 1), min(max(x, 0), width - 1)])

    for y in range(height):
        for x in range(width):
            g = sum(k * (at(y + a, x + 1) - at(y + a, x - 1)) for a, k in ((-1, 1), (0, 2), (1, 1)))
            out[y, x] = min(max(g, -cap), cap) + cap
    return out


def textured(image, window, cap, threshold):
    response = np.abs(xsobel(image, cap).astype(np.int64) - cap)
    height, width = image.shape
    h = window // 2
    out = np.zeros((height, width), bool)
    for y in range(height):
        for x in range(width):
            total = sum(int(response[min(max(y + a, 0), height - 1), min(max(x + b, 0), width - 1)])
                        for a in range(-h, h + 1) for b in range(-h, h + 1))
            out[y, x] = total >= threshold
    return out


def lr_consistent(disp, right_disp, limit, invalid=-1):
    height, width = disp.shape
    out = np.zeros((height, width), bool)
    for y in range(height):
        for x in range(width):
            d = int(disp[y, x])
            if d != invalid:
                back = int(right_disp[y, x - d])
                out[y, x] = back != invalid and abs(d - back) <= limit
    return out


def subpixel(disp, best, prev, nxt, fit, invalid=-1):
    out = disp.astype(np.float64).copy()
    for (y, x), d in np.ndenumerate(disp):
        c, p, n = float(best[y, x]), float(prev[y, x]), float(nxt[y, x])
        if d == invalid or p < 0 or n < 0:
            continue
        denominator = p - 2 * c + n if fit == "parabola" else max(p, n) - c
        if denominator > 0:
            out[y, x] = d + min(max((p - n) / (2 * denominator), -0.5), 0.5)
    return out


def winners_consistent(disp, cost, limit, invalid=-1):
    """StereoBM's check: right pixel xr's match is the d of the least-cost left pixel
    with x - d = xr (the leftmost of equals)."""
    height, width = disp.shape
    out = np.zeros((height, width), bool)
    for y in range(height):
        owner = {}
        for x in range(width):
            d = int(disp[y, x])
            if d != invalid and (x - d not in owner or cost[y, x] < owner[x - d][0]):
                owner[x - d] = (int(cost[y, x]), d)
        for x in range(width):
            d = int(disp[y, x])
            out[y, x] = d != invalid and abs(d - owner[x - d][1]) <= limit
    return out


def speckles(disp, max_size, max_diff):
    from collections import deque

    height, width = disp.shape
    seen = np.zeros((height, width), bool)
    small = np.zeros((height, width), bool)
    for y0 in range(height):
        for x0 in range(width):
            if seen[y0, x0] or np.isnan(disp[y0, x0]):
                continue
            region, queue = [], deque([(y0, x0)])
            seen[y0, x0] = True
            while queue:
                y, x = queue.popleft()
                region.append((y, x))
                for yy, xx in ((y - 1, x), (y + 1, x), (y, x - 1), (y, x + 1)):
                    if 0 <= yy < height and 0 <= xx < width and not seen[yy, xx] \
                            and not np.isnan(disp[yy, xx]) \
                            and abs(disp[yy, xx] - disp[y, x]) <= max_diff:
                        seen[yy, xx] = True
                        queue.append((yy, xx))
            if len(region) < max_size:
                for y, x in region:
                    small[y, x] = True
    return small


def median_valid(disp, size):
    height, width = disp.shape
    h = size // 2
    out = np.full((height, width), np.nan, np.float32)
    for y in range(height):
        for x in range(width):
            if np.isnan(disp[y, x]):
                continue
            box = disp[max(y - h, 0):y + h + 1, max(x - h, 0):x + h + 1].ravel()
            values = sorted(v for v in box if not np.isnan(v))
            out[y, x] = values[(len(values) - 1) // 2]
    return out


def fill_background(disp):
    out = disp.copy()
    for y, row in enumerate(disp):
        valid = [x for x in range(len(row)) if not np.isnan(row[x])]
        for x in range(len(row)):
            if not np.isnan(row[x]):
                continue
            left = [row[v] for v in valid if v < x]
            right = [row[v] for v in valid if v > x]
            sides = ([left[-1]] if left else []) + ([right[0]] if right else [])
            out[y, x] = min(sides) if sides else 0.0
    return out


def remap_bilinear(image, map_x, map_y):
    """The remap kernel's result, plainly: (out, valid) where out[y, x] is the image
    bilinearly at (map_x, map_y), the point rounded to 1/32 pixel and the weights
    integers (OpenCV's fixed point), rounded half up; valid where the point lies inside
    the image (0 <= x <= w - 1, 0 <= y <= h - 1), 0 outside."""
    height, width = image.shape
    out = np.zeros(map_x.shape, image.dtype)
    valid = np.zeros(map_x.shape, bool)
    for y in range(map_x.shape[0]):
        for x in range(map_x.shape[1]):
            sx, sy = map_x[y, x], map_y[y, x]  # float32 arithmetic, as the kernel's
            if not (0.0 <= sx <= width - 1 and 0.0 <= sy <= height - 1):
                continue
            ix = int(sx * np.float32(32) + np.float32(0.5))
            iy = int(sy * np.float32(32) + np.float32(0.5))
            x0, y0, wx, wy = ix // 32, iy // 32, ix % 32, iy % 32
            x1, y1 = min(x0 + 1, width - 1), min(y0 + 1, height - 1)
            upper = int(image[y0, x0]) * (32 - wx) + int(image[y0, x1]) * wx
            lower = int(image[y1, x0]) * (32 - wx) + int(image[y1, x1]) * wx
            out[y, x] = (upper * (32 - wy) + lower * wy + 512) // 1024
            valid[y, x] = True
    return out, valid


# Semi-global matching, brute force over the whole volume (see kernels/jit/sgm.py).

SGM_PATHS = {4: ((0, 1), (0, -1), (1, 0), (-1, 0)),
             5: ((0, 1), (0, -1), (1, 0), (1, 1), (1, -1)),
             8: ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))}


def sgm_volume(left, right, window, dmin, dmax, cost, census_window=5,
               census_pattern="dense", starts=None, band=None):
    """C (H, W, D) as Python-int-exact int64: the contract's window cost where the right
    pixel x - d is in the image, else the largest cost a window can have; Hamming
    costs whose largest lies in 256..510 truncated to 255.  With
    ``starts`` (H, W) and ``band`` K: C (H, W, K), slot k of pixel p holding
    d = dmin + starts[p] + k (a narrowed search: every d stays within dmin..dmax)."""
    pixels = np.asarray(left).dtype
    if cost == "census":
        bits = len([1 for a in range(census_window) for b in range(census_window)
                    if (a, b) != (census_window // 2,) * 2 and (
                        census_pattern == "dense" or
                        ((a - census_window // 2) % 2 == 0 and (b - census_window // 2) % 2 == 0)
                        or max(abs(a - census_window // 2), abs(b - census_window // 2)) == 1)])
        left = census(left, census_window, census_pattern)
        right = census(right, census_window, census_pattern)
        per_pixel = bits
    else:
        top = int(np.iinfo(pixels).max)
        per_pixel = {"sad": top, "ssd": top * top, "shd": np.iinfo(pixels).bits}[cost]
    cmax = per_pixel * window * window
    if cost in ("census", "shd") and 255 < cmax <= 510:
        cmax = 255  # Hamming costs truncated to a byte (docs/engines.md, "Costs")
    height, width = left.shape
    slots = dmax - dmin + 1 if starts is None else band
    volume = np.full((height, width, slots), cmax, np.int64)
    for y in range(height):
        for x in range(width):
            first = dmin + (0 if starts is None else int(starts[y, x]))
            assert first + slots - 1 <= dmax
            ds = range(first, first + slots)
            inside = [d for d in ds if 0 <= x - d <= width - 1]
            for d, c in zip(inside, window_costs(left, right, y, x, inside, window, cost),
                            strict=True):
                volume[y, x, d - first] = min(c, cmax)
    return volume


def sgm_sums(volume, paths, p1, p2, starts=None):
    """S (H, W, D) int64: Hirschmueller's L_r summed over the paths, each path starting
    with L = C at its first pixel inside the image.  With ``starts`` (a narrowed
    volume's, see sgm_volume), slot k of p meets the slots of p - r holding the same d
    and d -/+ 1; a d that p - r did not search has no L (as one beyond the range)."""
    height, width, ndisp = volume.shape
    total = np.zeros_like(volume)
    for dy, dx in SGM_PATHS[paths]:
        L = np.zeros_like(volume)
        ys = range(height) if dy >= 0 else range(height - 1, -1, -1)
        xs = list(range(width)) if dx >= 0 else list(range(width - 1, -1, -1))
        for y in ys:
            for x in xs:
                py, px = y - dy, x - dx
                c = volume[y, x]
                if not (0 <= py < height and 0 <= px < width):
                    L[y, x] = c
                    continue
                # around[1 + k]: L(p - r) at slot k's d, around[k], [k + 2] at d -/+ 1,
                # infinite at d that p - r did not search
                shift = 0 if starts is None else int(starts[y, x]) - int(starts[py, px])
                searched = L[py, px].astype(np.float64)
                least = searched.min()
                slot = np.arange(-1, ndisp + 1) + shift
                inside = (slot >= 0) & (slot < ndisp)
                around = np.where(inside, searched[np.clip(slot, 0, ndisp - 1)], np.inf)
                # min(L(k), L(k - 1) + P1, L(k + 1) + P1, least + P2)
                best = np.minimum(np.minimum(around[1:-1], least + p2),
                                  np.minimum(around[:-2], around[2:]) + p1)
                L[y, x] = c + best.astype(np.int64) - int(least)
        total += L
    return total


def sgm_match(left, right, window, dmin, dmax, cost, paths, p1, p2, census_window=5,
              census_pattern="dense", starts=None, band=None):
    """(disparity int32, min_cost int64, extras) as oracle_match's with ``extras``, the
    costs being the sums S over the candidates whose right pixel is in the image (and,
    with ``starts`` and ``band``, that the pixel searched: see sgm_volume)."""
    volume = sgm_volume(left, right, window, dmin, dmax, cost, census_window,
                        census_pattern, starts, band)
    total = sgm_sums(volume, paths, p1, p2, starts)
    height, width, slots = volume.shape
    invalid = -1 if dmin >= 0 else np.iinfo(np.int32).min
    disp = np.full((height, width), invalid, np.int32)
    mins = np.full((height, width), -1, np.int64)
    more = {k: np.full((height, width), -1, np.int64)
            for k in ("second_cost", "prev_cost", "next_cost")}
    more["right_disparity"] = np.full((height, width), invalid, np.int32)
    for y in range(height):
        seen = {}
        for x in range(width):
            first = dmin + (0 if starts is None else int(starts[y, x]))
            ds = [d for d in range(first, first + slots) if 0 <= x - d <= width - 1]
            if not ds:
                continue
            record(ds, [int(total[y, x, d - first]) for d in ds], y, x, disp, mins, more,
                   seen)
    return disp, mins, more


def row_spans(disp, valid):
    """(low, high) (h, w): each pixel's match where valid, else the row's nearest valid
    matches left and right of it (their least and greatest; one side if only one has
    any); -1 where its row has none.  disp holds no negatives."""
    h, w = disp.shape
    cols = np.arange(w, dtype=np.int32)
    before = np.maximum.accumulate(np.where(valid, cols, -1), axis=1)
    after = np.minimum.accumulate(np.where(valid, cols, w)[:, ::-1], axis=1)[:, ::-1]
    left = np.take_along_axis(disp, np.maximum(before, 0), axis=1)
    right = np.take_along_axis(disp, np.minimum(after, w - 1), axis=1)
    left[before < 0] = -1
    right[after >= w] = -1
    low = np.where(left < 0, right, np.where(right < 0, left, np.minimum(left, right)))
    high = np.maximum(left, right)
    return low, high


def neighbourhood(values, reduce):
    """values (h, w) reduced over each pixel's 3 x 3 neighbourhood (edges repeated);
    reduce: np.minimum or np.maximum."""
    padded = np.pad(values, 1, mode="edge")
    rows = reduce(reduce(padded[:-2], padded[1:-1]), padded[2:])
    return reduce(reduce(rows[:, :-2], rows[:, 1:-1]), rows[:, 2:])


def narrow_starts(disp, valid, shape, dmin, ndisp, slots, margin):
    """The narrowed search's starts, int32 ``shape`` (H, W) in 0..ndisp - slots, from a
    half-size match (csw.matching.narrow): disp int32 (h, w) over the half range, which
    starts at dmin // 2; valid bool (h, w), its left-right check.  Each half-size pixel's
    span is that of its 3 x 3 neighbourhood's row spans (row_spans), doubled and
    ``margin`` wider each side; K = slots centred on it where it is at most K wide, else
    centred on the pixel's own match (where it has none, the span's middle); 0 where the
    neighbourhood has no match; each full-size pixel takes its half-size pixel's, the
    last row and column of an odd size their neighbour's."""
    height, width = shape
    offsets = disp - np.int32(dmin // 2)
    low, high = row_spans(offsets, valid)
    found = low >= 0
    low = neighbourhood(np.where(found, low, np.int32(2 * ndisp)), np.minimum)
    high = neighbourhood(np.where(found, high, -1), np.maximum)
    known = low <= high
    own = np.where(valid, offsets, np.where(known, (low + high) // 2, 0))
    base = 2 * (dmin // 2) - dmin  # full-size offset of the half range's start
    first = 2 * low + base - margin
    last = 2 * high + base + margin
    span = last - first + 1
    centred = first - (slots - span) // 2
    on_own = 2 * own + base - slots // 2
    start = np.where(span <= slots, centred, on_own)
    start = np.clip(np.where(known, start, 0), 0, ndisp - slots).astype(np.int32)
    ys = np.minimum(np.arange(height) // 2, start.shape[0] - 1)
    xs = np.minimum(np.arange(width) // 2, start.shape[1] - 1)
    return start[ys][:, xs]

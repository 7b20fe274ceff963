"""Semi-global matching: the window costs of the contract aggregated along 4 or 8 paths
(Hirschmueller's recurrence, kernels/jit/sgm.py has it exactly), then the winner, its
second best, neighbours, right map and left-right check as the local engines make them,
so that every stage of the pipeline runs on its result unchanged.

Memory never holds the H x W x D volume: the image is cut into bands of rows, and a band
holds its costs and sums (B x W x D each).  The paths down need every row above a band,
the paths up every row below, so the rows are swept twice, exactly:

  pass 1, down   each band's costs, and the down paths through them; the down paths'
                 state (one row of W x D) kept where each band starts
  pass 2, up     bands from the bottom: the band's costs again, the down paths again
                 from the kept state (adding into the band's sums), the up paths from
                 the band below, then each row's two horizontal paths and its winner

A pair of at most one band skips pass 1.  With 5 paths (left, right, down and the two
diagonals going down, OpenCV's MODE_SGBM's) every path comes from above or along the
row, so one sweep down does it all: each band's costs, its paths and its winners, the
paths' states carried to the next band; the bands are then made small enough to stay
in the caches (SINGLE_PASS_BAND_BYTES).  Every core works on one band at a time: the
costs split the band's columns, each block's path down made with them row by row
(fused, kernels/jit/sgm.py: each column's path is its own) and its path up right after,
the rows' last step its rows; the diagonal paths cross columns and run in one thread.
A band in one thread also makes its path up within the last step, the rows going up.
With 4 paths, a band on two threads is cut into halves, so that every vertical step is
fused, none a pass of its own over the slabs (which took three times a fused one's
time): first the top half's costs going down with the path down, then the bottom half's
going up with the path up, each thread a block of columns of both; then the top half's
rows going up, each with its step of the path up (whose state the bottom half left at
the cut), beside the bottom half's going down with the path down.
Each step asks for the next row's slab lines while it works on a row (kernels/jit/sgm.py).
Results do not depend on the bands or the threads: every split computes the same sums.

Layers:
  match_sgm     public: validate, pad, choose the accumulator and the bands, run
  the passes    here, each step's stripes in the pool (kernels/runtime.py)
  jit/sgm.py    the workers
"""

import math

import numpy as np

from . import native, runtime
from .catalogue import PATHS, accumulator, aggregated_max, cost_type, entry, sentinel
from .census import census_pair
from .contract import (
    CENSUS,
    LANES,
    SHD,
    candidate_count,
    census_bits,
    pad_edge,
    validate,
)
from .costs import cost_coded, cost_named
from .fast import keyed_range
from .window import extra_maps, result
from .workspace import empty, output, slab

COSTS, VERTICAL, DIAGONAL, SELECT = 0, 1, 2, 3  # the worker's steps (jit/sgm.py)

# A pair whose slabs (costs and sums) fit in this many bytes is one band, with no first
# pass; a band never holds more.  With byte costs, 1280 x 720 at d 0..63 (177 MB) took
# 68 ms as one band against 76 in bands (two threads), and KITTI's 1242 x 375 at d
# 0..191 (268 MB) 106 against 93.
BAND_BYTES = 192 << 20


def default_penalties(cost, window, census_bits_=None, pixels=np.uint8):
    """(P1, P2) scaled to the cost (a name) and the window, as OpenCV scales them to its
    block (kernels/costs.py has each cost's): for Hamming costs, a quarter of the code's
    bits and all of them per window pixel (``census_bits_``: a census code's, else the
    type's); for SAD, OpenCV's 8 and 32 per window pixel (on 8-bit images; 16-bit ones
    scale by 257); for SSD, their squares' scale."""
    bits = census_bits_ if census_bits_ is not None else np.iinfo(pixels).bits
    scale = 1 if np.dtype(pixels) == np.uint8 else 257
    return cost_named(cost).penalties(window * window, scale, int(bits))


def memory(height, width, ndisp, window, paths, threads, band_bytes=None, slots=None):
    """Bytes a match_sgm of a pair this size holds beyond its images and maps, at most
    (32-bit sums): the band's slabs, the paths' states and the down paths' states kept
    at each band's start (none in a single sweep: 5 paths), and each thread's cost
    scratch (column sums and Hamming costs' ring).  slots: a banded match's K (its slabs
    and states hold K, its states' pads 2K + 4 more; its cost scratch the whole range;
    and its starts)."""
    down, single = downward_paths(paths), paths == 5
    states = 2 * down if single else 4 * down  # two buffers a path going down or up
    if slots is not None:
        state = width * (3 * slots + 4) * 4
        bands, rows = band_plan(height, width, slots, 8, state / width / slots,
                                band_bytes, single)
        kept = 0 if single else (len(bands) - 1) * down * state
        # Each thread's cost scratch, of the whole range: column sums, and the ring, or
        # with a window of 1 a row's costs.
        return rows * width * slots * 8 + states * state + kept + height * width * 4 + \
            threads * (width + window) * ndisp * (4 + (4 if window == 1 else window))
    ndisp = -(-ndisp // LANES) * LANES  # padded at most to whole vectors (padded_depth)
    state = width * (ndisp + 2) * 4
    bands, rows = band_plan(height, width, ndisp, 8, down * state / width / ndisp,
                            band_bytes, single)
    kept = 0 if single else (len(bands) - 1) * down * state
    scratch = threads * (width + window) * ndisp * (4 + window)
    return rows * width * ndisp * 8 + states * state + kept + scratch


def downward_paths(paths):
    """The paths going down: the vertical one, and with 5 or 8 paths the two diagonals."""
    return 1 if paths == 4 else 3


# A single sweep's band (5 paths).  Each band restarts the window's cost sums and its
# steps are calls of their own, so bands of tens of rows; slabs small enough for the
# caches (a few rows) measured slower, not faster.
SINGLE_PASS_BAND_BYTES = 64 << 20

# Bands are at least this tall where the pair is cut (each band's steps are calls of
# their own, a few tens of microseconds each).
MIN_BAND_ROWS = 32

# A narrowed search's costs are made in tiles of this many rows (kernels/jit/sgm.py,
# cost_rows): each column's sums cover the slots its pixels search in the tile.  Taller
# tiles widen those spans; shorter ones sum the window's first rows more often.
TILE_ROWS = 16

# A step of a band (its costs, a vertical path, its rows' paths and winners) is split
# between the threads from this much work (runtime.DIRECT_WORK's units: about 1 ms),
# where other runs take 10 ms: handing stripes to the pool costs about 0.13 ms, and a
# 1080p pair's narrowed bands' steps, 5-8 ms each, ran in one thread of two.
STEP_DIRECT_WORK = runtime.DIRECT_WORK // 10


def band_rows(height, width, ndisp, itemsize, kept_itemsize, band_bytes=None,
              single_pass=False):
    """Rows per band.  A single sweep's (``single_pass``: 5 paths, no state kept between
    passes): as many as fit SINGLE_PASS_BAND_BYTES (or band_bytes where less).
    Otherwise all of them where the whole pair's slabs (``itemsize``: their bytes per
    (pixel, d) together) fit in band_bytes (None: BAND_BYTES): one band, no first pass;
    else the height that holds the least memory, slabs and kept states together
    (``kept_itemsize``: a kept state's bytes per (column, d)): B rows of slabs and H / B
    kept rows, least at B = sqrt(H * kept / slab), so that memory grows with the square
    root of the height; at least MIN_BAND_ROWS."""
    band_bytes = BAND_BYTES if band_bytes is None else band_bytes
    per_row = width * ndisp * itemsize
    if single_pass:
        return int(max(1, min(height, min(band_bytes, SINGLE_PASS_BAND_BYTES) // per_row)))
    if height * per_row <= band_bytes:
        return height
    best = max(MIN_BAND_ROWS, round(math.sqrt(height * kept_itemsize / itemsize)))
    return int(max(1, min(height, best, band_bytes // per_row)))


# Where a pair is cut into bands, pass 1 makes the costs and down paths of every band
# but the bottom one, and pass 2 makes them again: each row the bottom band holds is
# made once.  So the bottom band takes as many rows as fit this many bytes, beyond the
# other bands' least-memory height (a KITTI pair at d 0..191: 137 rows rather than 32).
LAST_BAND_BYTES = 128 << 20


def band_plan(height, width, ndisp, itemsize, kept_itemsize, band_bytes=None,
              single_pass=False):
    """The bands, (y0, y1) from the top, and the slabs' rows (the tallest band's): bands
    of band_rows(...) rows (the arguments are its), but the bottom one, which takes as
    many as fit LAST_BAND_BYTES (or band_bytes where less) where the pair is cut in two
    passes."""
    rows = band_rows(height, width, ndisp, itemsize, kept_itemsize, band_bytes,
                     single_pass)
    if single_pass or rows >= height:
        return [(y0, min(y0 + rows, height)) for y0 in range(0, height, rows)], rows
    budget = min(BAND_BYTES if band_bytes is None else band_bytes, LAST_BAND_BYTES)
    last = int(min(height - 1, max(rows, budget // (width * ndisp * itemsize))))
    top = height - last
    bands = [(y0, min(y0 + rows, top)) for y0 in range(0, top, rows)]
    return bands + [(top, height)], max(rows, last)


def match_sgm(left, right, *, window, dmin, dmax, cost, paths, p1, p2,
              census_window=None, census_pattern=None, extras=False, right_map=False,
              lr_check=None, threads=None, into=None, band_bytes=None,
              workspace=None, engine="fast", csw=False, tau=-1, rule="literal",
              csw_margin=None, rows=None, starts=None, slots=None, second=True):
    """Semi-global matching of a rectified pair (kernels/jit/sgm.py has the definition).

    left, right: uint8 or uint16 (H, W), same shape and dtype.  window, dmin, dmax,
    cost, census_window, census_pattern: as for the local engines (the window sums the
    costs before aggregation; 1 aggregates each pixel's own).  paths: 4, 5 (one sweep
    down) or 8.  p1, p2:
    the penalties, whole numbers, 0 <= P1 <= P2.  extras, right_map, lr_check, threads,
    into: as for kernels.fast.match_fast; with extras, second=False leaves the second
    best out (its result's second_cost None), which a confidence and the uniqueness
    check read but subpixel does not: a sixth of the winners' step.  band_bytes: a
    band's memory (tests make it small to cut many bands; None: BAND_BYTES); workspace:
    a kernels.workspace.Workspace that keeps the band's slabs for the next match (None:
    fresh ones).
    rows: as for match_fast, but every row is matched (the paths cross them all) and
    the maps keep those asked for.
    starts, slots: a narrowed search: pixel p searches d = dmin + starts[p] + k for k <
    slots; starts int (H, W), 0 <= starts <= dmax - dmin + 1 - slots (None: every d).
    engine, tau, rule, csw_margin: the local engines' (taken, unused); CSW is theirs
    only.
    Returns a MatchResult whose min_cost, second, prev and next costs are the
    aggregated sums S.
    """
    if csw:
        raise ValueError("semi-global matching takes every candidate: no CSW")
    if paths not in PATHS:
        raise ValueError(f"paths must be one of {', '.join(map(str, PATHS))}, got {paths!r}")
    for name, value in (("P1", p1), ("P2", p2)):
        if isinstance(value, bool) or int(value) != value or value < 0:
            raise ValueError(f"{name} must be a whole number >= 0, got {value!r}")
    p1, p2 = int(p1), int(p2)
    if p1 > p2:
        raise ValueError(f"P1 ({p1}) must not exceed P2 ({p2})")
    left, right, s, rows = validate(left, right, rows=rows, window=window, dmin=dmin,
                                    dmax=dmax,
                                    cost=cost, csw=False, tau=-1,
                                    census_window=census_window,
                                    census_pattern=census_pattern, extras=extras,
                                    right_map=right_map, lr_check=lr_check)
    height, width = left.shape
    ndisp = s.dmax - s.dmin + 1
    if ndisp > np.iinfo(np.int16).max:
        raise ValueError("semi-global matching searches at most 32767 disparities at once; "
                         "narrow dmin..dmax")
    banded = starts is not None
    if banded:
        if isinstance(slots, bool) or not isinstance(slots, (int, np.integer)) or \
                not 1 <= slots <= ndisp:
            raise ValueError(f"slots must be a whole number in 1..{ndisp}, got {slots!r}")
        starts = np.asarray(starts)
        if starts.shape != (height, width) or starts.dtype.kind not in "iu":
            raise ValueError(f"starts must be whole numbers shaped {(height, width)}, got "
                             f"{starts.dtype} {starts.shape}")
        if starts.size and (starts.min() < 0 or starts.max() > ndisp - slots):
            raise ValueError(f"starts must lie in 0..{ndisp - slots} (dmax - dmin + 1 - "
                             "slots)")
        starts = np.ascontiguousarray(starts, np.int32)
        whole, ndisp = ndisp, int(slots)
    else:
        starts = np.zeros((1, 1), np.int32)
    h = s.window // 2
    shift = max(0, -s.dmin)
    shape = (height + 2 * h, width + 2 * h)
    bits = None
    if s.cost == CENSUS:
        bits = census_bits(census_window, census_pattern)
        left_p, right_rev = census_pair(left, right, census_window, threads, h,
                                        pattern=census_pattern)
        s = s._replace(cost=SHD)
    else:
        left_p = pad_edge(left, h, left.dtype, out=np.empty(shape, left.dtype))
        right_rev = pad_edge(right[:, ::-1], h, right.dtype, out=np.empty(shape, right.dtype))
    if shift:
        right_rev = np.ascontiguousarray(np.pad(right_rev, ((0, 0), (shift, 0)), mode="edge"))
    cmax = aggregated_max(cost_coded(s.cost), left_p.dtype, bits, s.window)
    acc = accumulator(cmax, p1, p2, paths, banded)
    run = native.entry(*entry("sgm", s.cost, left_p.dtype, cmax, acc, s.dmin, banded))
    slots_searched = ndisp
    if not banded:
        ndisp = padded_depth(ndisp, cmax, p1, p2, cost_type(cmax, acc))
    n_threads = runtime.thread_count(threads)

    disp = output(into, "disparity", (height, width), np.int32)
    min_cost = np.empty((height, width), np.int64)
    maps = extra_maps(disp.shape, s, workspace, second=second, written=True)
    seconds = s.extras and second
    checked = s.lr_check >= 0
    lr_valid = output(into, "lr_valid", (height, width), np.uint8) if checked else \
        np.empty((1, width), np.uint8)
    single_pass = paths == 5
    bands, rows_per_band = band_plan(height, width, ndisp,
                                     acc.itemsize + cost_type(cmax, acc).itemsize,
                                     downward_paths(paths) * acc.itemsize *
                                     (ndisp + 2) / ndisp, band_bytes, single_pass)
    # The slabs from the thread's workspace where there is one (kernels/workspace.py):
    # a stream's or a notebook's next match reuses them (a half-size pass's as well).
    costs = slab(workspace, "sgm-costs", (rows_per_band, width, ndisp), cost_type(cmax, acc))
    sums = slab(workspace, "sgm-sums", (rows_per_band, width, ndisp), acc)
    never = int(np.iinfo(acc).max)
    big = sentinel(cmax, p2, banded)  # the d axis's sentinels

    def fresh_state(path):
        state = empty(workspace, f"sgm-{path}", (2, width, ndisp + 2), acc)
        state.fill(big)
        state[:, :, 1:1 + ndisp] = 0
        return state, np.zeros((2, width), acc)

    down, down_mins = fresh_state("down")
    diagonals = paths != 4
    if diagonals:
        down_l, down_l_mins = fresh_state("down-left")
        down_r, down_r_mins = fresh_state("down-right")
    if not single_pass:
        up, up_mins = fresh_state("up")
    if paths == 8:
        up_l, up_l_mins = fresh_state("up-left")
        up_r, up_r_mins = fresh_state("up-right")
    dummy3 = np.empty((1, 1, 1), acc)
    dummy2 = np.empty((1, 1), acc)
    base = dict(left_p=left_p, right_rev=right_rev, costs=costs, sums=sums,
                col_sums=dummy2, row_sums=np.empty(1, acc), ring=np.empty((1, 1, 1), np.uint8),
                row_costs=np.empty((1, 1), costs.dtype), spans=np.empty((2, 1), np.int32),
                state=dummy3, mins=dummy2,
                other=dummy3, other_mins=dummy2, line=dummy2,
                moved=np.empty(1, acc),  # a banded step's own: moved_row
                right_best=np.empty(1, acc), right_d=np.empty(1, np.int16),
                disp=disp, min_cost=min_cost, second=maps[0], prev=maps[1], next=maps[2],
                right_disp=maps[3], lr_valid=lr_valid, window=s.window, dmin=s.dmin,
                p1=p1, p2=p2, cmax=cmax, never=never, y0=0, y1=0, band_y0=0, x0=0, x1=width,
                direction=1, add=0, extras=2 if seconds else int(s.extras),
                keep_right=int(s.right_map),
                lr_limit=s.lr_check, keyed=int(keyed_range() > 0), starts=starts,
                tile_rows=TILE_ROWS, fused=0, slots=slots_searched,
                pad_cost=pad_cost(cmax, p1, p2))
    right_width = width + shift
    work_per_row = width * ndisp * 8

    def one_thread(y0, y1):
        """Whether a band's steps run in one thread (each is then fused with a vertical
        path, kernels/jit/sgm.py)."""
        return n_threads == 1 or (y1 - y0) * work_per_row < STEP_DIRECT_WORK

    def rows_step(step, y0, y1, scratch, **path):
        """A step over the band's rows y0..y1, its rows split between the threads; or
        given the vertical ``path`` up (its state and mins), in one thread, fused with
        that path."""
        count = 1 if path else min(n_threads, y1 - y0)
        work = (y1 - y0) * work_per_row
        if work < STEP_DIRECT_WORK:
            count = 1
        edges = y0 + runtime.even_split(y1 - y0, count)

        def stripe(i, stop):
            return run(**dict(base, **scratch(), **path, fused=int(bool(path)), step=step,
                              y0=int(edges[i]), y1=int(edges[i + 1]), band_y0=y0,
                              stop=stop))

        runtime.run_stripes(stripe, count, count, work, STEP_DIRECT_WORK)

    def costs_and_down(y0, y1, add, then_up=False):
        """The band's costs and the vertical path down through them (add: as vertical's),
        fused, the band's columns split between the threads (each column's path is its
        own; each thread sums w - 1 columns more); then_up: each block's path up next, in
        the same task, so that the threads need not meet in between (a hand-off saved;
        the block's slabs are too big to be still in the caches)."""
        count = 1 if one_thread(y0, y1) else min(n_threads, width)
        edges = runtime.even_split(width, count)

        def stripe(i, stop):
            x0, x1 = int(edges[i]), int(edges[i + 1])
            scratch = cost_scratch()
            status = run(**dict(base, **scratch, state=down, mins=down_mins, add=add,
                                step=COSTS, y0=y0, y1=y1, band_y0=y0, x0=x0, x1=x1,
                                stop=stop))
            if then_up:
                status = run(**dict(base, moved=scratch["moved"], state=up, mins=up_mins,
                                    step=VERTICAL, y0=y0, y1=y1, band_y0=y0, x0=x0, x1=x1,
                                    direction=-1, add=1, stop=stop))
            return status

        runtime.run_stripes(stripe, count, count, (y1 - y0) * work_per_row,
                            STEP_DIRECT_WORK)

    def both_diagonals(y0, y1):
        """The band's four diagonal paths (8 paths), adding into its sums."""
        diagonal(y0, y1, ((down_l, down_l_mins), (down_r, down_r_mins)), 1, 1)
        diagonal(y0, y1, ((up_l, up_l_mins), (up_r, up_r_mins)), -1, 1)

    def up_and_select(y0, y1, before_select=None):
        """The rows' paths and winners, the vertical path up made first (with the costs,
        in threads; see costs_and_down) or with the rows (in one thread);
        before_select(y0, y1): what else must add into the sums first."""
        fused = one_thread(y0, y1)
        if before_select is not None:
            before_select(y0, y1)
        if fused:
            rows_step(SELECT, y0, y1, select_scratch, state=up, mins=up_mins)
        else:
            rows_step(SELECT, y0, y1, select_scratch)

    def in_halves(y0, y1):
        """Whether a band's rows are cut into halves, one for each of two threads,
        rather than split step by step (see above): with 4 paths on two threads.  On
        more, the steps stay split between all of them: the halves' winners would keep
        two busy and leave the others idle (not measured: the hosts here have two
        cores)."""
        return not diagonals and n_threads == 2 and y1 - y0 >= 2 and width >= 2 and \
            not one_thread(y0, y1)

    def halves(y0, y1):
        """The band's costs, vertical paths and winners in two halves (see above):
        the top one's paths go down first and up second, the bottom one's the other
        way, each vertical step fused with the costs or the winners."""
        mid = (y0 + y1) // 2
        work = (y1 - y0) * work_per_row
        # (rows, the vertical path made with the costs, and with the winners)
        top = (y0, mid, (down, down_mins), (up, up_mins))
        bottom = (mid, y1, (up, up_mins), (down, down_mins))

        edges = runtime.even_split(width, 2)

        def costs_block(i, stop):
            # Each thread a block of columns of both halves, as costs_and_down: a
            # block's column sums, ring and path state stay in the caches where a whole
            # row's did not (a whole-range KITTI band's costs took 27% longer).
            x0, x1 = int(edges[i]), int(edges[i + 1])
            scratch = cost_scratch()
            status = 0
            for j, (a, b, (state, mins), _) in enumerate((top, bottom)):
                status = run(**dict(base, **scratch, state=state, mins=mins, add=0,
                                    step=COSTS, y0=a, y1=b, band_y0=y0, x0=x0, x1=x1,
                                    direction=1 if j == 0 else -1, stop=stop))
            return status

        def select_half(i, stop):
            a, b, _, (state, mins) = (top, bottom)[i]
            return run(**dict(base, **select_scratch(), state=state, mins=mins,
                              fused=1 if i == 0 else 2, step=SELECT, y0=a, y1=b,
                              band_y0=y0, stop=stop))

        runtime.run_stripes(costs_block, 2, 2, work, STEP_DIRECT_WORK)
        runtime.run_stripes(select_half, 2, 2, work, STEP_DIRECT_WORK)

    def cost_scratch():
        # Hamming costs' ring of the window's rows (kernels/jit/sgm.py): w x Wp x D bytes;
        # a banded match's column sums and ring are indexed by the whole range's d, each
        # column's span of them used.
        full = whole if banded else ndisp
        ring = (s.window, left_p.shape[1], full) if s.cost == SHD and s.window > 1 \
            else (1, 1, 1)
        return dict(col_sums=np.empty((left_p.shape[1], full), acc),
                    row_sums=np.empty(full, acc), ring=np.empty(ring, np.uint8),
                    row_costs=np.empty((width, full) if banded and s.window == 1 else (1, 1),
                                       costs.dtype),
                    spans=np.empty((2, left_p.shape[1]), np.int32), moved=moved_row())

    def moved_row():
        """A step's scratch for moving a banded path's state to its pixel's slots
        (kernels/jit/sgm.py, meet), one per thread; a whole-range step's is never used
        (base's)."""
        return np.empty(ndisp + 2 if banded else 1, acc)

    def select_scratch():
        line = np.full((2, ndisp + 2), big, acc)
        return dict(line=line, moved=moved_row(), right_best=np.empty(right_width, acc),
                    right_d=np.empty(right_width, np.int16))

    def diagonal(y0, y1, pair, direction, add):
        (state, mins), (other, other_mins) = pair
        runtime.run_stripes(
            lambda i, stop: run(**dict(base, moved=moved_row(), state=state, mins=mins,
                                       other=other, other_mins=other_mins, step=DIAGONAL,
                                       y0=y0, y1=y1, band_y0=y0, direction=direction,
                                       add=add, stop=stop)),
            1, 1, 0)

    def two_passes(bands):
        """Pass 1 down, keeping the down paths' states where each band starts; pass 2
        up, each band's paths and winners (see above)."""
        kept = {}  # band start -> the down paths' states entering the band
        for y0, y1 in bands[:-1]:  # pass 1
            costs_and_down(y0, y1, 2)
            if diagonals:
                diagonal(y0, y1, ((down_l, down_l_mins), (down_r, down_r_mins)), 1, 2)
            kept[y1] = [a[0].copy() for a in ((down, down_mins) + (
                (down_l, down_l_mins, down_r, down_r_mins) if diagonals else ()))]
        for y0, y1 in reversed(bands):  # pass 2
            if y0 in kept:
                states = (down, down_mins) + ((down_l, down_l_mins, down_r, down_r_mins)
                                              if diagonals else ())
                for array, saved in zip(states, kept.pop(y0), strict=True):
                    array[0] = saved
            elif y0 > 0:
                raise AssertionError("a band's down state was not kept")
            else:
                for array in (down, down_mins) + ((down_l, down_l_mins, down_r, down_r_mins)
                                                  if diagonals else ()):
                    _reset(array)
            if in_halves(y0, y1):
                halves(y0, y1)
                continue
            costs_and_down(y0, y1, 0, then_up=not one_thread(y0, y1))
            up_and_select(y0, y1, both_diagonals if diagonals else None)

    if single_pass:  # the states go down from band to band
        for y0, y1 in bands:
            costs_and_down(y0, y1, 0)
            diagonal(y0, y1, ((down_l, down_l_mins), (down_r, down_r_mins)), 1, 1)
            rows_step(SELECT, y0, y1, select_scratch)
    else:
        two_passes(bands)
    if rows.size != height:  # the rows asked for, of the paths through every row
        disp, min_cost = disp[rows], min_cost[rows]
        *maps, lr_valid = (m[rows] if m.shape[0] == height else m for m in (*maps, lr_valid))
    plain = candidate_count(width, s.dmin, s.dmax) * rows.size
    searched = min(plain, rows.size * width * ndisp) if banded else plain
    return result(disp, min_cost, searched, plain, s, maps,
                  lr_valid.view(np.bool_) if checked else None, second)


def pad_cost(cmax, p1, p2):
    """The cost of a whole-range pass's slots past its candidates (kernels/jit/sgm.py
    shows that they change nothing)."""
    return cmax + 2 * p2 - p1


def padded_depth(ndisp, cmax, p1, p2, costs_dtype):
    """The d axis of a whole-range pass of ``ndisp`` disparities: rounded up to whole
    vectors of LANES where more than a quarter of a vector is left over and pad_cost
    fits the cost slab's type (every path value then fits the accumulator too: 4
    paths' sums of cmax + P2 do), else ndisp.  At half KITTI's size on one thread: 54
    and 60 disparities took 15.8 and 14.9 ms, padded to 64, 12.5 and 12.4; 97 and 100
    took 17.3 and 17.0, padded to 112, 18.4: a few left over cost less than a vector."""
    left_over = ndisp % LANES
    if ndisp < LANES or left_over <= LANES // 4 or \
            pad_cost(cmax, p1, p2) > np.iinfo(costs_dtype).max:
        return ndisp
    return ndisp + LANES - left_over


def _reset(array):
    """A path state (or its minima) as at a path's start: zeros between the sentinels."""
    if array.ndim == 3:
        array[0, :, 1:array.shape[2] - 1] = 0
    else:
        array[0] = 0

"""The fast engine: running sums, O(1) work per (pixel, disparity) whatever the window.

It computes the same contract as the window engine, bit for bit (integer sums are
exact, and the scan order and tie rule are the same), after OpenCV's stereobm.cpp: the
column sums of each disparity move down the rows, a row sum per disparity moves along the
row (kernels/jit/fast.py has the formulas).

Layout: the disparity index k is the innermost (contiguous) axis everywhere, and the right
image is stored with its columns reversed, so that R[y, j - d] for k = 0, 1, ... is a
forward, contiguous read and the loops over k vectorise.

Accumulator width is a decision: the narrowest unsigned/signed type that holds the
largest possible window cost (kernels/costs.py, ``accumulator_dtype``). Unsigned 16-bit
sums wrap on the way, but wrap-around arithmetic is exact modulo 2**16, and every true value fits.

Layers:
  match_fast      public: validate, pad, reverse, pick the accumulator and the variant,
                  allocate the maps
  the driver      stripes of rows in parallel threads, each allocating its own column
                  sums, row sums and B-map (kernels/runtime.py)
  jit/fast.py     the per-stripe and per-row workers, compiled once per variant
"""

import functools

import numpy as np

from . import native, runtime, store
from .catalogue import entry
from .census import CensusCall, census_transform, fits_one_stripe
from .contract import (
    CENSUS,
    SHD,
    candidate_count,
    census_dtype,
    invalid,
    pad_edge,
    validate,
)
from .costs import accumulator_dtype
from .pad import Padder
from .window import extra_maps, result
from .workspace import empty, output

# How a pixel picks its least cost with 16-bit sums (kernels/jit/fast.py, select_row):
# packed keys, sum << 16 | k, whose minimum is the least sum at its smallest k, in one
# pass of 32-bit lanes; or two passes of 16-bit lanes, the minimum and then its first
# index.  Which is faster depends on the CPU.  Where 256-bit vectors run whole, keys won
# at up to 128 disparities (census cones, d 0..127, with the right map: 10.3 ms against
# 11.5; level at 256).  Where a CPU splits each 256-bit operation into two 128-bit
# halves (LLVM's names below: AMD's Zen 1, Jaguar and Bulldozer lines), twice the lanes
# cost twice the time and two passes of narrow lanes won at every range (Zen 1, with
# the right map: 10.2 ms against 13.4 at 640 wide, d 0..63; 23 against 32 at 1242
# wide, d 0..127; default preset at 640x480, d 0..63, 1.58x StereoBM's time -> 1.46x).
KEYED_RANGE = 128
SPLIT_256_CPUS = frozenset({"znver1", "btver2", "bdver1", "bdver2", "bdver3", "bdver4"})


@functools.cache
def keyed_range():
    """The largest disparity range whose minimum uses packed keys on the CPU the kernels
    are compiled for (0: none).  Both ways are compiled in every variant, so this is a
    scalar of the call."""
    return 0 if store.target_cpu() in SPLIT_256_CPUS else KEYED_RANGE


def stripe_bounds(height, window, threads, rows):
    """int64 (n, 2) [start, end) rows of the stripes covering ``rows`` (ascending).

    Starting a stripe costs w rows of column sums, so each run of consecutive rows is cut
    into stripes as few and tall as load balance allows: one for one thread; otherwise up
    to 4 per thread, each at least 16 windows tall.  A sample of scattered rows (as for
    tau auto) gets one single-row stripe per row, so its cost follows the sample's size;
    a band's core rows (csw.scale.tiled) are one run.
    """
    if rows.size == 0:
        return np.zeros((0, 2), np.int64)
    if threads == 1 and rows[-1] - rows[0] + 1 == rows.size:  # one run, one thread
        return np.array([[rows[0], rows[-1] + 1]], np.int64)
    breaks = np.flatnonzero(np.diff(rows) != 1) + 1
    starts = rows[np.r_[0, breaks]]
    ends = rows[np.r_[breaks - 1, rows.size - 1]] + 1
    stripes = []
    for start, end in zip(starts, ends, strict=True):
        run = int(end - start)
        per_thread = 1 if threads == 1 else max(1, min(4, run // (threads * 16 * window)))
        count = max(1, min(threads * per_thread, run))
        edges = start + runtime.even_split(run, count)
        stripes.append(np.stack([edges[:-1], edges[1:]], axis=1))
    return np.concatenate(stripes).astype(np.int64)


def match_fast(left, right, *, window, dmin, dmax, cost, csw=False, tau=-1,
               rule="literal", csw_margin=None, slack=None, rows=None, threads=None,
               census_window=None, census_pattern=None,
               extras=False, right_map=False, lr_check=None, workspace=None, into=None):
    """Match a rectified pair with running sums (same contract as match_window).

    left, right: uint8 or uint16 (H, W), same shape and dtype; left is the reference.
    rows: optional ascending row indices; the maps are then (n, W) for those rows.
    lr_check: the left-right check is made at the end of each row, from the right
        image's best matches as they stand then, so the right map is never stored
        unless ``right_map`` asks for it.
    workspace: a kernels.workspace.Workspace for the scratch (the padded images or
        census codes, the right map when it is not returned), borrowed for this call.
    into: arrays the caller owns to write outputs into rather than fresh ones:
        "disparity" int32 (n, W), "lr_valid" uint8 (n, W) (kernels.workspace.output).
    Other options as for match_window.
    Returns a MatchResult: disparity int32 (H, W), min_cost int64 (H, W).
    """
    options = dict(window=window, dmin=dmin, dmax=dmax, cost=cost, csw=csw, tau=tau,
                   rule=rule, csw_margin=csw_margin, slack=slack,
                   census_window=census_window, census_pattern=census_pattern,
                   extras=extras, right_map=right_map, lr_check=lr_check)
    if rows is None and workspace is not None and workspace.keeps_calls(np.size(left)):
        # a call bound by this thread's last match
        key = (np.shape(left), np.asarray(left).dtype, np.shape(right),
               np.asarray(right).dtype, *options.values())
        if len(key[0]) == 2 and FastCall.fits(key[0], key[1], options):
            call = workspace.kept_or_made("fast-call", key,
                                          lambda: FastCall(key[0], key[1], **options))
            return call(left, right, into)
    left, right, s, rows = validate(left, right, rows=rows, **options)
    height, width = left.shape
    ndisp = _checked_span(s)
    n_threads = runtime.thread_count(threads)
    h = s.window // 2
    shift = max(0, -s.dmin)  # a negative range reaches right pixels beyond the image
    shape = (height + 2 * h, width + 2 * h)
    if s.cost == CENSUS:  # the codes, written padded (and reversed) by the transform
        codes = census_dtype(census_window, census_pattern)
        left_p = census_transform(left, census_window, threads, pad=h,
                                  out=empty(workspace, "padded-left", shape, codes),
                                  pattern=census_pattern, workspace=workspace)
        right_rev = census_transform(right, census_window, threads, pad=h, reverse=True,
                                     out=empty(workspace, "padded-right", shape, codes),
                                     pattern=census_pattern, workspace=workspace)
        s = s._replace(cost=SHD)
    else:  # padding the reversed image is reversing the padded one
        left_p = pad_edge(left, h, left.dtype,
                          out=empty(workspace, "padded-left", shape, left.dtype))
        right_rev = pad_edge(right[:, ::-1], h, right.dtype,
                             out=empty(workspace, "padded-right", shape, right.dtype))
    if shift:  # the right image padded `shift` columns more beyond its right edge
        right_rev = np.ascontiguousarray(np.pad(right_rev, ((0, 0), (shift, 0)), mode="edge"))
    run = native.entry(*entry("fast", s.cost, left_p.dtype, s.window, s.csw, s.right_costs,
                              s.extras, s.dmin))
    disp = output(into, "disparity", (height, width), np.int32)
    min_cost = np.empty((height, width), np.int64)
    maps = extra_maps(disp.shape, s, workspace)
    checked = s.lr_check >= 0
    lr_valid = output(into, "lr_valid", (height, width), np.uint8) if checked else \
        np.empty((1, width), np.uint8)  # a dummy the workers never write
    evaluated = np.zeros(height, np.int64)
    work = rows.size * width * ndisp
    if work < runtime.DIRECT_WORK:
        n_threads = 1
    stripes = stripe_bounds(height, s.window, n_threads, rows)

    def stripe(i, stop):
        y0, y1 = stripes[i]
        return run(**_arguments(left_p, right_rev, disp, min_cost, maps, lr_valid, evaluated,
                                s, stop, y0, y1))

    runtime.run_stripes(stripe, len(stripes), n_threads, work)
    if rows.size != height:  # only the sampled rows were computed
        disp, min_cost = disp[rows], min_cost[rows]
        *maps, lr_valid = (m[rows] if m.shape[0] == height else m for m in (*maps, lr_valid))
    plain = candidate_count(width, s.dmin, s.dmax) * rows.size
    return result(disp, min_cost, int(evaluated[rows].sum()), plain, s, maps,
                  lr_valid.view(np.bool_) if checked else None)


def _checked_span(s):
    """The disparities searched, dmin..dmax; ValueError beyond the engine's int16 index."""
    ndisp = s.dmax - s.dmin + 1
    if ndisp > np.iinfo(np.int16).max:
        raise ValueError("the fast engine searches at most 32767 disparities at once; "
                         "narrow dmin..dmax or use the window engine")
    return ndisp


def _arguments(left_p, right_rev, disp, min_cost, maps, lr_valid, evaluated, s, stop, y0, y1):
    """The worker's arguments for the stripe of rows y0..y1 (ascending row indices into
    the maps' rows), its scratch made here, in the stripe's own thread."""
    acc = accumulator_dtype(left_p.dtype, s.cost, s.window)
    ndisp = s.dmax - s.dmin + 1
    right_width = disp.shape[1] + max(0, -s.dmin)
    second, prev, nxt, right_disp = maps
    # Hamming costs' ring of the window's rows (kernels/jit/fast.py): w x Wp x D bytes
    ring = (s.window, left_p.shape[1], ndisp) if s.cost == SHD else (1, 1, 1)
    return dict(left_p=left_p, right_rev=right_rev,
                col_sums=np.empty((left_p.shape[1], ndisp), acc),
                row_sums=np.empty(ndisp, acc), claims=np.empty(right_width, np.int32),
                right_best=np.empty(right_width, acc),
                right_d=np.empty(right_width, np.int16),
                disp=disp, min_cost=min_cost, second=second, prev=prev, next=nxt,
                right_disp=right_disp, lr_valid=lr_valid, evaluated=evaluated, stop=stop,
                ring=np.empty(ring, np.uint8), window=s.window, dmin=s.dmin, dmax=s.dmax,
                tau=s.tau, rule=s.rule,
                csw_margin=s.csw_margin, slack=s.slack, y0=y0, y1=y1,
                never=_never(acc), keep_right=s.right_map, lr_limit=s.lr_check,
                keyed_range=keyed_range())


@functools.cache
def _never(acc):
    return int(np.iinfo(acc).max)


class FastCall:
    """match_fast for many pairs of one shape and type, made once: validated, with its
    padded images or census codes, its scratch and its bound entry calls (a stream's
    small frames, whose whole match takes a few milliseconds, paid about a millisecond
    more for doing this on every call).  ``call(left, right, into)`` equals match_fast
    with the same options, bit for bit, in the calling thread as one stripe, on pairs of
    the planned shape and type (H, W).  Only what :meth:`fits` accepts is planned: a
    range from 0 up (no extra right columns), run as one stripe.  match_fast keeps one
    in the workspace it is given, so that a thread's repeated matches use it."""

    def __init__(self, shape, pixels, *, window, dmin, dmax, cost, csw=False, tau=-1,
                 rule="literal", csw_margin=None, slack=None, census_window=None,
                 census_pattern=None, extras=False, right_map=False, lr_check=None):
        options = dict(window=window, dmin=dmin, dmax=dmax, cost=cost, csw=csw, tau=tau,
                       rule=rule, csw_margin=csw_margin, slack=slack,
                       census_window=census_window, census_pattern=census_pattern,
                       extras=extras, right_map=right_map, lr_check=lr_check)
        blank = np.zeros(shape, pixels)
        self.shape, self.pixels = tuple(shape), np.dtype(pixels)
        _, _, s, _ = validate(blank, blank, **options)
        _checked_span(s)
        height, width = shape
        h = s.window // 2
        padded = (height + 2 * h, width + 2 * h)
        if s.cost == CENSUS:
            self.left = CensusCall(shape, pixels, census_window, census_pattern, pad=h)
            self.right = CensusCall(shape, pixels, census_window, census_pattern, pad=h,
                                    reverse=True)
            left_p, right_rev = self.left.codes, self.right.codes
            s = s._replace(cost=SHD)
        else:  # the padded images, the right one reversed
            left_p, right_rev = np.empty(padded, pixels), np.empty(padded, pixels)
            self.left = Padder(shape, pixels, h, left_p)
            self.right = Padder(shape, pixels, h, right_rev, reverse=True)
        self.s = s
        run = native.entry(*entry("fast", s.cost, left_p.dtype, s.window, s.csw,
                                  s.right_costs, s.extras, s.dmin))
        self.maps = extra_maps(shape, s)  # the 1-row dummies; full maps are fresh per pair
        self.checked = s.lr_check >= 0
        self.lr_dummy = np.empty((1, width), np.uint8)
        self.evaluated = np.zeros(height, np.int64)
        self.plain = candidate_count(width, s.dmin, s.dmax) * height
        outputs = (np.empty(shape, np.int32), np.empty(shape, np.int64))
        lr_valid = np.empty(shape, np.uint8) if self.checked else self.lr_dummy
        self.call = run.bind(**_arguments(left_p, right_rev, *outputs, self.maps, lr_valid,
                                          self.evaluated, s, runtime.new_stop_flag(), 0,
                                          height))

    @staticmethod
    def fits(shape, pixels, options):
        """Whether match_fast with these options on pairs of ``shape`` (H, W) can be
        planned: a range from 0 up, matched (and its census codes made) as one stripe.
        Options it can't read are not planned: match_fast's checks then say what is
        wrong with them."""
        try:
            dmin, dmax = int(options["dmin"]), int(options["dmax"])
            if pixels not in (np.uint8, np.uint16) or not 0 <= dmin <= dmax or \
                    min(shape) < 1 or shape[0] * shape[1] * (dmax - dmin + 1) >= \
                    runtime.DIRECT_WORK:
                return False
            return options["cost"] != "census" or fits_one_stripe(
                shape, options.get("census_window"), options.get("census_pattern"))
        except (TypeError, ValueError, KeyError):
            return False

    def __call__(self, left, right, into=None):
        if np.shape(left) != self.shape or np.shape(right) != self.shape or \
                np.asarray(left).dtype != self.pixels or np.asarray(right).dtype != self.pixels:
            raise ValueError(f"this call matches {self.pixels} pairs of {self.shape}")
        s, call = self.s, self.call
        self.left(left)  # the census codes or the padded image, written in place
        self.right(right)
        disp = output(into, "disparity", self.shape, np.int32)
        min_cost = np.empty(self.shape, np.int64)
        call.point("disp", disp)
        call.point("min_cost", min_cost)
        lr_valid = None
        if self.checked:
            lr_valid = output(into, "lr_valid", self.shape, np.uint8)
            call.point("lr_valid", lr_valid)
        maps = self.maps
        if s.extras or s.right_map:  # outputs: fresh for each pair
            maps = extra_maps(self.shape, s)
            for name, array in zip(("second", "prev", "next", "right_disp"), maps, strict=True):
                call.point(name, array)
        else:
            maps[3].fill(invalid(s.dmin))
        call()
        return result(disp, min_cost, int(self.evaluated.sum()), self.plain, s, maps,
                      None if lr_valid is None else lr_valid.view(np.bool_))

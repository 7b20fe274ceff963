"""The window engine: the paper's method, a full w x w cost sum for every candidate.

Because every candidate costs a full window sum, the candidates that CSW skips are real
work saved; this is the engine that reproduces the paper's timings.

Layers (as in stumpy's stump.py):
  match_window      public: validate, pad, allocate, pick the variant and thread count
  the driver        stripes of rows in parallel threads, each with its own B-map and
                    cost scratch (kernels/runtime.py)
  jit/window.py     the per-stripe and per-row workers, compiled once per variant
"""

from functools import partial

import numpy as np

from . import native, runtime
from .catalogue import entry, padded_type
from .census import compared
from .contract import (
    MatchResult,
    candidate_count,
    invalid,
    pad_edge,
    validate,
)
from .filters import lr_consistent
from .workspace import empty, output


def extra_maps(shape, s, workspace=None, right=None, second=True, written=False):
    """(second, prev, next, right) outputs: full maps where asked for (s.extras for the
    first three, the first only with ``second``; for the last, ``right``, by default
    s.right_map), else 1-row dummies the workers never write (the entries take arrays of
    the right type either way).  The right map, when only the left-right check uses it,
    is the workspace's scratch (see match_fast); a returned one is fresh.  The first
    three hold -1 (none) until the worker writes them, unless ``written`` says that it
    writes every pixel of them (semi-global matching: filling 2 x 3.7 MB took 0.3 ms
    of a KITTI frame's match)."""
    rows = shape[0] if s.extras else 1
    make = np.empty if written else partial(np.full, fill_value=-1)
    costs = tuple(make((rows if second or i else 1, shape[1]), dtype=np.int64)
                  for i in range(3))
    stored = s.right_map if right is None else right
    right_shape = (shape[0] if stored else 1, shape[1])
    right_map = np.empty(right_shape, np.int32) if s.right_map else \
        empty(workspace, "right-disparity", right_shape, np.int32)
    right_map.fill(invalid(s.dmin))
    return (*costs, right_map)


def result(disp, min_cost, evaluated, plain, s, maps, lr_valid=None, second=True):
    """The MatchResult, with the extra maps only where they were computed (the second
    best with extras and ``second``)."""
    costs = (maps[0] if second else None, *maps[1:3]) if s.extras else (None,) * 3
    return MatchResult(disp, min_cost, evaluated, plain, *costs,
                       maps[3] if s.right_map else None, lr_valid)


def match_window(left, right, *, window, dmin, dmax, cost, csw=False, tau=-1,
                 rule="literal", csw_margin=None, slack=None, rows=None, threads=None,
                 census_window=None,
                 census_pattern=None, extras=False, right_map=False,
                 lr_check=None, workspace=None, into=None):
    """Match a rectified pair with full window sums (the contract: docs/engines.md).

    left, right: uint8 or uint16 (H, W), same shape and dtype; left is the reference.
    cost: "sad", "ssd", "shd" or "census" (census codes of a census_window x
        census_window window and a census_pattern, "dense" or "sparse", compared with
        SHD; see kernels/census.py).
    rule, csw_margin: the CSW rule ("literal" or "unique") and the unique rule's margin
        in percent (see docs/engines.md, "CSW rules").  slack: override the rule's binding
        (a claim by x' blocks x only when x - x' > slack); for studies of the rule.
    rows: optional int64 (n,) ascending row indices; then the maps are (n, W).
    extras: also return the second-best and neighbour costs; right_map: the right image's
        map from the same costs; lr_check: a limit N for the left-right check on the two
        maps (see MatchResult).
    workspace: a kernels.workspace.Workspace for the right map when only the check uses
        it (scratch, borrowed for this call).
    into: arrays the caller owns for the outputs, as for match_fast.
    Returns a MatchResult: disparity int32 (H, W), min_cost int64 (H, W).
    Raises ValueError, with a message that says how to fix it, on bad input.
    """
    left, right, s, rows = validate(left, right, window=window, dmin=dmin, dmax=dmax,
                                    cost=cost, csw=csw, tau=tau, rule=rule,
                                    csw_margin=csw_margin, slack=slack, rows=rows,
                                    census_window=census_window,
                                    census_pattern=census_pattern, extras=extras,
                                    right_map=right_map, lr_check=lr_check)
    n_threads = runtime.thread_count(threads)
    left, right, s = compared(left, right, s, census_window, threads,
                              pattern=census_pattern)
    h = s.window // 2
    dtype = padded_type(left.dtype)
    left_p, right_p = pad_edge(left, h, dtype), pad_edge(right, h, dtype)
    run = native.entry(*entry("window", s.cost, left.dtype, s.window, s.csw, s.right_costs,
                              s.extras, s.dmin))
    width = left.shape[1]
    ndisp = s.dmax - s.dmin + 1
    disp = output(into, "disparity", (rows.size, width), np.int32)
    min_cost = np.empty((rows.size, width), np.int64)
    maps = extra_maps(disp.shape, s, workspace, right=s.right_costs)
    evaluated = np.zeros(rows.size, np.int64)
    work = rows.size * width * ndisp * s.window ** 2
    if work < runtime.DIRECT_WORK:
        n_threads = 1
    # Rows cost alike: a few stripes per thread balance the load.
    count = max(1, min(rows.size, n_threads * 4 if n_threads > 1 else 1))
    edges = runtime.even_split(rows.size, count)

    second, prev, nxt, right_disp = maps

    def stripe(i, stop):
        # Each stripe owns its scratch, allocated in its own thread.
        return run(left_p=left_p, right_p=right_p, rows=rows,
                   claims=np.empty(width, np.int32), costs=np.empty(ndisp, np.int64),
                   right_best=np.empty(width, np.int64), disp=disp, min_cost=min_cost,
                   second=second, prev=prev, next=nxt, right_disp=right_disp,
                   evaluated=evaluated, stop=stop, window=s.window, dmin=s.dmin,
                   dmax=s.dmax, tau=s.tau, rule=s.rule, csw_margin=s.csw_margin,
                   slack=s.slack, i0=edges[i], i1=edges[i + 1])

    runtime.run_stripes(stripe, count, n_threads, work)
    plain = candidate_count(width, s.dmin, s.dmax) * rows.size
    lr_valid = None
    if s.lr_check >= 0:  # the paper's engine: a pass of its own over the two maps
        lr_valid = lr_consistent(disp, maps[3], s.lr_check, invalid(s.dmin), threads,
                                 out=output(into, "lr_valid", disp.shape, np.uint8))
    return result(disp, min_cost, int(evaluated.sum()), plain, s, maps, lr_valid)

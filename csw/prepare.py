"""What every match does before its first row, in one place, for whole images
(csw.whole) and row stripes (csw.tiled) alike: resolve the options, check the pair once
with the kernels' own rules, compile (or load) the kernels, and resolve tau.
"""

import time
from dataclasses import dataclass

import numpy as np

from . import kernels, params
from .pipeline import run as run_pipeline
from .tau import resolve_tau, sample_rows


@dataclass
class Prepared:
    """A match ready to run.

    opts: the resolved options (csw.params.resolve).  stages: the pipeline's stage
    options.  args: the kernels' arguments, with csw and the resolved tau.  settings:
    opts with tau resolved to a number (-1 when CSW is off), ``tau_source`` and the
    uniqueness margin used.  compile_seconds: the JIT compile or cache load.  plan: what
    ``make_plan`` returned, if given.
    """

    opts: dict
    stages: dict
    args: dict
    settings: dict
    compile_seconds: float
    plan: object = None


def prepare(opts, shape, dtype, right=None, sample_min_cost=None, make_plan=None):
    """Prepare a match of a pair of ``shape`` (H, W) and ``dtype``.

    opts: the resolved options (csw.params.resolve: the callers resolve them before
    reading any pixel, so a bad option fails first).  right: (shape, dtype)
    of the right image, checked against the left's.  sample_min_cost(args, stages, rows):
    plain matching's min-cost rows (int64 (n, W)) for the rows tau auto samples
    (csw.tau.sample_rows), matched with ``stages``; called only when tau resolves to auto.
    make_plan(): how the match will run (csw.tiled's stripes), made once the pair is
    checked and before anything compiles; its result is ``Prepared.plan``.
    Raises ValueError, saying how to fix it, on any bad option or pair.
    """
    if right is not None:
        kernels.contract.check_pair(shape, dtype, *right)
    height, width = shape
    # The kernels' own checks, once, on a stand-in as wide as the pair and one window
    # tall (their rules on the window, range and cost don't depend on the pixels).
    stand_in = np.zeros((min(height, opts["window"]), width), dtype)
    _, _, setup, _ = kernels.contract.validate(
        stand_in, stand_in, window=opts["window"], dmin=opts["dmin"], dmax=opts["dmax"],
        cost=opts["cost"], csw=False, tau=-1, rule=opts["csw_rule"],
        uniqueness=opts["uniqueness"], census_window=opts["census_window"])
    stages = params.stages(opts)
    layout = make_plan() if make_plan is not None else None
    compile_s = warm_up(opts["engine"], opts["cost"], setup.window, dtype, stages)
    args = params.kernel_args(opts)
    tau, source = -1.0, "off"
    if opts["csw"]:
        # Only the stages that shape the costs: the checks and filters don't change m.
        shaping = dict(params.OFF, **{k: stages[k] for k in
                                      ("prefilter", "prefilter_cap", "census_window")})
        tau, source = resolve_tau(
            opts["tau"], opts["csw_rule"],
            plain_min_cost=lambda: sample_min_cost(args, shaping, sample_rows(height)))
    settings = dict(opts, tau=tau, tau_source=source,
                    uniqueness=kernels.contract.resolve_uniqueness(opts["cost"],
                                                                   opts["uniqueness"]))
    return Prepared(opts, stages, dict(args, csw=opts["csw"], tau=tau), settings, compile_s,
                    layout)


def warm_up(engine, cost, window, dtype=np.uint8, stages=None):
    """Compile (or load from the cache) the kernels that a match with these settings runs,
    on a tiny pair of the same dtype and window (the fast engine's accumulator type
    depends on both, and the census codes' type on the census window); return the
    seconds taken."""
    stages = dict(params.OFF, **(stages or {}))
    side = max(window, 8)
    tiny = np.zeros((side, side + 1), dtype)
    args = dict(engine=engine, window=window, dmin=0, dmax=1, cost=cost)
    start = time.perf_counter()
    for csw in (False, True):
        run_pipeline(tiny, tiny, dict(args, csw=csw, tau=0), stages, confidence=True)
    run_pipeline(tiny, tiny, dict(args, rows=np.array([0])), params.OFF)  # tau auto's sample
    return time.perf_counter() - start

"""What every match does before its first row, in one place, for whole images
(csw.matching.matcher) and row stripes (csw.scale.tiled) alike: check the pair once with
the kernels' own rules, compile (or load) the kernels, and resolve tau.
"""

from dataclasses import dataclass

import numpy as np

from .. import kernels
from ..config import params
from ..config.tau import resolve_tau, sample_rows
from .pipeline import entries


@dataclass
class Prepared:
    """A match ready to run.

    opts: the resolved options (csw.config.params.resolve).  stages: the pipeline's stage
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


def prepare(opts, shape, dtype, right=None, sample_min_cost=None, make_plan=None,
            confidence=False, shrunk=None):
    """Prepare a match of a pair of ``shape`` (H, W) and ``dtype``.

    opts: the resolved options (csw.config.params.resolve: the callers resolve them before
    reading any pixel, so a bad option fails first).
    right: (shape, dtype) of the right image, checked against the left's.
    sample_min_cost(args, stages, rows): plain matching's min-cost rows (int64 (n, W))
        for the rows tau auto samples (csw.config.tau.sample_rows), matched with ``stages``;
        called only when tau resolves to auto.
    make_plan(opts): how the match will run (csw.scale.tiled's stripes), made once the pair is
        checked and its range known, before anything compiles; its result is
        ``Prepared.plan``.
    confidence: the run computes the confidence map (its kernels make the second-best
        costs).
    shrunk(f): the pair shrunk f times (csw.matching.autorange.shrink), for a range "auto".
    Raises ValueError, saying how to fix it, on any bad option or pair.
    """
    if right is not None:
        kernels.contract.check_pair(shape, dtype, *right)
    height, width = shape
    if opts["window"] > min(height, width):  # said of the pair, not of a stand-in
        raise params.OptionError("window", f"window {opts['window']} is larger than the "
                                           f"image ({width}x{height}); use a smaller window")
    for bound in ("dmin", "dmax"):
        if opts[bound] != "auto" and opts[bound] >= width:
            raise params.OptionError(bound, f"{bound} ({opts[bound]}) must be less than the "
                                            f"image width ({width}); lower {bound}")
    if opts["cost"] == "census":  # before any work: a census too wide for 64 bits
        try:
            kernels.contract.census_dtype(opts["census_window"], opts["census_pattern"])
        except ValueError as exc:
            raise params.OptionError("census_window", str(exc)) from None
    range_source = opts.get("range_source", "given")
    if "auto" in (opts["dmin"], opts["dmax"]):
        from .autorange import estimate, factor

        f = factor(width)
        low, high = estimate(*shrunk(f), f, width,
                             None if opts["dmin"] == "auto" else opts["dmin"],
                             None if opts["dmax"] == "auto" else opts["dmax"],
                             opts["threads"])
        opts = dict(opts, dmin=low, dmax=high)
        range_source = "auto"
    # The kernels' own checks, once, on a stand-in as wide as the pair and one window
    # tall (their rules on the window, range and cost don't depend on the pixels).
    stand_in = np.zeros((min(height, opts["window"]), width), dtype)
    kernels.contract.validate(
        stand_in, stand_in, window=opts["window"], dmin=opts["dmin"], dmax=opts["dmax"],
        cost=opts["cost"], csw=False, tau=-1, rule=opts["csw_rule"],
        uniqueness=opts["uniqueness"], census_window=opts["census_window"],
        census_pattern=opts["census_pattern"])
    stages = params.stages(opts)
    layout = make_plan(opts) if make_plan is not None else None
    compile_s = load_kernels(opts, stages, dtype, confidence)
    args = params.kernel_args(opts)
    tau, source = -1.0, "off"
    if opts["csw"]:
        shaping = params.cost_stages(stages)
        tau, source = resolve_tau(
            opts["tau"], opts["csw_rule"],
            plain_min_cost=lambda: sample_min_cost(args, shaping, sample_rows(height)))
    settings = dict(opts, tau=tau, tau_source=source, range_source=range_source,
                    uniqueness=kernels.contract.resolve_uniqueness(opts["cost"],
                                                                   opts["uniqueness"]))
    return Prepared(opts, stages, dict(args, csw=opts["csw"], tau=tau), settings, compile_s,
                    layout)


def load_kernels(opts, stages, dtype, confidence=False):
    """Load (compiling once, if need be) every kernel entry a match with these options
    runs, including tau auto's plain sample; return the seconds taken."""
    args = params.kernel_args(opts)
    wanted = entries(dict(args, csw=opts["csw"]), stages, dtype, confidence)
    if opts["csw"]:  # tau's sample: plain matching with the stages that shape the costs
        wanted += entries(dict(args, csw=False), params.cost_stages(stages), dtype)
    return kernels.native.ensure(wanted)


def preset_entries(presets=None):
    """Every kernel entry the presets run, plain and with CSW, for 8- and 16-bit images:
    what ``csw compile`` puts in the cache."""
    wanted = []
    for preset in presets or params.PRESETS:
        for csw in (False, True):
            opts = params.resolve(preset=preset, csw=csw)
            for dtype in (np.uint8, np.uint16):
                args = dict(params.kernel_args(opts), csw=csw)
                stages = params.stages(opts)
                wanted += entries(args, stages, np.dtype(dtype))
                if csw:  # tau auto's plain sample
                    wanted += entries(dict(args, csw=False), params.cost_stages(stages),
                                      np.dtype(dtype))
    return list(dict.fromkeys((k, tuple(v)) for k, v in wanted))


def compile_kernels(presets=None, progress=None):
    """Compile every kernel entry the presets run into the kernel cache (see
    :func:`preset_entries`), so that later runs, here or on a machine that shares the
    cache, load them at once.  progress(key, compiled) is called for each entry.
    Returns (entries compiled, entries already there, seconds)."""
    from ..kernels import native

    wanted = preset_entries(presets)
    before = native.STATS["compiled"]
    native.clear()  # so that entries loaded earlier in this process are counted too
    seconds = native.ensure(wanted, progress, notice=progress is None)
    compiled = native.STATS["compiled"] - before
    return compiled, len(wanted) - compiled, seconds

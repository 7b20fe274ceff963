"""What every match does before its first row, in one place, for whole images
(csw.matching.matcher) and row stripes (csw.scale.tiled) alike: check the pair once
with the kernels' own rules, decide the range, compile (or load) the kernels, and
resolve tau.
"""

from dataclasses import dataclass

import numpy as np

from .. import kernels
from ..config import params
from ..config.params import Config, OptionError
from ..config.tau import resolve_tau, sample_rows
from . import disparity_range
from .pipeline import compared_dtype, entries, penalties
from .stages import cost_shaping


@dataclass
class Prepared:
    """A match ready to run.

    config: the resolved options, the range decided.  args: the kernels' arguments, with
    csw and the resolved tau.  settings: the config as a flat dict, with tau resolved to
    a number (-1 when CSW is off) and ``tau_source``.  compile_seconds: the JIT compile or
    cache load.  plan: what ``make_plan`` returned, if given.  from_pixels: the range
    was found from the pair's pixels (so the set-up is that pair's alone).
    """

    config: Config
    args: dict
    settings: dict
    compile_seconds: float
    plan: object = None
    from_pixels: bool = False


def _said_of(option, check, *args):
    """``check(*args)``, its ValueError an OptionError naming ``option``."""
    try:
        return check(*args)
    except ValueError as exc:
        raise OptionError(option, str(exc)) from None


def set_up(config, shape, dtype, right=None, sample_min_cost=None, make_plan=None,
           confidence=False, shrunk=None, calibration=None):
    """Set up a match of a pair of ``shape`` (H, W) and ``dtype``.

    config: a csw.config.params.Config (the callers resolve it before reading any pixel,
    so a bad option fails first).
    right: (shape, dtype) of the right image, checked against the left's.
    sample_min_cost(args, stages, rows): plain matching's min-cost rows (int64 (n, W))
        for the rows tau auto samples (csw.config.tau.sample_rows), matched with
        ``stages``; called only when tau resolves to auto.
    make_plan(config): how the match will run (csw.scale.tiled's stripes), made once the
        pair is checked and its range known, before anything compiles; its result is
        ``Prepared.plan``.
    confidence: the run computes the confidence map (its kernels make the second-best
        costs).
    shrunk(f): the pair shrunk f times (csw.matching.disparity_range.shrink), for a
        range "auto".
    calibration: the pair's csw.Calibration, whose ndisp sets the range when no dmax
        was given.  The range is decided here, once per pair
        (csw.matching.disparity_range.decide); ``Prepared.from_pixels`` says whether it
        was found from the pair's pixels.
    Raises ValueError, saying how to fix it, on any bad option or pair.  The kernels
    check their arguments once more, on the real pixels, at their entry.
    """
    if right is not None:
        kernels.contract.check_pair(shape, dtype, *right)
    height, width = shape
    _said_of("window", kernels.contract.check_window, config.window, height, width)
    for bound in ("dmin", "dmax"):  # before a range "auto" is searched for
        value = getattr(config, bound)
        if value != "auto" and value >= width:
            raise OptionError(bound, f"{bound} ({value}) must be less than the image width "
                                     f"({width}); lower {bound}")
    stages = config.stages
    if config.cost == "census":  # before any work: a census too wide for 64 bits
        _said_of("census_window", kernels.contract.census_dtype, stages.census_window,
                 stages.census_pattern)
    early_s = 0.0
    if "auto" in disparity_range.known_range(config, width, calibration) and \
            shrunk is not None:
        # The coarse match and the match after it use different kernels: load both at
        # once, so that a first run on an empty cache compiles them together, on every
        # core (the match's, planned with dmin as given, is right unless dmin is auto
        # and comes out below 0: the kernels depend on dmin's sign, not on dmax).
        f = disparity_range.factor(width)
        early_s = kernels.native.ensure(
            config_entries(disparity_range.coarse_config(width // f, f, config),
                           np.dtype(dtype))
            + config_entries(disparity_range.assumed_range(config, width), np.dtype(dtype),
                             confidence))
    looked = []  # shrunk, called: the range was found from these pixels

    def shrunk_noted(f):
        looked.append(f)
        return shrunk(f)

    config = disparity_range.decide(config, width, calibration,
                                    shrunk=shrunk_noted if shrunk is not None else None)
    _said_of("dmin", kernels.contract.check_range, config.dmin, config.dmax, width)
    layout = make_plan(config) if make_plan is not None else None
    compile_s = early_s + load_kernels(config, dtype, confidence)
    args = config.kernel_args()
    tau, source = -1.0, "off"
    if config.csw:
        tau, source = resolve_tau(
            config.tau, config.csw_rule,
            plain_min_cost=lambda: sample_min_cost(args, cost_shaping(stages),
                                                   sample_rows(height)))
    settings = dict(config.as_dict(), tau=tau, tau_source=source)
    if stages.aggregate == "sgm":  # the penalties the kernels take, defaults resolved
        settings["sgm_p1"], settings["sgm_p2"] = penalties(
            stages, config.cost, config.window, compared_dtype(stages, dtype))
    return Prepared(config, dict(args, csw=config.csw, tau=tau), settings, compile_s, layout,
                    bool(looked))


def load_kernels(config, dtype, confidence=False):
    """Load (compiling once, if need be) every kernel entry a match with ``config`` (its
    range decided) runs, including tau auto's plain sample; return the seconds taken."""
    return kernels.native.ensure(config_entries(config, np.dtype(dtype), confidence))


def config_entries(config, dtype, confidence=False):
    """The kernel entries a match with ``config`` runs on images of ``dtype``."""
    args = config.kernel_args()
    wanted = entries(dict(args, csw=config.csw), config.stages, dtype, confidence)
    if config.csw:  # tau's sample: plain matching with the stages that shape the costs
        wanted += entries(dict(args, csw=False), cost_shaping(config.stages), dtype)
    return wanted


def preset_entries(presets=None):
    """Every kernel entry the presets run, plain and with CSW, for 8- and 16-bit images,
    with the coarse match that finds a range "auto" (every preset's default), and the
    luma of colour pairs: what ``csw compile --preset`` puts in the cache."""
    from .disparity_range import coarse_configs

    wanted = []
    for preset in presets or params.PRESETS:
        aggregated = params.PRESETS[preset].get("aggregate", "none") == "sgm"
        for csw in (False,) if aggregated else (False, True):  # CSW is local matching's
            config = params.resolve(preset=preset, csw=csw)
            for dtype in (np.uint8, np.uint16):
                wanted += config_entries(config, np.dtype(dtype))
    for config in coarse_configs():
        for dtype in (np.uint8, np.uint16):
            wanted += config_entries(config, np.dtype(dtype))
    return list(dict.fromkeys((k, tuple(v)) for k, v in
                              wanted + kernels.catalogue.entries_of("colour")))


def compile_kernels(presets=None, progress=None):
    """Compile into the kernel cache every kernel entry a run can load (the catalogue's,
    csw.kernels.catalogue.every_entry), or only those the ``presets`` run with their
    defaults (:func:`preset_entries`), so that later runs, here or on a machine that
    shares the cache, load them at once.  progress(key, compiled) is called for each
    entry.  Returns (entries compiled, entries already there, seconds)."""
    from ..kernels import native

    wanted = preset_entries(presets) if presets else kernels.catalogue.every_entry()
    before = native.STATS["compiled"]
    native.clear()  # so that entries loaded earlier in this process are counted too
    seconds = native.ensure(wanted, progress, notice=progress is None)
    compiled = native.STATS["compiled"] - before
    return compiled, len(wanted) - compiled, seconds

"""``csw.match``: one rectified pair in, a disparity map and what goes with it out.

This is the function ``csw match`` calls; both read their defaults from
:mod:`csw.defaults`.
"""

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import kernels
from .defaults import MATCH, PRESETS
from .io import read_image, to_gray
from .pipeline import OFF
from .pipeline import run as run_pipeline
from .tau import resolve_tau, sample_rows


@dataclass
class Result:
    """What :func:`match` returns.

    disparity: float32 (H, W), the disparity (subpixel where asked), NaN where invalid (no
        candidate, or refused by a validity stage or filter).
    confidence: float32 (H, W), 0..1: (second - best) / second of the costs, 0 where
        invalid (all 0 unless the second-best costs were computed: see ``match``).
    min_cost:  int64 (H, W), the minimum cost m at the chosen d, -1 where no candidate.
    evaluated: candidates (pixel, d) whose cost was evaluated.
    candidates: candidates plain matching evaluates, so ``work_saved`` is CSW's share.
    settings: every option as used, with ``tau`` resolved to a number (-1 when CSW is
        off) and ``tau_source`` saying where it came from.
    seconds: the match itself; compile_seconds: JIT compile or cache load before it.
    """

    disparity: np.ndarray
    confidence: np.ndarray
    min_cost: np.ndarray
    evaluated: int
    candidates: int
    settings: dict = field(default_factory=dict)
    seconds: float = 0.0
    compile_seconds: float = 0.0

    @property
    def valid(self):
        """bool (H, W): where a disparity was found."""
        return np.isfinite(self.disparity)

    @property
    def work_saved(self):
        """Share (0..1) of plain matching's candidate costs that CSW skipped."""
        return 1.0 - self.evaluated / self.candidates if self.candidates else 0.0

    @property
    def invalid_share(self):
        """Share (0..1) of pixels without a disparity."""
        return float(np.mean(~self.valid)) if self.disparity.size else 0.0


def options(**given):
    """The full option set: ``given`` over the preset over the defaults.  TypeError on an
    unknown name; ValueError for a stage added to the paper preset."""
    unknown = set(given) - set(MATCH)
    if unknown:
        raise TypeError(f"unknown option(s) {', '.join(sorted(unknown))}; "
                        f"csw.match takes {', '.join(MATCH)}")
    preset = given.get("preset", MATCH["preset"])
    if preset not in PRESETS:
        raise ValueError(f"preset must be one of {', '.join(PRESETS)}, got {preset!r}")
    if preset == "paper":
        added = [k for k in OFF if k in given and given[k] != OFF[k]]
        if added:
            raise ValueError(f"the paper preset is the paper's raw method; drop "
                             f"{', '.join(added)} (or use another preset)")
    return {**MATCH, **PRESETS[preset], **given}


def stages(opts):
    """The pipeline's stage options out of a full option set."""
    return {k: opts[k] for k in OFF}


def as_gray(image, name):
    """A path, or a (H, W) / (H, W, 3|4) uint8/uint16 array -> uint8/uint16 (H, W)."""
    if isinstance(image, (str, Path)):
        return read_image(image)
    image = np.asarray(image)
    if image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"{name} image must be uint8 or uint16, got {image.dtype}; change the "
                         "dtype with .astype(np.uint8) or .astype(np.uint16)")
    return to_gray(image, name)


def kernel_args(opts):
    """The kernels' keyword arguments for a resolved option set."""
    return dict(engine=opts["engine"], window=opts["window"], dmin=opts["dmin"],
                dmax=opts["dmax"], cost=opts["cost"], rule=opts["csw_rule"],
                uniqueness=opts["uniqueness"], threads=opts["threads"])


def warm_up(engine, cost, window, dtype=np.uint8, stages=None):
    """Compile (or load from the cache) the kernels that a match with these settings runs,
    on a tiny pair of the same dtype and window (the fast engine's accumulator type
    depends on both, and the census codes' type on the census window); return the
    seconds taken."""
    stages = dict(OFF, **(stages or {}))
    side = max(window, 8)
    tiny = np.zeros((side, side + 1), dtype)
    args = dict(engine=engine, window=window, dmin=0, dmax=1, cost=cost)
    start = time.perf_counter()
    for csw in (False, True):
        run_pipeline(tiny, tiny, dict(args, csw=csw, tau=0), stages, confidence=True)
    run_pipeline(tiny, tiny, dict(args, rows=np.array([0])), OFF)  # tau auto's sample
    return time.perf_counter() - start


def check_tau_use(csw, tau):
    """Refuse a tau that would do nothing: CSW is off."""
    if not csw and tau is not None:
        raise ValueError("tau applies only with CSW on; add csw=True (--csw) or drop tau")


def match(left, right, want_confidence=False, **given):
    """Match a rectified pair; left is the reference.

    Parameters
    ----------
    left, right : path or ndarray
        Image files, or uint8/uint16 arrays (H, W) or (H, W, 3|4); colour is converted to
        gray with the ITU-R 601-2 luma, as ``csw match`` does.
    engine : {"fast", "window"}
        Running sums, or a full window sum per candidate (the paper's method).  Both give
        identical results.
    cost : {"sad", "ssd", "shd"}
    window : int
        Odd window side.
    dmin, dmax : int
        The disparity range searched.
    csw : bool
        Skip right pixels already claimed by a confident match on the row.
    csw_rule : {"literal", "unique"}
    tau : float, "auto" or "none", optional
        CSW's cost threshold; default: auto for the literal rule, none for the unique rule.
    uniqueness : int, optional
        The unique rule's margin in percent (default 12; 25 for SSD).
    threads : int, optional
        Threads (default: all cores).
    preset : {"raw", "paper", "accurate"}
        A named set of the options below and the cost (see :data:`csw.defaults.PRESETS`);
        options given explicitly override it.  "paper" takes no stage.
    prefilter, prefilter_cap, census_window, lr_check, uniqueness_ratio,
    texture_threshold, subpixel, speckle_size, speckle_range, median, fill
        The pipeline's stages (see :mod:`csw.pipeline`).
    want_confidence : bool
        Compute the confidence map even when no stage needs the second-best costs.

    Defaults are those of :data:`csw.defaults.MATCH`.

    Returns
    -------
    Result

    Raises
    ------
    ValueError
        On bad input, with a message that says how to fix it.
    """
    opts = options(**given)
    check_tau_use(opts["csw"], opts["tau"])
    left, right = as_gray(left, "left"), as_gray(right, "right")
    args = kernel_args(opts)
    if opts["engine"] not in kernels.ENGINES:
        raise ValueError(f"engine must be one of {', '.join(kernels.ENGINES)}, "
                         f"got {opts['engine']!r}")
    # Every check of the kernels' entry, once, before the warm-up compiles for these types.
    _, _, setup, _ = kernels.contract.validate(
        left, right, window=opts["window"], dmin=opts["dmin"], dmax=opts["dmax"],
        cost=opts["cost"], csw=False, tau=-1, rule=opts["csw_rule"],
        uniqueness=opts["uniqueness"], census_window=opts["census_window"])
    compile_s = warm_up(opts["engine"], opts["cost"], setup.window, left.dtype, stages(opts))
    tau, source = -1.0, "off"
    if opts["csw"]:
        def sampled_min_cost():
            rows = sample_rows(left.shape[0])
            # Only the stages that shape the costs: filters don't change min_cost.
            shaping = {k: opts[k] for k in ("prefilter", "prefilter_cap", "census_window")}
            return run_pipeline(left, right, dict(args, rows=rows), dict(OFF, **shaping))[2]\
                .min_cost

        tau, source = resolve_tau(opts["tau"], opts["csw_rule"], plain_min_cost=sampled_min_cost)
    start = time.perf_counter()
    disparity, confidence, raw = run_pipeline(left, right, dict(args, csw=opts["csw"], tau=tau),
                                              stages(opts), confidence=want_confidence)
    seconds = time.perf_counter() - start
    settings = dict(opts, tau=tau, tau_source=source,
                    uniqueness=kernels.contract.resolve_uniqueness(opts["cost"],
                                                                   opts["uniqueness"]))
    return Result(disparity, confidence, raw.min_cost, raw.evaluated, raw.candidates,
                  settings, seconds, compile_s)

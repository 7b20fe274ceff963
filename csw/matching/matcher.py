"""``csw.match``: one rectified pair in memory, a disparity map and what goes with it out.

Pairs bigger than memory go through :mod:`csw.scale.tiled`; :func:`csw.matching.files.match_files`
chooses between the two for files.  Both prepare through :mod:`csw.matching.setup`.
"""

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import kernels
from ..config.params import resolve
from ..io.images import read_image, to_gray
from .disparity_range import crowded_end, shrink
from .pipeline import match_rows
from .pipeline import run as run_pipeline
from .setup import load_kernels, set_up


@dataclass
class Result:
    """What :func:`match` returns.

    disparity: float32 (H, W), the disparity (subpixel where asked), NaN where invalid (no
        candidate, or refused by a validity stage or filter).
    confidence: float32 (H, W), 0..1: (second - best) / second of the costs, 0 where
        invalid (unless the second-best costs were computed, see ``match``, a read-only
        map of zeros).
    min_cost:  int64 (H, W), the minimum cost m at the chosen d, -1 where no candidate.
    evaluated: candidates (pixel, d) whose cost was evaluated.
    candidates: candidates plain matching evaluates, so ``work_saved`` is CSW's share.
    settings: every option as used (csw.config.params.Config.as_dict), the range
        decided and ``range_source`` saying where it came from, ``tau`` resolved to a
        number (-1 when CSW is off) and ``tau_source`` saying where it came from.
    seconds: the match itself; compile_seconds: JIT compile or cache load before it.
    notes: lines for the user about the result (the range looks cut short...); the CLI
        prints them on stderr.
    """

    disparity: np.ndarray
    confidence: np.ndarray
    min_cost: np.ndarray
    evaluated: int
    candidates: int
    settings: dict = field(default_factory=dict)
    seconds: float = 0.0
    compile_seconds: float = 0.0
    notes: list = field(default_factory=list)
    stripes = None  # matched whole (csw.scale.tiled's results give their stripe count)

    @property
    def shape(self):
        return self.disparity.shape

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


def as_gray(image, name):
    """A path, or a (H, W) / (H, W, 3|4) uint8/uint16 array -> uint8/uint16 (H, W)."""
    if isinstance(image, (str, Path)):
        return read_image(image)
    image = np.asarray(image)
    if image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"{name} image must be uint8 or uint16, got {image.dtype}; change the "
                         "dtype with .astype(np.uint8) or .astype(np.uint16)")
    return to_gray(image, name)


def match(left, right, want_confidence=False, **options):
    """Match a rectified pair; left is the reference.

    Parameters
    ----------
    left, right : path or ndarray
        Image files, or uint8/uint16 arrays (H, W) or (H, W, 3|4); colour is converted to
        gray with the ITU-R 601-2 luma, as ``csw match`` does.
    preset : {"accurate", "raw", "paper"}
        A named set of the options below (see :data:`csw.config.params.PRESETS`); options given
        explicitly override it.  "paper" takes no stage.
    engine : {"fast", "window"}
        Running sums, or a full window sum per candidate (the paper's method).  Both give
        identical results.
    cost : {"sad", "ssd", "shd", "census"}
        Census compares census codes (of a ``census_window`` square, ``census_pattern``
        dense or sparse) by Hamming distance.
    window : int
        Odd window side.
    dmin, dmax : int
        The disparity range searched.
    csw : bool
        Skip right pixels already claimed by a confident match on the row.
    csw_rule : {"literal", "unique"}
    tau : float, "auto" or "none", optional
        CSW's cost threshold; default: auto for the literal rule, none for the unique rule.
    csw_margin : int, optional
        The unique rule's margin in percent (default 12; 25 for SSD).
    threads : int, optional
        Threads (default: all cores).
    prefilter, prefilter_cap, census_window, census_pattern, lr_check, uniqueness_ratio,
    texture_threshold, subpixel, speckle_size, speckle_range, median, fill
        The pipeline's stages (see :mod:`csw.matching.pipeline`); ``lr_check``,
        ``uniqueness_ratio`` and ``texture_threshold`` take a number or "off" (None).
    want_confidence : bool
        Compute the confidence map even when no stage needs the second-best costs.

    Every option's default, allowed values and help are in :data:`csw.config.params.OPTIONS`.

    ``csw.match(left, right, **options)`` is ``csw.Matcher(**options).match(left,
    right)``: for many pairs with the same options, make the Matcher once.

    Returns
    -------
    Result

    Raises
    ------
    ValueError
        On bad input, with a message that says how to fix it.
    TypeError
        On an unknown option name.
    """
    return Matcher(pixels=None, **options).match(left, right, want_confidence)


class Matcher:
    """A matcher made once and called per pair, as OpenCV's ``StereoBM_create(...)`` and
    ``compute(l, r)``: the options are resolved and checked at construction, and the
    kernels they need loaded (compiled once, if need be), so that a bad option or a
    missing kernel fails now, not at the thousandth pair.

    >>> matcher = csw.Matcher(dmax=64)                      # the same options as csw.match
    >>> result = matcher.match(left, right)                 # a csw.Result, as csw.match's

    pixels: the images' type whose kernels are loaded now (np.uint8 by default; a pair of
    another type loads its own on first use; None: none now).  A range "auto" is found
    from the first pair and kept for the next ones (``settings["range_source"]`` says
    so).  One Matcher may be used from several threads at once: each thread matches
    with scratch of its own (kernels/workspace.py), and the matcher keeps nothing of a
    pair but that first range.
    """

    def __init__(self, pixels=np.uint8, config=None, **options):
        if config is not None and options:
            raise TypeError("give a Matcher its options or a resolved config, not both")
        # TypeError / ValueError now.  config: a csw.config.params.Config resolved
        # already (csw's own callers, which resolve before they read any file).
        self.config = resolve(**options) if config is None else config
        self._found = None  # the config with the range found on the first pair
        if pixels is not None and self.config.range_known:
            load_kernels(self.config, np.dtype(pixels))

    def match(self, left, right, want_confidence=False):
        """Match a rectified pair (paths or arrays, as for :func:`csw.match`); returns a
        :class:`Result`."""
        config = self._found or self.config
        result = _match(config, left, right, want_confidence)
        if self._found is None and not config.range_known:
            s = result.settings
            self._found = config.replace(dmin=s["dmin"], dmax=s["dmax"],
                                         range_source="auto (from the first pair)")
        return result


def _match(config, left, right, want_confidence):
    """One pair with a resolved ``config``."""
    left, right = as_gray(left, "left"), as_gray(right, "right")

    def sample_min_cost(args, stages, rows):
        return match_rows(left, right, dict(args, rows=rows), stages)[2].min_cost

    def shrunk(f):
        return shrink(left, f), shrink(right, f)

    ready = set_up(config, left.shape, left.dtype, right=(right.shape, right.dtype),
                   sample_min_cost=sample_min_cost, confidence=want_confidence,
                   shrunk=shrunk)
    start = time.perf_counter()
    # This thread's workspace: a notebook's or a batch's repeated matches reuse their
    # scratch instead of faulting it in again (kernels/workspace.py).
    disparity, confidence, raw = run_pipeline(left, right, ready.args, ready.config.stages,
                                              confidence=want_confidence,
                                              workspace=kernels.workspace.for_this_thread())
    seconds = time.perf_counter() - start
    if confidence is None:  # not computed: zeros that take no memory (a fresh 4 bytes a
        # pixel per match made glibc return and fault in the heap's top on every call)
        confidence = np.broadcast_to(np.float32(0), disparity.shape)
    note = crowded_end(disparity, ready.settings)
    return Result(disparity, confidence, raw.min_cost, raw.evaluated, raw.candidates,
                  ready.settings, seconds, ready.compile_seconds, [note] if note else [])

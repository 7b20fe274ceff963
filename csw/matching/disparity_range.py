"""The disparity range a match searches, decided in one place (:func:`decide`): as given,
from the calibration's ndisp, the defaults, or found from the pair itself
(``dmax="auto"``, ``dmin="auto"``), with where it came from.

Found from the pair:
The pair is shrunk by box averaging (a power-of-two factor, at least 2, that brings its
width to SMALL_WIDTH or less), the small pair is matched with the accurate pipeline
(census, the left-right check, speckle removal: only confident disparities survive) over
the widest sensible range, keeping distinct matches only, and the robust extremes of
what it found (the LOW and HIGH percentiles) are scaled back with a margin.  It costs a
few percent of the full match.
"""

import math

import numpy as np

from ..config.params import resolve
from .pipeline import run as run_pipeline

# Chosen once, over every registered dataset (tests/library/test_autorange.py): the
# range covers each ground truth's 99th percentile and moves density and bad-2 by under
# half a point against the dataset's own range.
SMALL_WIDTH = 256
LOW, HIGH = 0.5, 99.5  # percentiles of the small pair's confident disparities
MARGIN = 0.08  # of the found extreme, plus PAD small-pair pixels
PAD = 0.25
DISTINCT = 5  # percent: StereoBM's uniqueness ratio, on the small pair
# A map whose valid pixels crowd the range's last disparity is likely cut short: measured
# over the registered datasets, a range 0.6 times too short puts 3 to 35% of the valid
# pixels there (the accurate preset refuses most of the rest), a found range under 0.1%.
CROWDED_END = 0.02


def decide(config, width, calibration=None, shrunk=None):
    """``config`` (csw.config.params.Config) with its range decided for a pair ``width``
    wide, and ``range_source`` saying where it came from:

      given                 dmin or dmax given by the caller (kept as resolved)
      ndisp of FILE         no dmax given: the calibration's ndisp (below the width)
      default               neither, and the preset fixes the range (the paper's)
      auto                  "auto" for a bound (csw's default for dmax): found from the
                            pair, ``shrunk(f)`` giving it shrunk f times
                            (csw.matching.disparity_range.shrink); a bound given beside
                            it is kept

    The one decision of a pair's range: csw.matching.setup.set_up calls it once per
    pair (a set-up kept for the next pairs keeps its range too).  Without ``shrunk``, an
    "auto" bound stays "auto"."""
    config = _with_calibration(config, width, calibration)
    if config.range_known or shrunk is None:
        return config
    f = factor(width)
    low, high = estimate(*shrunk(f), f, width,
                         None if config.dmin == "auto" else config.dmin,
                         None if config.dmax == "auto" else config.dmax,
                         config.threads)
    source = "auto" if config.range_source in ("given", "default", "auto") else \
        f"{config.range_source}, dmin auto"
    return config.replace(dmin=low, dmax=high, range_source=source)


def _with_calibration(config, width, calibration):
    """No dmax given: the calibration's ndisp sets it (below the width)."""
    if calibration is not None and calibration.ndisp and "dmax" not in config.given:
        config = config.replace(dmax=min(calibration.ndisp - 1, width - 1),
                                range_source=f"ndisp of {calibration.source}")
    return config


def known_range(config, width, calibration=None):
    """(dmin, dmax) as far as they are known before the pair's pixels are read (given,
    the preset's, a calibration's ndisp), for the checks made before any work (a map
    format's range), each bound not known yet left "auto" (found from the pair by
    :func:`decide`), csw's one way to say so.  This decides nothing."""
    config = _with_calibration(config, width, calibration)
    return config.dmin, config.dmax


def assumed_range(config, width, calibration=None):
    """``config`` with a range to plan with (memory, threads) before the pair's own is
    decided: :func:`known_range`, each "auto" bound stood in for by the widest a
    found one can usually be (dmin 0, dmax half the width: the coarse search's top,
    csw.matching.disparity_range._coarse).  The one stand-in for a range not known yet;
    never the range a pair is matched with."""
    config = _with_calibration(config, width, calibration)
    if config.range_known:
        return config
    return config.replace(dmin=0 if config.dmin == "auto" else config.dmin,
                          dmax=max(1, width // 2) if config.dmax == "auto" else config.dmax)


def kept_from_first(config, settings):
    """``config`` with the range a first pair found (its Result's ``settings``), kept for
    the next pairs of a stream (csw.Matcher, keep_range)."""
    return config.replace(dmin=settings["dmin"], dmax=settings["dmax"],
                          range_source="auto (from the first pair)")


def check_bounds(config, width):
    """OptionError now when a bound given can't fit a pair ``width`` wide (a video's
    frames, known from its header before any is decoded), as the kernels would refuse
    it on every pair; an "auto" bound is taken as the widest it could be."""
    from ..config.params import OptionError
    from ..kernels.contract import check_range

    dmin = -width + 1 if config.dmin == "auto" else config.dmin
    dmax = width - 1 if config.dmax == "auto" else config.dmax
    try:
        check_range(dmin, dmax, width)
    except ValueError as exc:
        raise OptionError("dmin" if str(exc).startswith("dmin") else "dmax",
                          str(exc)) from None


def factor(width):
    """The shrink factor for an image ``width`` wide: a power of two, at least 2."""
    f = 2
    while width / f > SMALL_WIDTH:
        f *= 2
    return f


def shrink(image, f):
    """The box average of f x f blocks (the image cropped to whole blocks), uint8/uint16
    as given, rounded half to even; f a power of two.

    The block sums are integers added 2 x 2 at a time, in a type that holds them: numpy's
    mean over the blocks' axes took 2.2 ms at 640x480 (f 4) against 0.5, which a stream
    finding its range on every frame pays twice a frame."""
    height, width = (image.shape[0] // f) * f, (image.shape[1] // f) * f
    top = int(np.iinfo(image.dtype).max) * f * f
    total = image[:height, :width].astype(np.uint16 if top < 2 ** 16 else np.uint32
                                          if top < 2 ** 32 else np.uint64)
    for _ in range(f.bit_length() - 1):
        total = total[0::2, 0::2] + total[1::2, 0::2] + total[0::2, 1::2] + total[1::2, 1::2]
    count = f * f
    quotient, remainder = np.divmod(total, count)
    up = (2 * remainder > count) | ((2 * remainder == count) & (quotient % 2 == 1))
    return (quotient + up).astype(image.dtype)


def coarse_config(small_width, f, config):
    """The Config of the coarse match of a pair shrunk f times (``small_width`` wide),
    for ``config``'s bounds ("auto" for one to find)."""
    dmin = None if config.dmin == "auto" else config.dmin
    dmax = None if config.dmax == "auto" else config.dmax
    return _coarse(small_width, f, dmin, dmax, config.threads)


def coarse_configs():
    """The configs a range found from a pair matches its shrunk pair with (dmin found,
    or given as 0), whatever the pair's size: their kernels are the same, and ``csw
    compile --preset`` compiles them, since a default run finds its range."""
    return [_coarse(SMALL_WIDTH, 2, dmin, None, None) for dmin in (None, 0)]


def _coarse(small_width, f, dmin, dmax, threads):
    low = -(small_width // 4) if dmin is None else math.floor(dmin / f)
    high = small_width // 2 if dmax is None else math.ceil(dmax / f)
    low, high = max(low, -(small_width - 1)), min(high, small_width - 1)
    if low > high:
        low = high
    # Only confident matches: the accurate pipeline's checks, and distinct ones (a tie
    # over the whole range, as on a featureless pair, says nothing of it).
    return resolve(preset="accurate", dmin=low, dmax=high, uniqueness_ratio=DISTINCT,
                   threads=threads)


def estimate(small_left, small_right, f, width, dmin=None, dmax=None, threads=None):
    """(dmin, dmax) for the full pair (``width`` wide) from its f-times shrunk images;
    a bound given (not None) is kept as given.  ValueError when the small pair yields no
    confident disparity to go by."""
    config = _coarse(small_left.shape[1], f, dmin, dmax, threads)
    low, high = config.dmin, config.dmax
    try:
        found = run_pipeline(small_left, small_right,
                             dict(config.kernel_args(), csw=False, tau=-1), config.stages)[0]
    except ValueError as exc:  # its sizes are the shrunk pair's: say so, not the user's
        height, small = small_left.shape[:2]
        raise ValueError(f"can't find the disparity range from the pair ({width} wide, "
                         f"shrunk {f} times to {small}x{height}: {exc}); give --dmin and "
                         "--dmax") from None
    # A match at the search's end is no minimum found (the best may lie beyond it), and
    # where a texture repeats, a whole band of them can pass the checks; leave them out.
    values = found[np.isfinite(found) & (found > low) & (found < high)]
    if values.size < 0.01 * found.size:
        raise ValueError("the pair gives too few confident matches to find a disparity "
                         "range from; give --dmin and --dmax")
    top, bottom = np.percentile(values, (HIGH, LOW))
    out_low = dmin if dmin is not None else \
        math.floor(bottom * f - MARGIN * abs(bottom) * f - PAD * f)
    out_high = dmax if dmax is not None else math.ceil(top * f * (1 + MARGIN) + PAD * f)
    if dmin is None:  # a found bound stays within the image; a given one is checked later
        out_low = max(out_low, -(width - 1))
    if dmax is None:
        out_high = max(min(out_high, width - 1), out_low)
    return int(out_low), int(out_high)


def crowded_end(disparity, settings):
    """One line for the user when the valid pixels of ``disparity`` (float32 (H, W), NaN
    where invalid) crowd the last disparity of the range it was matched with
    (``settings``, a Result's): the scene is probably nearer than dmax allows.  None
    when they don't."""
    top = settings["dmax"]
    # Counts, not a copy of the valid pixels: NaN compares False (a stream pays this on
    # every frame).
    at_end = np.count_nonzero(disparity >= top - 1)
    if at_end == 0:
        return None
    share = at_end / np.count_nonzero(np.isfinite(disparity))
    if share < CROWDED_END:
        return None
    advice = ("a larger --dmax" if settings.get("range_source") == "auto" else
              "a larger --dmax, or --dmax auto to find the range from the pair")
    return (f"{100 * share:.1f}% of the valid pixels are at d {top - 1}..{top}, the end of "
            f"the range: the scene may be nearer than dmax {top} allows; try {advice}")

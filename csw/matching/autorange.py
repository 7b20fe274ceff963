"""A disparity range found from the pair itself (``dmax="auto"``, ``dmin="auto"``).

The pair is shrunk by box averaging (a power-of-two factor, at least 2, that brings its
width to SMALL_WIDTH or less), the small pair is matched with the accurate pipeline
(census, the left-right check, speckle removal: only confident disparities survive) over
the widest sensible range, keeping distinct matches only, and the robust extremes of
what it found (the LOW and HIGH percentiles) are scaled back with a margin.  It costs a
few percent of the full match.
"""

import math

import numpy as np

# Chosen once, over every registered dataset (tests/library/test_autorange.py): the
# range covers each ground truth's 99th percentile and moves density and bad-2 by under
# half a point against the dataset's own range.
SMALL_WIDTH = 256
LOW, HIGH = 0.5, 99.5  # percentiles of the small pair's confident disparities
MARGIN = 0.08  # of the found extreme, plus PAD small-pair pixels
PAD = 0.25
UNIQUE = 5  # percent: StereoBM's uniqueness ratio, on the small pair


def factor(width):
    """The shrink factor for an image ``width`` wide: a power of two, at least 2."""
    f = 2
    while width / f > SMALL_WIDTH:
        f *= 2
    return f


def shrink(image, f):
    """The box average of f x f blocks (the image cropped to whole blocks), uint8/uint16
    as given, rounded."""
    height, width = (image.shape[0] // f) * f, (image.shape[1] // f) * f
    blocks = image[:height, :width].reshape(height // f, f, width // f, f)
    return np.round(blocks.mean(axis=(1, 3))).astype(image.dtype)


def estimate(small_left, small_right, f, width, dmin=None, dmax=None, threads=None):
    """(dmin, dmax) for the full pair (``width`` wide) from its f-times shrunk images;
    a bound given (not None) is kept as given.  ValueError when the small pair yields no
    confident disparity to go by."""
    from .matcher import match

    small_width = small_left.shape[1]
    low = -(small_width // 4) if dmin is None else math.floor(dmin / f)
    high = small_width // 2 if dmax is None else math.ceil(dmax / f)
    low, high = max(low, -(small_width - 1)), min(high, small_width - 1)
    if low > high:
        low = high
    # Only confident matches: the accurate pipeline's checks, and distinct ones (a tie
    # over the whole range, as on a featureless pair, says nothing of it).
    found = match(small_left, small_right, preset="accurate", dmin=low, dmax=high,
                  uniqueness_ratio=UNIQUE, threads=threads).disparity
    values = found[np.isfinite(found)]
    if values.size < 0.01 * found.size:
        raise ValueError("the pair gives too few confident matches to find a disparity "
                         "range from; give --dmin and --dmax")
    top, bottom = np.percentile(values, (HIGH, LOW))
    out_low = dmin if dmin is not None else \
        math.floor(bottom * f - MARGIN * abs(bottom) * f - PAD * f)
    out_high = dmax if dmax is not None else math.ceil(top * f * (1 + MARGIN) + PAD * f)
    out_low = max(out_low, -(width - 1))
    out_high = max(min(out_high, width - 1), out_low)
    return int(out_low), int(out_high)

"""The matching contract shared by every engine: cost codes, input checks, results.

Every engine in this package computes exactly the same thing (see docs/engines.md, "The matching
contract"). This module holds the part they share: the public names of the costs, the
validation that runs once at the door, and the result type.
"""

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

# The costs' codes and names, re-exported for the engines and callers (kernels/costs.py).
from .costs import CENSUS, COSTS, SAD, SHD, SSD, cost_named  # noqa: F401

# The engines (kernels/__init__.py maps each name to its entry).
ENGINE_NAMES = ("fast", "window")

# The census codes' widest (see census_dtype).
MAX_CENSUS_BITS = 64

# Disparities in a vector of 16-bit lanes (256 bits; half of a 512-bit one).  The
# compiled loops over d run in whole vectors and finish the rest one d at a time: the
# semi-global kernels pad their d axes to whole vectors of this many (kernels/sgm.py,
# jit/sgm.py), where 63 disparities took half as long again as 64.
LANES = 16
# Which neighbours of the census window make bits (see census_places):
#   dense   every one
#   sparse  every second pixel of every second row, counted from the centre, and the
#           centre's 8 neighbours: a 9x9 window in 32 bits, so codes of 32-bit lanes,
#           which the engines compare in about 60% of the time of 64-bit ones
CENSUS_PATTERNS = ("dense", "sparse")

# Rules that decide which CSW matches claim their right pixel, and which claims bind
# (see docs/engines.md, "CSW rules"):
#   literal  the paper's: claim when m <= tau; every claim blocks later pixels.
#   unique   claim when m <= tau and the match is distinct (the best cost beats every
#            candidate at least 2 away from it by `csw_margin` percent); a claim does not
#            bind the very next pixel, whose match may share the right pixel at integer
#            precision where the disparity grows along the row.
RULE_LITERAL, RULE_UNIQUE = 0, 1
RULES = {"literal": RULE_LITERAL, "unique": RULE_UNIQUE}
# How many pixels after the claimant a claim does not bind, per rule.
RULE_SLACK = {RULE_LITERAL: 0, RULE_UNIQUE: 1}

# One invalid-disparity convention everywhere: -1 in integer maps (inf in PFM files,
# NaN in float maps); where the range reaches below 0, -1 is a disparity, and integer
# maps mark invalid pixels with NEG_INVALID instead (see invalid()).
INVALID = -1
NEG_INVALID = int(np.iinfo(np.int32).min)


def invalid(dmin):
    """The integer maps' invalid value for a range starting at dmin."""
    return INVALID if dmin >= 0 else NEG_INVALID


def pad_edge(image, h, dtype=np.uint16, out=None):
    """Copy of a (H, W) image padded by h on every side with its edge values (the
    contract's clamp), as ``dtype``: the window engine uses one uint16 kernel for 8- and
    16-bit input; the fast engine keeps 8-bit data 8-bit.  Written out rather than
    np.pad(mode="edge"), which costs about 45 us a call whatever the size (a sixth of a
    small match's overhead).  out: a (H + 2h, W + 2h) array of ``dtype`` to write it in
    (else a new one)."""
    height, width = image.shape
    if out is None:
        out = np.empty((height + 2 * h, width + 2 * h), dtype)
    core = out[h:h + height]
    core[:, h:h + width] = image
    core[:, :h] = core[:, h:h + 1]
    core[:, h + width:] = core[:, h + width - 1:h + width]
    out[:h] = core[0]
    out[h + height:] = core[height - 1]
    return out


@dataclass
class MatchResult:
    """What a matcher returns.

    disparity: int32 (H, W); the chosen d, or invalid(dmin) (-1, or NEG_INVALID for a
        range reaching below 0) where no candidate was left.
    min_cost:  int64 (H, W); the minimum cost m at the chosen d, or -1 where invalid.
    evaluated: number of (pixel, d) candidates whose cost was evaluated.
    candidates: number of candidates plain matching evaluates on the same rows, so
        ``1 - evaluated / candidates`` is the share of work CSW skipped.
    With ``extras`` (else None), over evaluated candidates only, -1 where none:
    second_cost: int64 (H, W), the least cost at least 2 disparities from the chosen d
        (for the unique rule's margin and confidence).
    prev_cost, next_cost: int64 (H, W), the costs at d - 1 and d + 1 (for subpixel).
    With ``right_map`` (else None):
    right_disparity: int32 (H, W), for each right pixel its best left match's d over the
        evaluated candidates (the smallest d among equal costs; -1 where none): the right
        image's map, for the left-right check.
    With ``lr_check`` N (else None):
    lr_valid: bool (H, W), the left-right check: d is valid and the right map at x - d
        holds a d' with |d - d'| <= N (filters.lr_consistent on the two maps).
    """

    disparity: np.ndarray
    min_cost: np.ndarray
    evaluated: int
    candidates: int
    second_cost: np.ndarray | None = None
    prev_cost: np.ndarray | None = None
    next_cost: np.ndarray | None = None
    right_disparity: np.ndarray | None = None
    lr_valid: np.ndarray | None = None

    @property
    def work_saved(self) -> float:
        """Share (0..1) of plain matching's candidate evaluations that were skipped."""
        return 1.0 - self.evaluated / self.candidates if self.candidates else 0.0


class MatchParams(NamedTuple):
    """The scalar parameters of a match, as one record (as OpenCV's StereoBMParams),
    validated and normalised by :func:`validate`; the entries receive them as their int64
    scalars, and ``cost``, ``csw``, ``extras`` and ``right_map`` choose the compiled
    variant."""

    window: int
    dmin: int
    dmax: int
    cost: int  # a code of kernels/costs.py: census runs as SHD over census codes
    csw: bool
    tau: int
    rule: int
    csw_margin: int  # percent, for RULE_UNIQUE
    slack: int  # a claim by pixel x' binds pixel x only when x - x' > slack
    extras: bool  # also compute MatchResult's second/prev/next costs
    right_map: bool  # also return MatchResult's right_disparity
    lr_check: int  # -1, or the limit of MatchResult's lr_valid (the left-right check)

    @property
    def right_costs(self):
        """Whether the right image's best matches are tracked: for its map, or for the
        left-right check made from it."""
        return self.right_map or self.lr_check >= 0


def dtype_name(dtype):
    """'u8', 'u16', ... : how kernel variants name pixel and accumulator types."""
    dtype = np.dtype(dtype)
    return f"{dtype.kind}{dtype.itemsize * 8}"


def dtype_of(name):
    """The numpy dtype a variant's type name stands for."""
    kinds = {"u": "uint", "i": "int", "f": "float"}
    return np.dtype(bool) if name[0] == "b" else np.dtype(kinds[name[0]] + name[1:])


@functools.cache
def census_places(census_window, pattern):
    """The neighbours a census code compares, as their places in the window (row-major,
    0 .. size * size - 1), in bit order: row by row, left to right, the first one the
    code's most significant bit; the centre is never one.  Their number is a multiple
    of 8 for every odd window and both patterns (the transform makes 8 bits a pass)."""
    if pattern not in CENSUS_PATTERNS:
        raise ValueError(f"census pattern must be one of {', '.join(CENSUS_PATTERNS)}, "
                         f"got {pattern!r}")
    h = census_window // 2
    places = []
    for a in range(-h, h + 1):
        for b in range(-h, h + 1):
            if (a, b) == (0, 0):
                continue
            if pattern == "dense" or (a % 2 == 0 and b % 2 == 0) or max(abs(a), abs(b)) == 1:
                places.append((a + h) * census_window + b + h)
    return tuple(places)


def census_bits(census_window, pattern):
    """len(census_places(census_window, pattern)), counted without listing the places
    (a window of 99999 would list 10**10 of them)."""
    h = census_window // 2
    if pattern == "dense":
        return census_window * census_window - 1
    even = 2 * (h // 2) + 1  # offsets -h..h that are even
    # The (even, even) places but the centre, and the centre's 8 neighbours, none of
    # which is one of them.
    return even * even - 1 + (8 if h >= 1 else 0)


@functools.cache
def census_dtype(census_window, pattern):
    """The narrowest unsigned type holding a census code of this window and pattern."""
    if pattern not in CENSUS_PATTERNS:
        raise ValueError(f"census pattern must be one of {', '.join(CENSUS_PATTERNS)}, "
                         f"got {pattern!r}")
    bits = census_bits(census_window, pattern)
    for dtype in (np.uint8, np.uint16, np.uint32, np.uint64):
        if bits <= np.iinfo(dtype).bits:
            return dtype
    largest = max(c for c in range(3, min(census_window, 65), 2)
                  if census_bits(c, pattern) <= MAX_CENSUS_BITS)
    fix = f"use a census window of {largest} or less" + (
        " or the sparse pattern" if pattern == "dense" else "")
    raise ValueError(f"a {pattern} {census_window}x{census_window} census has {bits} bits, "
                     f"more than {MAX_CENSUS_BITS}; {fix}")


def _as_image(name, image):
    image = np.asarray(image)
    if image.ndim != 2:
        raise ValueError(
            f"{name} image must be 2-D grayscale (H, W), got shape {image.shape}; "
            "convert colour images to gray first"
        )
    if image.dtype not in (np.uint8, np.uint16):
        raise ValueError(
            f"{name} image must be uint8 or uint16, got {image.dtype}; "
            "change the dtype with .astype(np.uint8) or .astype(np.uint16)"
        )
    return np.ascontiguousarray(image)


def validate(left, right, *, window, dmin, dmax, cost, csw, tau, rule="literal",
             csw_margin=None, slack=None, rows=None, census_window=None,
             census_pattern=None, extras=False, right_map=False, lr_check=None):
    """Check the inputs once and return ``(left, right, MatchParams, rows)``; raise
    ValueError.

    left, right: uint8 or uint16 (H, W), equal shapes and dtypes.  rows: int64 (n,).
    The kernels have no defaults of their own: csw_margin is needed for the unique rule,
    census_window and census_pattern for the census cost (csw.config.params has the
    defaults).  Every message says how to fix the input.
    """
    left = _as_image("left", left)
    right = _as_image("right", right)
    check_pair(left.shape, left.dtype, right.shape, right.dtype)
    height, width = left.shape
    window = check_window(window, height, width)
    dmin, dmax = check_range(dmin, dmax, width)
    code = cost_named(cost).code  # raises, naming the costs
    if rule not in RULES:
        raise ValueError(f"CSW rule must be one of {', '.join(RULES)}, got {rule!r}")
    # slack is the rule's unless given: studies of the rule (reports/csw-tradeoff.md)
    # switch its two halves on and off separately.
    slack = RULE_SLACK[RULES[rule]] if slack is None else int(slack)
    if not 0 <= slack <= 1_000_000:
        raise ValueError(f"slack must be >= 0, got {slack}")
    if csw_margin is None:
        if rule == "unique":
            raise ValueError("the unique rule needs its margin: give csw_margin (percent)")
        csw_margin = 0  # the literal rule has none
    if isinstance(csw_margin, bool) or int(csw_margin) != csw_margin or \
            not 0 <= csw_margin <= 1000:
        raise ValueError(f"csw_margin must be a whole percentage from 0 to 1000, got "
                         f"{csw_margin!r}")
    # Costs are integers, so m <= tau is the same test as m <= floor(tau); +inf (no
    # threshold) becomes a bound above every possible cost.
    tau = float(tau)
    if np.isnan(tau):
        raise ValueError("tau must be a number, got NaN")
    tau = int(np.clip(np.floor(tau), -1, np.iinfo(np.int64).max // 2))
    if rows is None:
        rows = np.arange(height, dtype=np.int64)
    else:
        rows = np.asarray(rows, dtype=np.int64)
        if rows.ndim != 1 or (rows.size and (rows.min() < 0 or rows.max() >= height)):
            raise ValueError(f"rows must be a 1-D list of row indices in 0..{height - 1}")
        if np.any(np.diff(rows) <= 0):
            raise ValueError("rows must be strictly increasing")
    if cost == "census":
        if census_window is None or census_pattern is None:
            raise ValueError("the census cost needs census_window and census_pattern")
        census_window = int(census_window)
        if census_window < 3 or census_window % 2 == 0:
            raise ValueError(f"census window must be odd and at least 3, got {census_window}")
        census_dtype(census_window, census_pattern)  # raises when over 64 bits
    if lr_check is None:
        lr_check = -1
    elif isinstance(lr_check, bool) or int(lr_check) != lr_check or lr_check < 0:
        raise ValueError(f"lr_check must be a whole number of pixels >= 0 (or None), got "
                         f"{lr_check!r}")
    params = MatchParams(window, dmin, dmax, code, bool(csw), tau, RULES[rule],
                         int(csw_margin), slack, bool(extras), bool(right_map), int(lr_check))
    return left, right, params, rows


def check_window(window, height, width):
    """The window side as an int; ValueError unless odd, >= 1 and within the image."""
    if isinstance(window, bool) or int(window) != window:
        raise ValueError(f"window must be an odd whole number, got {window!r}")
    window = int(window)
    if window < 1 or window % 2 == 0:
        raise ValueError(f"window must be odd and at least 1 (e.g. 9), got {window}")
    if window > min(height, width):
        raise ValueError(
            f"window {window} is larger than the image ({width}x{height}); use a smaller window"
        )
    return window


def check_range(dmin, dmax, width):
    """(dmin, dmax) as ints; ValueError unless -width < dmin <= dmax < width."""
    dmin, dmax = int(dmin), int(dmax)
    if dmin <= -width:
        raise ValueError(f"dmin ({dmin}) must be greater than minus the image width "
                         f"({width}); raise dmin")
    if dmin > dmax:
        raise ValueError(f"dmin ({dmin}) must not exceed dmax ({dmax})")
    if dmax >= width:
        raise ValueError(
            f"dmax ({dmax}) must be less than the image width ({width}); lower dmax"
        )
    return dmin, dmax


def check_pair(left_shape, left_dtype, right_shape, right_dtype):
    """ValueError unless the two images have one size and one pixel type."""
    if tuple(left_shape) != tuple(right_shape):
        raise ValueError(
            f"left and right images differ in size: {left_shape[1]}x{left_shape[0]} vs "
            f"{right_shape[1]}x{right_shape[0]}; stereo pairs must be rectified to one size"
        )
    if np.dtype(left_dtype) != np.dtype(right_dtype):
        raise ValueError(
            f"left is {np.dtype(left_dtype)} but right is {np.dtype(right_dtype)}; give both "
            "the same bit depth"
        )



@functools.lru_cache(maxsize=256)  # per image size and range: a batch repeats them
def candidate_count(width, dmin, dmax):
    """Candidates plain matching evaluates on one row of ``width`` pixels."""
    # Pixel x has the candidates d in [max(dmin, x - width + 1), min(dmax, x)]: the
    # right pixel x - d lies in the image.
    x = np.arange(width)
    low = np.maximum(dmin, x - width + 1)
    return int(np.clip(np.minimum(dmax, x) - low + 1, 0, None).sum())

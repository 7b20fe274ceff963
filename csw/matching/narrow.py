"""Semi-global matching's narrowed search (option sgm_narrow, docs/engines.md): a
half-size pass says where each pixel's match lies, and the full-size pass aggregates
only K disparities around it, as tSGM does in photogrammetry.  The paths' work and
memory shrink from the range to K; the half-size pass costs an eighth of a whole
search.

Each full-size pixel's span is that of the half-size matches in its 3 x 3 half-size
neighbourhood, doubled, MARGIN wider each side; a half-size pixel the left-right check
left without a match spans its row's nearest matches on either side.  K slots centred
on the span cover it where it is at most K wide; where it is wider (a depth edge), K
slots centred on the pixel's own half-size match.  The kernel
kernels.filters.narrow_starts makes them from the half-size match; tests/oracle.py's
narrow_starts defines them exactly, in NumPy.
"""

import numpy as np

from ..kernels import filters, sgm

# Disparities each side of the doubled half-size span: a half-size pixel's match is
# within one of the truth there, which is two at full size.
MARGIN = 2


def half(image):
    """The image at half size, (H // 2, W // 2): means of 2 x 2 blocks, rounded.  Row
    pairs added in a type wide enough for four pixels, then column pairs, in place where
    it can be: numpy's sum over two axes of a (h, 2, w, 2) view is a slow reduction, and
    this runs on every match (0.1 ms for a KITTI frame, half of four strided views')."""
    h, w = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
    rows = image[0:h:2, :w].astype(np.uint16 if image.dtype.itemsize == 1 else np.uint32)
    rows += image[1:h:2, :w]
    total = rows[:, 0::2] + rows[:, 1::2]
    total += 2
    total >>= 2
    return total.astype(image.dtype)


def narrows(slots, dmin, dmax, width=None):
    """Whether a search of ``slots`` disparities a pixel narrows dmin..dmax: a range at
    most that wide is searched whole, and so is one at the edge of an image ``width``
    wide (dmax = W - 1 of an odd W, dmin = 1 - W), past the half width's once halved."""
    half = None if width is None else width // 2
    return 0 < slots < dmax - dmin + 1 and (half is None or -half < dmin // 2 <= dmax // 2
                                            < half)


def starts(left, right, *, dmin, dmax, slots, threads=None, **match_options):
    """The full-size pass's starts, int32 (H, W) in 0..D - slots (kernels.sgm.match_sgm's),
    from a half-size semi-global match of ``left``, ``right`` over half the range, with
    match_options (window, cost, paths, p1, p2, census_window, census_pattern, and the
    workspace whose slabs the full pass takes next) as the full pass's; None where the
    range is at most ``slots`` wide (nothing to narrow)."""
    ndisp = dmax - dmin + 1
    if not narrows(slots, dmin, dmax, left.shape[1]) or min(left.shape) < 4:
        return None
    # Half the range, floored at both ends: an odd dmax's top half-size match (dmax / 2
    # rounded up) is within MARGIN of its rounded-down neighbour, and the half range's
    # count stays a whole number of vectors where the range's is (0..191: 96 at half
    # size, not 97, whose one extra disparity cost a fifth of the pass).
    coarse = sgm.match_sgm(half(left), half(right), dmin=dmin // 2, dmax=dmax // 2,
                           lr_check=1, threads=threads, **match_options)
    # The half range's start is offset 0 of the spans; base is its full-size offset.
    return filters.narrow_starts(coarse.disparity, coarse.lr_valid, left.shape, dmin // 2,
                                 ndisp, slots, 2 * (dmin // 2) - dmin, MARGIN, threads)

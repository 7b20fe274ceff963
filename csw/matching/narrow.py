"""Semi-global matching's narrowed search (option sgm_narrow, docs/engines.md): a
half-size pass says where each pixel's match lies, and the full-size pass aggregates
only K disparities around it, as tSGM does in photogrammetry.  The paths' work and
memory shrink from the range to K; the half-size pass costs an eighth of a whole
search.

Each full-size pixel's span is that of the half-size matches in its 3 x 3 half-size
neighbourhood, doubled, MARGIN wider each side; a half-size pixel the left-right check
left without a match spans its row's nearest matches on either side.  K slots centred
on the span cover it where it is at most K wide; where it is wider (a depth edge), K
slots centred on the pixel's own half-size match.
"""

import numpy as np

from ..kernels import sgm

# Disparities each side of the doubled half-size span: a half-size pixel's match is
# within one of the truth there, which is two at full size.
MARGIN = 2


def half(image):
    """The image at half size, (H // 2, W // 2): means of 2 x 2 blocks, rounded.  Four
    strided views added in a type wide enough for four pixels: numpy's sum over two
    axes of a (h, 2, w, 2) view is a slow reduction, and this runs on every match."""
    h, w = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
    wide = np.uint16 if image.dtype.itemsize == 1 else np.uint32
    top, bottom = image[0:h:2].astype(wide), image[1:h:2].astype(wide)
    total = top[:, 0:w:2] + top[:, 1:w:2] + bottom[:, 0:w:2] + bottom[:, 1:w:2] + 2
    return (total // 4).astype(image.dtype)


def row_spans(disp, valid):
    """(low, high) (h, w): each pixel's match where valid, else the row's nearest valid
    matches left and right of it (their least and greatest; one side if only one has
    any); -1 where its row has none.  disp holds no negatives."""
    h, w = disp.shape
    cols = np.arange(w, dtype=np.int32)
    before = np.maximum.accumulate(np.where(valid, cols, -1), axis=1)
    after = np.minimum.accumulate(np.where(valid, cols, w)[:, ::-1], axis=1)[:, ::-1]
    left = np.take_along_axis(disp, np.maximum(before, 0), axis=1)
    right = np.take_along_axis(disp, np.minimum(after, w - 1), axis=1)
    left[before < 0] = -1
    right[after >= w] = -1
    low = np.where(left < 0, right, np.where(right < 0, left, np.minimum(left, right)))
    high = np.maximum(left, right)
    return low, high


def neighbourhood(values, reduce):
    """values (h, w) reduced over each pixel's 3 x 3 neighbourhood (edges repeated);
    reduce: np.minimum or np.maximum.  Three rows, then three columns: a 3 x 3 window
    view's reduction took 70 ms of a 960 x 540 half-size pass."""
    padded = np.pad(values, 1, mode="edge")
    rows = reduce(reduce(padded[:-2], padded[1:-1]), padded[2:])
    return reduce(reduce(rows[:, :-2], rows[:, 1:-1]), rows[:, 2:])


def narrows(slots, dmin, dmax):
    """Whether a search of ``slots`` disparities a pixel narrows dmin..dmax: a range at
    most that wide is searched whole."""
    return 0 < slots < dmax - dmin + 1


def starts(left, right, *, dmin, dmax, slots, threads=None, **match_options):
    """The full-size pass's starts, int32 (H, W) in 0..D - slots (kernels.sgm.match_sgm's),
    from a half-size semi-global match of ``left``, ``right`` over half the range, with
    match_options (window, cost, paths, p1, p2, census_window, census_pattern, and the
    workspace whose slabs the full pass takes next) as the full pass's; None where the
    range is at most ``slots`` wide (nothing to narrow)."""
    ndisp = dmax - dmin + 1
    if not narrows(slots, dmin, dmax) or min(left.shape) < 4:
        return None
    height, width = left.shape
    coarse = sgm.match_sgm(half(left), half(right), dmin=dmin // 2, dmax=-(-dmax // 2),
                           lr_check=1, threads=threads, **match_options)
    valid = coarse.lr_valid
    # Offsets from the half range's start: 0 .. about ndisp / 2, so that no sum below
    # wraps in int32, nor does twice the mark of "none found" (2 * ndisp).
    offsets = coarse.disparity - np.int32(dmin // 2)
    low, high = row_spans(offsets, valid)
    found = low >= 0
    low = neighbourhood(np.where(found, low, np.int32(2 * ndisp)), np.minimum)
    high = neighbourhood(np.where(found, high, -1), np.maximum)
    known = low <= high  # none where no row of the neighbourhood had a match
    own = np.where(valid, offsets, np.where(known, (low + high) // 2, 0))
    base = 2 * (dmin // 2) - dmin  # full-size offset of the half range's start
    first = 2 * low + base - MARGIN
    last = 2 * high + base + MARGIN
    span = last - first + 1
    centred = first - (slots - span) // 2
    on_own = 2 * own + base - slots // 2
    start = np.where(span <= slots, centred, on_own)
    # Where the neighbourhood had no half-size match at all: from the range's start.
    start = np.clip(np.where(known, start, 0), 0, ndisp - slots).astype(np.int32)
    # Back to full size: pixel (y, x) takes half-size pixel (y // 2, x // 2), the last
    # row and column of an odd size their neighbour's.  Every step above is the half-size
    # pixel's own, so it is made at half size, a quarter of the pixels.
    ys = np.minimum(np.arange(height) // 2, start.shape[0] - 1)
    xs = np.minimum(np.arange(width) // 2, start.shape[1] - 1)
    return start[ys][:, xs]

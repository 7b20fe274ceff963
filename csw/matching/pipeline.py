"""The matching pipeline around the CSW kernels; every stage is an option (csw.config.params holds
their defaults and allowed values) and off in the paper's contract:

  prefilter          "none", or "xsobel": StereoBM's x-Sobel response clipped to
                     +-prefilter_cap (offset by the cap into 0..2*cap), which absorbs
                     brightness differences between the views
  cost               sad, ssd, shd, or census (codes of a census_window square,
                     census_pattern dense or sparse, Hamming distance summed over the
                     matching window)
  CSW                the B-map skip and its rules, as in the contract
  lr_check N         invalid where |d - d_right(x - d)| > N; the right image's map comes
                     from the same costs in the same pass (no second match)
  uniqueness_ratio U StereoBM's: invalid where a candidate 2 or more away costs at most
                     best * (1 + U/100)
  texture_threshold T  StereoBM's: invalid where the window's summed |x-Sobel| (the
                     prefilter's response, capped) is below T
  subpixel           "none", "parabola" or "linear" (equiangular): a fit through the
                     costs at d - 1, d, d + 1
  speckle_size S     invalid where a region of similar disparity (4-connected, steps of at
                     most speckle_range) has fewer than S pixels (OpenCV's filterSpeckles)
  median K           a K x K median over valid pixels
  fill               "none", or "background": the evaluation kits' hole filling

The confidence of a pixel is (second - best) / second of its costs (0..1, 0 where
invalid or without a second candidate): how distinct the match is.
"""

from dataclasses import dataclass

import numpy as np

from .. import kernels
from ..kernels.filters import fill_background, median_valid, speckle_mask


def xsobel(image, cap):
    """StereoBM's prefilter: the 3x3 x-Sobel response, clipped to [-cap, cap] and offset
    by cap, as uint8 (H, W); edge-replicated borders."""
    p = np.pad(image.astype(np.int32), 1, mode="edge")
    gx = (p[:-2, 2:] - p[:-2, :-2]) + 2 * (p[1:-1, 2:] - p[1:-1, :-2]) + (p[2:, 2:] - p[2:, :-2])
    return (np.clip(gx, -cap, cap) + cap).astype(np.uint8)


def box_sum(values, window):
    """Sum over the window x window box centred on each pixel, edge-replicated (exact
    integer arithmetic, by cumulative sums)."""
    h = window // 2
    p = np.pad(values.astype(np.int64), h, mode="edge")
    c = np.zeros((p.shape[0] + 1, p.shape[1] + 1), np.int64)
    c[1:, 1:] = p.cumsum(0).cumsum(1)
    height, width = values.shape
    return (c[window:window + height, window:window + width] - c[:height, window:window + width]
            - c[window:window + height, :width] + c[:height, :width])


def entries(args, stages, dtype, confidence=False):
    """The compiled kernel entries (csw.kernels.native) a run of the pipeline with these
    kernel arguments and stages loads, for images of ``dtype``."""
    from ..kernels.filters import entries as filter_entries

    return kernels.entries(args["engine"], args["cost"], dtype, args["window"],
                           stages.census_window, args.get("csw", False), False,
                           confidence or stages.needs_extras, args["dmin"],
                           lr_check=stages.lr_check is not None,
                           census_pattern=stages.census_pattern) + \
        filter_entries(stages.speckle_size > 0, stages.median > 0, stages.fill == "background")


def prefiltered(left, right, stages):
    """The images the cost compares: as given, or StereoBM's x-Sobel response."""
    if stages.prefilter == "xsobel":
        cap = int(stages.prefilter_cap)
        return xsobel(left, cap), xsobel(right, cap)
    return left, right


def distinct(min_cost, second, ratio):
    """bool (H, W): no candidate 2 or more away costs <= best * (1 + ratio/100)."""
    return (second < 0) | (second * 100 > min_cost * (100 + ratio))


def textured(left, window, cap, threshold):
    """bool (H, W): the window's summed |x-Sobel| (capped at cap) reaches threshold."""
    response = np.abs(xsobel(left, cap).astype(np.int64) - cap)
    return box_sum(response, window) >= threshold


def subpixel_offset(best, prev, nxt, fit):
    """float64 (H, W) offsets in (-0.5, 0.5] from the costs at d - 1, d, d + 1 (int64, -1
    where unknown); 0 where a neighbour is unknown or the costs are flat."""
    best, prev, nxt = (a.astype(np.float64) for a in (best, prev, nxt))
    known = (prev >= 0) & (nxt >= 0)
    if fit == "parabola":
        denominator = prev - 2 * best + nxt
    else:  # linear: the equiangular (V-shaped) fit, suited to SAD-like costs
        denominator = np.maximum(prev, nxt) - best
    ok = known & (denominator > 0)
    offset = np.zeros_like(best)
    offset[ok] = (prev[ok] - nxt[ok]) / (2 * denominator[ok])
    return np.clip(offset, -0.5, 0.5)


def confidence_map(min_cost, second, valid):
    """float32 (H, W): (second - best) / second, 0..1; 0 where invalid or no second."""
    conf = np.zeros(min_cost.shape, np.float32)
    ok = valid & (second > 0)
    conf[ok] = ((second[ok] - min_cost[ok]) / second[ok]).astype(np.float32)
    return conf


@dataclass
class Work:
    """What a run's kernels did, beside its maps (arrays the caller owns).

    min_cost: int64 (H, W), the minimum cost m at the chosen d, -1 where no candidate.
    evaluated: candidates (pixel, d) whose cost was evaluated; candidates: those plain
    matching evaluates on the same rows.
    """

    min_cost: np.ndarray
    evaluated: int
    candidates: int

    @property
    def work_saved(self):
        """Share (0..1) of plain matching's candidate evaluations that were skipped."""
        return 1.0 - self.evaluated / self.candidates if self.candidates else 0.0


def run(left, right, kernel_args, stages, confidence=False, workspace=None):
    """Run the pipeline: (disparity float32 (H, W) NaN invalid, confidence float32 (H, W),
    :class:`Work`).  The confidence is None when neither ``confidence`` nor a stage asked
    for the second-best costs.

    left, right: uint8/uint16 (H, W).  kernel_args: csw.kernels.match's arguments (engine,
    window, range, cost, CSW).  stages: a csw.config.params.Stages (see the module's
    docstring).
    confidence: compute the second-best costs for the confidence map even when no stage
    needs them.
    workspace: a kernels.workspace.Workspace for the scratch that never leaves the call
        (padded images or census codes, the integer maps, the masks), lent to the kernels
        for their own scratch and their integer outputs.  Whole-image matches pass their
        thread's, so that repeated matches reuse it.  None: fresh arrays (the tiled
        bands, whose memory is planned).
    """
    disp, conf, raw = match_rows(left, right, kernel_args, stages, confidence, workspace)
    disp, conf = filter_map(disp, conf, stages, workspace, kernel_args.get("threads"))
    return disp, conf, raw


def row_overlap(stages, window, cost):
    """Rows of input above and below a stripe that make :func:`match_rows` on the stripe
    give exactly the whole image's rows: half the window, plus half the census window,
    plus one for the x-Sobel (prefilter or texture)."""
    rows = window // 2
    if cost == "census":
        rows += int(stages.census_window) // 2
    if stages.prefilter == "xsobel" or stages.texture_threshold is not None:
        rows += 1
    return rows


def filter_overlap(stages):
    """Rows of disparity above and below a stripe that make :func:`filter_map` exact on
    it.  A region under S = speckle_size pixels spans at most S - 1 rows beyond any of its
    pixels; a larger one has S of its pixels within S - 1 rows (its first S pixels in a
    breadth-first walk), so S - 1 rows decide every region as the whole map does.  The
    median needs half its side more, of rows the speckle filter got right."""
    rows = int(stages.speckle_size) - 1 if stages.speckle_size > 1 else 0
    return rows + int(stages.median) // 2


def is_row_local(stages):
    """Whether :func:`filter_map` works row by row (no speckle filter, no median)."""
    return filter_overlap(stages) == 0


def match_rows(left, right, kernel_args, stages, confidence=False, workspace=None):
    """The row-local stages: costs, CSW, the validity checks and subpixel.  Returns
    (disparity float32 (H, W) NaN invalid, confidence float32 (H, W) or None, Work);
    row y depends only on input rows y +- :func:`row_overlap`.  workspace: see
    :func:`run`."""
    a, b = prefiltered(left, right, stages)
    rows = kernel_args.get("rows")
    shape = (left.shape[0] if rows is None else len(rows), left.shape[1])
    into = None if workspace is None else {  # the integer maps, used only here
        "disparity": workspace.empty("disparity", shape, np.int32),
        "lr_valid": workspace.empty("lr-valid", shape, np.uint8)}
    raw = kernels.match(a, b, census_window=stages.census_window,
                        census_pattern=stages.census_pattern,
                        extras=confidence or stages.needs_extras,
                        lr_check=stages.lr_check, workspace=workspace, into=into,
                        **kernel_args)
    invalid = kernels.invalid(kernel_args["dmin"])
    valid = np.not_equal(raw.disparity, invalid,
                         out=kernels.workspace.empty(workspace, "valid", raw.disparity.shape,
                                                     np.bool_))
    if stages.lr_check is not None:
        valid &= raw.lr_valid
    if stages.uniqueness_ratio is not None:
        valid &= distinct(raw.min_cost, raw.second_cost, stages.uniqueness_ratio)
    if stages.texture_threshold is not None:
        texture = textured(left, kernel_args["window"], int(stages.prefilter_cap),
                           stages.texture_threshold)
        valid &= texture if rows is None else texture[rows]
    if stages.subpixel != "none":
        disp = (raw.disparity + subpixel_offset(raw.min_cost, raw.prev_cost, raw.next_cost,
                                                stages.subpixel)).astype(np.float32)
    else:
        disp = raw.disparity.astype(np.float32)
    # None when the second-best costs were not computed: no confidence to give.
    conf = None if raw.second_cost is None else confidence_map(raw.min_cost, raw.second_cost,
                                                               valid)
    disp[np.logical_not(valid, out=valid)] = np.nan  # in place: no temporary mask
    return disp, conf, Work(raw.min_cost, raw.evaluated, raw.candidates)


def filter_map(disp, conf, stages, workspace=None, threads=None):
    """The 2-D stages on :func:`match_rows`' maps: speckle removal, the median, then the
    background fill; the confidence is 0 wherever the filters left no disparity.  Returns
    (disparity, confidence), float32 (H, W); ``disp`` may be changed in place, and a
    ``conf`` of None stays None.  workspace: see :func:`run`; threads: as for csw.match."""
    if stages.speckle_size > 0:
        disp[speckle_mask(disp, int(stages.speckle_size), float(stages.speckle_range),
                          workspace, threads)] = np.nan
    if stages.median:
        disp = median_valid(disp, int(stages.median), threads)
    if conf is not None and not is_row_local(stages):
        # Filters only remove pixels (the median keeps the valid set), so masking the
        # confidence afterwards equals computing it on the filtered map.
        conf = np.where(np.isfinite(disp), conf, np.float32(0))
    if stages.fill == "background":
        disp = fill_background(disp, threads)
    return disp, conf

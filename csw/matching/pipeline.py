"""The matching pipeline around the CSW kernels.  Each stage is one record
(csw.matching.stages: its options, margins, bytes, entries and step) and an option of
csw.config.params, off in the paper's contract:

  prefilter          "none", or "xsobel": StereoBM's x-Sobel response clipped to
                     +-prefilter_cap (offset by the cap into 0..2*cap), which absorbs
                     brightness differences between the views
  cost               sad, ssd, shd, or census (codes of a census_window square,
                     census_pattern dense or sparse, Hamming distance summed over the
                     matching window)
  CSW                the B-map skip and its rules, as in the contract
  lr_check N         invalid where |d - d_right(x - d)| > N; the right image's map comes
                     from the same costs in the same pass (no second match)
  winner_check N     StereoBM's check (disp12MaxDiff): as lr_check, the right image's
                     match of xr being the least-cost left pixel whose winner is xr
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
from ..kernels import catalogue, filters, sgm
from ..kernels.contract import census_bits
from ..kernels.costs import cost_named
from . import narrow
from .stages import active, needs_extras, needs_second


def entries(args, stages, dtype, confidence=False):
    """The compiled kernel entries (csw.kernels.native) a run of the pipeline with these
    kernel arguments and stages loads, for images of ``dtype``."""
    cost = args["cost"]
    if stages.aggregate == "sgm":
        compared = compared_dtype(stages, dtype)
        matching = catalogue.sgm_entries(
            cost, compared, args["window"], args["dmin"], stages.sgm_paths,
            *penalties(stages, cost, args["window"], compared), stages.census_window,
            stages.census_pattern)
    else:
        matching = catalogue.engine_entries(
            args["engine"], cost, dtype, args["window"], stages.census_window,
            args.get("csw", False), False, confidence or needs_extras(stages, cost),
            args["dmin"], lr_check=stages.lr_check is not None,
            census_pattern=stages.census_pattern)
    prefiltered = stages.prefilter == "xsobel" or stages.texture_threshold is not None
    return matching + \
        [entry for stage in active(stages, cost) for entry in stage.entries] + \
        [catalogue.entry("filters", "float")] + \
        ([catalogue.entry("filters", "confidence")] if makes_second(stages, cost, confidence)
         else []) + \
        ([catalogue.entry("prefilter", dtype)] if prefiltered else []) + \
        ([catalogue.entry("pad", dtype)] if args["engine"] == "fast" else [])  # calls' padding


def makes_second(stages, cost, confidence=False):
    """Whether the kernels make the second-best costs (and so a confidence map): when
    asked for, when a stage reads them, and in the local engines with the neighbours'
    costs whatever needs those (semi-global matching makes them apart)."""
    return confidence or needs_second(stages, cost) or \
        (stages.aggregate != "sgm" and needs_extras(stages, cost))


def compared_dtype(stages, dtype):
    """The type of the images the costs compare: the x-Sobel prefilter's are bytes."""
    return np.dtype(np.uint8) if stages.prefilter == "xsobel" else np.dtype(dtype)


def penalties(stages, cost, window, dtype):
    """Semi-global matching's (P1, P2) for images of ``dtype`` (as compared: see
    compared_dtype): as given, else scaled to the cost and window
    (kernels.sgm.default_penalties); a P2 left to default is at least the P1 given."""
    bits = census_bits(stages.census_window, stages.census_pattern) \
        if cost_named(cost).census else None
    p1, p2 = sgm.default_penalties(cost, window, bits, dtype)
    p1 = p1 if stages.sgm_p1 is None else stages.sgm_p1
    p2 = max(p2, p1) if stages.sgm_p2 is None else stages.sgm_p2
    return p1, p2


def confidence_map(min_cost, second, valid, threads=None):
    """float32 (H, W): (second - best) / second, 0..1; 0 where invalid or no second (one
    compiled pass: kernels.filters.confidence)."""
    return filters.confidence(min_cost, second, valid, threads)


class CandidateCounts:
    """``evaluated`` and ``candidates`` of a match, whole or striped, and what CSW saved
    of them (the pipeline's Work, csw.Result and csw.TiledResult share it; the kernels'
    MatchResult, a layer below, has its own)."""

    @property
    def work_saved(self):
        """Share (0..1) of plain matching's candidate costs that CSW skipped."""
        return 1.0 - self.evaluated / self.candidates if self.candidates else 0.0


@dataclass
class Work(CandidateCounts):
    """What a run's kernels did, beside its maps (arrays the caller owns).

    min_cost: int64 (H, W), the minimum cost m at the chosen d, -1 where no candidate.
    evaluated: candidates (pixel, d) whose cost was evaluated; candidates: those plain
    matching evaluates on the same rows.
    """

    min_cost: np.ndarray
    evaluated: int
    candidates: int



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
    give exactly the whole image's rows: half the window, and each stage's own
    (csw.matching.stages: half the census window, one for the x-Sobel)."""
    return window // 2 + sum(stage.input_rows(stages) for stage in active(stages, cost))


def filter_overlap(stages):
    """Rows of disparity above and below a stripe that make :func:`filter_map` exact on
    it: each 2-D filter's own (csw.matching.stages)."""
    return sum(stage.map_rows(stages) for stage in active(stages, None, "filter"))


def is_row_local(stages):
    """Whether :func:`filter_map` works row by row (no speckle filter, no median)."""
    return filter_overlap(stages) == 0


@dataclass
class _StageInputs:
    """What the checks and subpixel read: the left image (as given), the kernels'
    MatchResult, the stages, the window, the rows matched (None: all) and the integer
    map's invalid value (kernels.invalid)."""

    left: np.ndarray
    raw: object
    stages: object
    window: int
    rows: np.ndarray | None
    invalid: int


def match_rows(left, right, kernel_args, stages, confidence=False, workspace=None):
    """The row-local stages: costs, CSW, the validity checks and subpixel.  Returns
    (disparity float32 (H, W) NaN invalid, confidence float32 (H, W) or None, Work);
    row y depends only on input rows y +- :func:`row_overlap`.  workspace: see
    :func:`run`."""
    cost = kernel_args["cost"]
    a, b = left, right
    for stage in active(stages, cost, "images"):
        a, b = stage.step(a, b, stages)
    rows = kernel_args.get("rows")
    shape = (left.shape[0] if rows is None else len(rows), left.shape[1])
    into = None if workspace is None else {  # the integer maps, used only here
        "disparity": workspace.empty("disparity", shape, np.int32),
        "lr_valid": workspace.empty("lr-valid", shape, np.uint8)}
    options = dict(census_window=stages.census_window, census_pattern=stages.census_pattern,
                   extras=confidence or needs_extras(stages, cost), lr_check=stages.lr_check,
                   workspace=workspace, into=into)
    if stages.aggregate == "sgm":
        p1, p2 = penalties(stages, cost, kernel_args["window"], a.dtype)
        starts = None
        if stages.sgm_narrow:
            starts = narrow.starts(a, b, dmin=kernel_args["dmin"], dmax=kernel_args["dmax"],
                                   slots=stages.sgm_narrow, threads=kernel_args.get("threads"),
                                   window=kernel_args["window"], cost=cost,
                                   paths=stages.sgm_paths, p1=p1, p2=p2,
                                   census_window=stages.census_window,
                                   census_pattern=stages.census_pattern,
                                   workspace=workspace)
        raw = sgm.match_sgm(a, b, paths=stages.sgm_paths, p1=p1, p2=p2, starts=starts,
                            slots=None if starts is None else stages.sgm_narrow,
                            second=makes_second(stages, cost, confidence), **options,
                            **kernel_args)
    else:
        raw = kernels.match(a, b, **options, **kernel_args)
    invalid = kernels.invalid(kernel_args["dmin"])
    checks, shifts = active(stages, cost, "check"), active(stages, cost, "disparity")
    threads = kernel_args.get("threads")
    names = [stage.name for stage in checks]
    if raw.second_cost is None and not shifts and names in ([], ["lr_check"],
                                                            ["winner_check"]):
        # One left-right check, if any, and no confidence: the float map in one pass.
        mask = raw.lr_valid if names == ["lr_check"] else None
        if names == ["winner_check"]:
            mask = filters.winners_consistent(
                raw.disparity, raw.min_cost, stages.winner_check, invalid, threads,
                out=kernels.workspace.empty(workspace, "winners-valid",
                                            raw.disparity.shape, np.uint8))
        disp = filters.as_float(raw.disparity, mask, invalid, threads=threads,
                                workspace=workspace)
        return disp, None, Work(raw.min_cost, raw.evaluated, raw.candidates)
    valid = np.not_equal(raw.disparity, invalid,
                         out=kernels.workspace.empty(workspace, "valid", raw.disparity.shape,
                                                     np.bool_))
    run = _StageInputs(left, raw, stages, kernel_args["window"], rows, invalid)
    for stage in checks:
        valid &= stage.step(run)
    # The float map in one pass: moved by subpixel where it runs (the one stage that
    # moves disparities), NaN where a check failed.  (NumPy took a pass an operation,
    # each into a fresh array whose pages fault in: 13 ms of subpixel at KITTI's size.)
    if shifts:
        (shift,) = shifts
        disp = shift.step(run, valid, threads)
    else:
        disp = filters.as_float(raw.disparity, valid, invalid, threads=threads)
    # None when the second-best costs were not computed: no confidence to give.
    conf = None if raw.second_cost is None else confidence_map(raw.min_cost, raw.second_cost,
                                                               valid, threads)
    return disp, conf, Work(raw.min_cost, raw.evaluated, raw.candidates)


def filter_map(disp, conf, stages, workspace=None, threads=None):
    """The 2-D stages on :func:`match_rows`' maps: speckle removal, the median, then the
    background fill; the confidence is 0 wherever the filters left no disparity.  Returns
    (disparity, confidence), float32 (H, W); ``disp`` may be changed in place, and a
    ``conf`` of None stays None.  workspace: see :func:`run`; threads: as for csw.match."""
    filters = active(stages, None, "filter")
    for stage in filters:
        if not stage.fills:
            disp = stage.step(disp, stages, workspace, threads)
    if conf is not None and not is_row_local(stages):
        # Filters only remove pixels (the median keeps the valid set), so masking the
        # confidence afterwards equals computing it on the filtered map.
        conf = np.where(np.isfinite(disp), conf, np.float32(0))
    for stage in filters:
        if stage.fills:
            disp = stage.step(disp, stages, workspace, threads)
    return disp, conf

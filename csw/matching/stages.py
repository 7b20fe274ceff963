"""The pipeline's stages, each one record (:class:`Stage`): the options it owns, when it
is on, the rows of margin it adds around a stripe, the bytes per pixel the stripe
planner counts for it, the compiled entries it loads, and its step.  The pipeline
(csw.matching.pipeline) runs the steps in this order; the stripe planner
(csw.scale.tiled.plan) sums the margins and bytes; the set-up loads the entries.  Every
stage is off in the paper's contract (csw.config.params.OFF).
"""

import functools
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..config.params import OFF_STAGES
from ..kernels import prefilter
from ..kernels.contract import census_dtype
from ..kernels.filters import (
    fill_background,
    median_valid,
    speckle_mask,
    subpixel,
    winners_consistent,
)

# Rows of input a stripe takes beyond its own for semi-global paths (see STAGES).
SGM_MARGIN = 64


def _none(stages):
    return 0


@dataclass(frozen=True)
class Stage:
    """One stage of the pipeline.

    options: the option names it owns (csw.config.params.OPTIONS has their help).
    kind: where its step runs: "images" (on the pair, before the costs), "costs" (the
        kernels apply it: no step here), "check" (a validity mask from the kernels'
        maps), "disparity" (the float map from the kernels' and the checks' mask, row
        by row), "filter" (the map, in 2-D).
    on(stages, cost): whether it runs.
    input_rows(stages): rows of input it needs beyond a stripe's (row-local stages).
    map_rows(stages): rows of the map it needs beyond a stripe's (2-D filters).
    band_bytes(stages): bytes per band pixel it adds to the first pass (the kernels'
        pass); map_bytes: to the second (the 2-D filters').
    extras: it needs the kernels' neighbour costs; second: and their second best.
    entries: the compiled kernel entries it loads beyond the engine's.
    step: its step, with the arguments of its kind (see csw.matching.pipeline).
    fills: it gives invalid pixels a value (the confidence is masked before it).
    """

    name: str
    options: tuple
    kind: str
    on: Callable
    step: Callable | None = None
    input_rows: Callable = _none
    map_rows: Callable = _none
    band_bytes: Callable = _none
    map_bytes: int = 0
    extras: bool = False
    second: bool = False
    entries: tuple = ()
    fills: bool = False


def xsobel(image, cap):
    """StereoBM's prefilter: the 3x3 x-Sobel response, clipped to [-cap, cap] and offset
    by cap, as uint8 (H, W); edge-replicated borders (one compiled pass:
    kernels/prefilter.py)."""
    return prefilter.xsobel(image, cap)


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


def distinct(min_cost, second, ratio):
    """bool (H, W): no candidate 2 or more away costs <= best * (1 + ratio/100)."""
    return (second < 0) | (second * 100 > min_cost * (100 + ratio))


def textured(left, window, cap, threshold):
    """bool (H, W): the window's summed |x-Sobel| (capped at cap) reaches threshold."""
    response = np.abs(xsobel(left, cap).astype(np.int64) - cap)
    return box_sum(response, window) >= threshold


# ---------------------------------------------------------------------------- the steps
# images: (left, right, stages) -> (left, right).  check: (run) -> bool mask, run being
# the pipeline's record of the kernels' maps.  disparity: (run, valid, threads) ->
# the float32 map, NaN where valid (the checks' mask) is False.
# filter: (disp, stages, workspace, threads) -> disp.

def _prefilter(left, right, stages):
    cap = int(stages.prefilter_cap)
    return xsobel(left, cap), xsobel(right, cap)


def _lr_check(run):
    return run.raw.lr_valid


def _winners(run):
    return winners_consistent(run.raw.disparity, run.raw.min_cost, run.stages.winner_check,
                              run.invalid)


def _uniqueness(run):
    return distinct(run.raw.min_cost, run.raw.second_cost, run.stages.uniqueness_ratio)


def _texture(run):
    mask = textured(run.left, run.window, int(run.stages.prefilter_cap),
                    run.stages.texture_threshold)
    return mask if run.rows is None else mask[run.rows]


def _subpixel(run, valid, threads):
    raw = run.raw
    return subpixel(raw.disparity, raw.min_cost, raw.prev_cost, raw.next_cost, valid,
                    run.stages.subpixel, threads)


def _speckle(disp, stages, workspace, threads):
    disp = np.ascontiguousarray(disp, np.float32)  # cleared in place
    speckle_mask(disp, int(stages.speckle_size), float(stages.speckle_range), workspace,
                 threads, clear=True)
    return disp


def _median(disp, stages, workspace, threads):
    return median_valid(disp, int(stages.median), threads)


def _fill(disp, stages, workspace, threads):
    return fill_background(disp, threads)


def _census_bytes(stages):
    """The two images' codes, and the transform's padded copy of an image."""
    return 2 * np.dtype(census_dtype(stages.census_window, stages.census_pattern)).itemsize + 8


STAGES = (
    Stage("prefilter", ("prefilter", "prefilter_cap"), "images",
          on=lambda st, cost: st.prefilter == "xsobel", step=_prefilter,
          input_rows=lambda st: 1, band_bytes=lambda st: 24),
    Stage("census", ("census_window", "census_pattern"), "costs",
          on=lambda st, cost: cost == "census",
          input_rows=lambda st: int(st.census_window) // 2, band_bytes=_census_bytes),
    # Semi-global matching aggregates the costs in the kernels (kernels/sgm.py).  Its
    # paths cross every row, so a stripe's rows are exact only with the whole image's
    # beside them: the stripe planner keeps SGM_MARGIN rows each side and
    # reports/scale.md measures what that leaves different.  Its band's slabs are its
    # own, within kernels.sgm.BAND_BYTES.
    Stage("sgm", ("aggregate", "sgm_paths", "sgm_p1", "sgm_p2", "sgm_narrow"), "costs",
          on=lambda st, cost: st.aggregate == "sgm",
          input_rows=lambda st: SGM_MARGIN),
    Stage("lr_check", ("lr_check",), "check",
          on=lambda st, cost: st.lr_check is not None, step=_lr_check,
          band_bytes=lambda st: 8),
    Stage("winner_check", ("winner_check",), "check",
          on=lambda st, cost: st.winner_check is not None, step=_winners,
          band_bytes=lambda st: 1, entries=(("filters", ("winners",)),)),
    Stage("uniqueness_ratio", ("uniqueness_ratio",), "check",
          on=lambda st, cost: st.uniqueness_ratio is not None, step=_uniqueness,
          extras=True, second=True),
    # The x-Sobel row beyond a stripe is the prefilter's too, when both run.
    Stage("texture_threshold", ("texture_threshold",), "check",
          on=lambda st, cost: st.texture_threshold is not None, step=_texture,
          input_rows=lambda st: 0 if st.prefilter == "xsobel" else 1,
          band_bytes=lambda st: 32),
    Stage("subpixel", ("subpixel",), "disparity",
          on=lambda st, cost: st.subpixel != "none", step=_subpixel, extras=True,
          entries=(("filters", ("subpixel",)),)),
    # A region under S = speckle_size pixels spans at most S - 1 rows beyond any of its
    # pixels; a larger one has S of its pixels within S - 1 rows (its first S pixels in a
    # breadth-first walk), so S - 1 rows decide every region as the whole map does.
    Stage("speckle", ("speckle_size", "speckle_range"), "filter",
          on=lambda st, cost: st.speckle_size > 0, step=_speckle,
          map_rows=lambda st: int(st.speckle_size) - 1 if st.speckle_size > 1 else 0,
          map_bytes=26, entries=(("filters", ("speckle",)),)),
    # Half its side more, of rows the speckle filter got right.
    Stage("median", ("median",), "filter", on=lambda st, cost: st.median > 0,
          step=_median, map_rows=lambda st: int(st.median) // 2, map_bytes=4,
          entries=(("filters", ("median",)),)),
    Stage("fill", ("fill",), "filter", on=lambda st, cost: st.fill == "background",
          step=_fill, entries=(("filters", ("fill",)),), fills=True),
)

# The first pass's bytes per band pixel beside the stages': the pair, the kernels' maps
# and masks; the second-best and neighbour costs where a stage needs them; colour rows
# converted; and the second pass's: the map and the confidence.  From peak RSS measured
# on 4000-wide pairs with a margin; tests/library/test_tiled.py checks a real run.
BAND_BYTES = {"base": 48, "extras": 32, "colour": 40}
MAP_BYTES = {"base": 16, "confidence": 8}


@functools.lru_cache(maxsize=256)  # a stream asks on every frame; Stages are frozen
def active(stages, cost, kind=None):
    """The stages that run with these options (of ``kind``, if given), in order (a
    tuple)."""
    return tuple(s for s in STAGES if s.on(stages, cost) and kind in (None, s.kind))


def cost_shaping(stages):
    """Only the stages that shape the costs (the pre-filter, the census), the rest off:
    what tau auto's sample of plain matching runs with, since the checks and the
    filters don't change the minimum costs."""
    shaping = {name: getattr(stages, name) for stage in STAGES
               if stage.kind in ("images", "costs") for name in stage.options}
    return replace(OFF_STAGES, **shaping)


def needs_extras(stages, cost=None):
    """Whether the kernels must make the second-best and neighbour costs."""
    return any(s.extras for s in active(stages, cost))


def needs_second(stages, cost=None):
    """Whether a stage reads the second-best costs (the local engines make them with the
    neighbours' in any case; semi-global matching only when asked)."""
    return any(s.second for s in active(stages, cost))

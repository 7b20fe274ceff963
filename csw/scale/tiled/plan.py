"""How a pair is cut into row stripes: the memory model, the plan, and the rows each
stripe reads.

Rows are independent in CSW, so a stripe read with the rows above and below that the
windows reach gives exactly the rows of a whole-image match (:func:`csw.matching.pipeline.
row_overlap`).  Semi-global matching's paths cross every row: its stripes take
csw.matching.stages.SGM_MARGIN rows more each side, and a few pixels near their edges
may differ from the whole image's (reports/sgm.md measures how many).

The speckle filter and the median look across rows: when they are on, a
second pass reads the first pass's map back with the rows they need
(:func:`csw.matching.pipeline.filter_overlap`), which makes them exact too.
"""

import math
import re
from dataclasses import dataclass

from ...io.formats import TIFF_TILE
from ...io.sources import open_source
from ...kernels import runtime, sgm
from ...matching.disparity_range import assumed_range
from ...matching.narrow import narrows
from ...matching.pipeline import filter_overlap, row_overlap
from ...matching.stages import BAND_BYTES, MAP_BYTES, active, needs_extras

DEFAULT_MEMORY_LIMIT = 512 * 2**20  # the stripes' working memory, per process



class MemoryLimitError(ValueError):
    """The memory limit is below what one stripe needs; the message says how much."""


@dataclass
class Plan:
    """How a pair is cut: core stripes of ``stripe_rows`` rows (the last may be shorter),
    each read with ``row_overlap`` input rows and ``filter_overlap`` map rows beyond, and
    at least ``window`` input rows (the kernels' minimum).  ``paired_rows``: a half-size
    pass (semi-global matching's narrowed search) averages rows 2k and 2k + 1, so each
    stripe's input starts at an even row and holds whole pairs (but at an odd image's
    last row, which the half-size pass leaves out as the whole image's does)."""

    height: int
    width: int
    stripe_rows: int
    row_overlap: int
    filter_overlap: int
    bytes_per_stripe: int
    window: int = 1
    paired_rows: bool = False

    @property
    def stripes(self):
        """[(start, stop)] of the core stripes, top to bottom."""
        return [(s, min(s + self.stripe_rows, self.height))
                for s in range(0, self.height, self.stripe_rows)]

    @property
    def overhead(self):
        """Extra rows matched for the overlaps, as a share of the image's rows."""
        band = sum(b1 - b0 for b0, b1 in (input_band(s, self) for s in self.stripes))
        return band / self.height - 1.0


def parse_size(text):
    """Bytes from "512MB", "2GiB", "1.5G" or a number of bytes; ValueError otherwise."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return int(text)
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([kKmMgGtT]?)(i?)[bB]?\s*", str(text))
    if not match:
        raise ValueError(f"memory limit must be a size such as 512MB or 2GiB, got {text!r}")
    number, unit, binary = match.groups()
    base = 1024 if binary or not unit else 1000
    power = " KMGT".index(unit.upper()) if unit else 0
    return int(float(number) * base ** power)


def _mb(n):
    return f"{math.ceil(n / 2**20)} MiB"


def stripe_bytes(config, width, dmin, dmax, threads, colour=False):
    """(bytes per band row in pass 1, bytes per band row in pass 2, fixed bytes): the
    memory model the plan follows.  The fixed part is the fast engine's per-thread cost
    columns, (W + window) x (D + 1) accumulators of up to 8 bytes."""
    st, running = config.stages, active(config.stages, config.cost)
    p1 = BAND_BYTES["base"] + sum(stage.band_bytes(st) for stage in running)
    p1 += BAND_BYTES["extras"] if needs_extras(st, config.cost) else 0
    p1 += BAND_BYTES["colour"] if colour else 0
    p2 = MAP_BYTES["base"] + MAP_BYTES["confidence"] + sum(s.map_bytes for s in running)
    ndisp = dmax - dmin + 1
    fixed = threads * (width + config.window) * (ndisp + 1) * 8 \
        if config.engine == "fast" else threads * (width + ndisp) * 32
    return p1 * width, p2 * width, fixed


def plan(height, width, config, memory_limit=None, stripe_rows=None, threads=None,
         colour=False, resident=0):
    """The stripes for a pair under a memory limit (bytes for the stripes' working data,
    on top of the process itself), or of ``stripe_rows`` rows when given.  colour: the
    sources convert colour rows; resident: bytes the sources hold throughout.
    MemoryLimitError when one stripe of the smallest useful height does not fit."""
    memory_limit = DEFAULT_MEMORY_LIMIT if memory_limit is None else memory_limit
    st = config.stages
    over = row_overlap(st, config.window, config.cost)
    fover = filter_overlap(st)
    threads = threads or runtime.thread_count(config.threads)
    per_row1, per_row2, fixed = stripe_bytes(config, width, config.dmin, config.dmax,
                                             threads, colour)
    fixed += resident

    # Writing the output reads the stores TIFF_TILE rows at a time, with a padded copy
    # and the invalid-value conversion beside them.
    writing = resident + 4 * TIFF_TILE * width * 4

    # The pipeline's own decision (csw.matching.narrow) whether a half-size pass runs.
    paired = st.aggregate == "sgm" and narrows(st.sgm_narrow, config.dmin, config.dmax,
                                               width)

    def need(rows):  # peak bytes of a stripe of ``rows`` core rows
        band1 = min(height, rows + 2 * over + (2 if paired else 0))  # see input_band
        band2 = min(height, rows + 2 * fover) if fover else 0
        aggregated = sgm.memory(band1, width, config.dmax - config.dmin + 1, config.window,
                                st.sgm_paths, threads) if st.aggregate == "sgm" else 0
        return max(fixed + aggregated + per_row1 * band1, resident + per_row2 * band2,
                   writing)

    smallest = min(height, config.window)
    if stripe_rows is None:
        if need(smallest) > memory_limit:
            raise MemoryLimitError(
                f"a memory limit of {_mb(memory_limit)} is below what one stripe needs "
                f"({_mb(need(smallest))} for a {width}-pixel-wide pair with these options); "
                f"raise the memory limit to at least that")
        rows, most = smallest, height  # the tallest stripe that fits: need() only grows
        while rows < most:
            middle = (rows + most + 1) // 2
            rows, most = (middle, most) if need(middle) <= memory_limit else (rows, middle - 1)
    else:
        rows = int(stripe_rows)
        if rows < 1:
            raise ValueError(f"stripe_rows must be at least 1, got {rows}")
        rows = min(rows, height)
    return Plan(height, width, rows, over, fover, need(rows), config.window, paired)


def too_big_for_whole(left, config, memory_limit=None):
    """Whether matching the pair whole with the resolved options ``config`` would need more
    than ``memory_limit`` (default: DEFAULT_MEMORY_LIMIT), by the stripes' memory model
    for one stripe the image's height; reads only the header of ``left`` (a path)."""
    memory_limit = DEFAULT_MEMORY_LIMIT if memory_limit is None else memory_limit
    source = open_source(left, "left", probe=False, can_stripe=True)
    height, width = source.shape
    config = assumed_range(config, width)  # not known yet: csw's one stand-in
    whole = plan(height, width, config, stripe_rows=height, colour=source.colour)
    return whole.bytes_per_stripe > memory_limit


def input_band(stripe, plan):
    """(first, end) input rows that stripe (start, stop) is matched from: the overlap each
    side, within the image, grown to at least one window (the kernels refuse fewer rows;
    rows beyond the overlap change nothing, they are only more context), and to whole
    pairs of rows where the plan's half-size pass pairs them.  (A stripe read from an
    odd row averaged other rows than the whole image's half-size pass does, and its
    narrowed search differed far from its edges: 0.34% of a 2000 x 2000 pair's pixels
    in two stripes, against 0.003% with the rows paired.)"""
    start, stop = stripe
    first = max(0, start - plan.row_overlap)
    end = min(plan.height, stop + plan.row_overlap)
    while end - first < min(plan.window, plan.height):
        first, end = max(0, first - 1), min(plan.height, end + 1)
    if plan.paired_rows:
        first -= first % 2
        end = min(plan.height, end + (end - first) % 2)
    return first, end


def map_band(stripe, plan):
    """(first, end) rows of the first pass's map that the 2-D filters read for a stripe."""
    start, stop = stripe
    return max(0, start - plan.filter_overlap), min(plan.height, stop + plan.filter_overlap)



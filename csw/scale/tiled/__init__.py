"""Pairs bigger than memory: one pair matched in row stripes, here or on a Dask cluster,
with the whole-image map bit for bit.

  plan    how a pair is cut: the memory model, the stripes and the rows each one reads
  tasks   the stripe tasks of both passes, and the zarr stores they write
  run     csw.match_tiled: prepare, run the tasks, write the outputs
"""

from .plan import DEFAULT_MEMORY_LIMIT, MemoryLimitError, Plan, parse_size, too_big_for_whole
from .run import TiledResult, match_tiled

__all__ = ["DEFAULT_MEMORY_LIMIT", "MemoryLimitError", "Plan", "TiledResult", "match_tiled",
           "parse_size", "too_big_for_whole"]

"""csw's Numba kernels: window matching with and without the Constrained Sliding Window.

Installed as ``csw.kernels`` (the folder is ``kernels/`` in the source tree). Engines are
siblings that compute one contract (see docs/engines.md, "The matching contract"):
  window  full w x w sums per candidate, the paper's method (.window)
  fast    running sums, O(1) per (pixel, disparity), after OpenCV's StereoBM (.fast)

These are the bare kernels: every matching parameter is given explicitly.  ``csw.match``
is the entry with the user-facing defaults.
"""

from . import contract
from .contract import COSTS, ENGINE_NAMES, INVALID, RULES, MatchResult, candidate_count
from .fast import match_fast
from .window import match_window

ENGINES = dict(zip(ENGINE_NAMES, (match_fast, match_window), strict=True))


def match(left, right, *, engine, **options):
    """Match with the named engine; options as for :func:`.window.match_window`."""
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    return ENGINES[engine](left, right, **options)


__all__ = ["COSTS", "ENGINES", "INVALID", "RULES", "MatchResult", "candidate_count", "contract",
           "match", "match_fast", "match_window"]
